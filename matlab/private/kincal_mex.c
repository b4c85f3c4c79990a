/*
 * kincal_mex: the one MEX gateway of the kincal Matlab/Octave toolbox.
 *
 *     varargout = kincal_mex(OPERATION, args...)
 *
 * Users never call it: it lives in matlab/private/ and the public kincal_*.m wrappers (help
 * text, M-side argument checks) call it. It only marshals: every number is computed by the
 * Rust library through the C ABI (include/kincal.h), linked in statically.
 *
 * Structure (osqp-matlab, mexplus):
 * - one dispatch table OPERATIONS of {name, handler, nrhs, nlhs}; the argument count is exact
 *   (wrappers pass [] for defaults), outputs up to nlhs;
 * - one set of marshalling helpers (get_real_matrix, get_poses, get_robot, ...) that check
 *   class double, real, dense, finite and the sizes, and name the argument in the message;
 * - one place that turns a kincal_status into an error identifier `kincal:<statusName>`
 *   (KINCAL_STATUS_BAD_LENGTH -> kincal:badLength) plus the gateway's own kincal:badSize,
 *   kincal:badClass, kincal:nonFinite, kincal:badValue, kincal:missingField,
 *   kincal:unknownField, kincal:badArgCount, kincal:unknownOperation, kincal:abiMismatch;
 * - one helper (one_based) that turns the library's zero-based joint/pose/index numbers
 *   into the 1-based numbers Matlab users see, one (zero_based_index) for the other way.
 *
 * Error flow (style anchors section 10): a handler never raises. It records the failure in a
 * kc_fail and returns; Rust has returned by then and every buffer is either on the C stack or
 * an mxArray. mexFunction then destroys the outputs made so far and only then calls
 * mexErrMsgIdAndTxt. Nothing is kept between calls (no handles, no static state).
 *
 * Builds with Matlab's `mex` (either API: -R2017b or -R2018a) and Octave's
 * `mkoctfile --mex`; see make_kincal.m.
 */

#include "mex.h"

#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <string.h>

#include "kincal.h"

#if defined(MX_HAS_INTERLEAVED_COMPLEX) && MX_HAS_INTERLEAVED_COMPLEX
#define KC_DOUBLES(a) mxGetDoubles(a)
#else
#define KC_DOUBLES(a) mxGetPr(a)
#endif

/* Any size along this dimension. */
#define KC_ANY ((size_t)-1)

/* ------------------------------------------------------------------------------------------ */
/* Failure record                                                                             */
/* ------------------------------------------------------------------------------------------ */

typedef struct kc_fail {
    char id[64];
    char msg[1024];
} kc_fail;

/* Largest number of scratch buffers one operation allocates. */
#define KC_MAX_BUFFERS 24

/* The state of one gateway call: the operation's name (for messages, "kincal_fk: ..."), the
 * failure record, and the scratch buffers the handler allocated (kc_alloc), which mexFunction
 * frees after the handler returns, before it raises any error. */
typedef struct kc_ctx {
    const char *op;
    kc_fail fail;
    void *buffers[KC_MAX_BUFFERS];
    int n_buffers;
} kc_ctx;

/* Records a failure with identifier `id` (without the "kincal:" prefix); returns -1. */
static int fail(kc_ctx *c, const char *id, const char *fmt, ...)
{
    va_list ap;
    int n;
    snprintf(c->fail.id, sizeof c->fail.id, "kincal:%s", id);
    n = snprintf(c->fail.msg, sizeof c->fail.msg, "kincal_%s: ", c->op);
    if (n < 0 || (size_t)n >= sizeof c->fail.msg) {
        n = 0;
    }
    va_start(ap, fmt);
    vsnprintf(c->fail.msg + n, sizeof c->fail.msg - (size_t)n, fmt, ap);
    va_end(ap);
    return -1;
}

/* Scratch memory for one call, freed by mexFunction when the handler returns (success or
 * failure). NULL (with a failure recorded) when the table of buffers is full. */
static void *kc_alloc(kc_ctx *c, size_t bytes)
{
    void *p;
    if (c->n_buffers >= KC_MAX_BUFFERS) {
        fail(c, "internal", "too many scratch buffers (a bug in kincal_mex.c)");
        return NULL;
    }
    p = mxCalloc(bytes > 0 ? bytes : 1, 1);
    c->buffers[c->n_buffers++] = p;
    return p;
}

static void kc_free_all(kc_ctx *c)
{
    while (c->n_buffers > 0) {
        mxFree(c->buffers[--c->n_buffers]);
    }
}

/* Appends to the message of a recorded failure. */
static void fail_append(kc_ctx *c, const char *fmt, ...)
{
    va_list ap;
    size_t n = strlen(c->fail.msg);
    if (n + 1 >= sizeof c->fail.msg) {
        return;
    }
    va_start(ap, fmt);
    vsnprintf(c->fail.msg + n, sizeof c->fail.msg - n, fmt, ap);
    va_end(ap);
}

/* The 1-based number a Matlab user sees for a zero-based joint, pose, link or parameter
 * index of the C ABI. The only place where the index base changes on the way out. */
static double one_based(size_t zero_based)
{
    return (double)zero_based + 1.0;
}

/* Identifier of a status: "KINCAL_STATUS_BAD_LENGTH: ..." -> "badLength" (lower camel case of
 * the C name), taken from kincal_status_str so new codes get identifiers without edits here. */
static void status_identifier(uint32_t status, char *out, size_t out_len)
{
    static const char prefix[] = "KINCAL_STATUS_";
    const char *s = kincal_status_str(status);
    size_t k = 0;
    int upper = 0;
    if (out_len == 0) {
        return;
    }
    if (s == NULL || strncmp(s, prefix, sizeof prefix - 1) != 0) {
        snprintf(out, out_len, "unknownStatus");
        return;
    }
    for (s += sizeof prefix - 1; *s != '\0' && *s != ':' && k + 1 < out_len; ++s) {
        char ch = *s;
        if (ch == '_') {
            upper = 1;
            continue;
        }
        if (ch >= 'A' && ch <= 'Z' && !upper) {
            ch = (char)(ch - 'A' + 'a');
        }
        upper = 0;
        out[k++] = ch;
    }
    out[k] = '\0';
}

/* The explanation part of kincal_status_str ("...: explanation"). */
static const char *status_explanation(uint32_t status)
{
    const char *s = kincal_status_str(status);
    const char *colon = s ? strchr(s, ':') : NULL;
    if (colon == NULL) {
        return s ? s : "unknown kincal status code";
    }
    ++colon;
    while (*colon == ' ') {
        ++colon;
    }
    return colon;
}

static const char *quantity_name(uint32_t q)
{
    switch (q) {
    case KINCAL_QUANTITY_JOINT_READING: return "joint reading";
    case KINCAL_QUANTITY_PARAMETER: return "parameter";
    case KINCAL_QUANTITY_POSITION: return "position";
    case KINCAL_QUANTITY_ORIENTATION: return "orientation";
    case KINCAL_QUANTITY_SETTING: return "setting";
    case KINCAL_QUANTITY_APPROACH_DIRECTION: return "approach direction";
    case KINCAL_QUANTITY_TEMPERATURE: return "temperature";
    default: return NULL;
    }
}

/* The name a Matlab user knows for an argument or field the C ABI names in kincal_error:
 * the measurement arrays by their wrapper names, "opts->x" as "options.x" and any other
 * "s->f" as "s.f" (written into a static buffer: one message at a time). */
static const char *matlab_argument_name(const char *a)
{
    static const struct {
        const char *c_name, *m_name;
    } names[] = {
        {"data->q", "q"},
        {"data->poses", "T"},
        {"data->masks", "components"},
        {"data->aux", "approach/temp_c"},
        {"data->n_poses", "q"},
        {"t_base_tool_out", "T"},
        {"poses", "T"},
    };
    static char buf[96];
    const char *arrow;
    size_t i;
    for (i = 0; i < sizeof names / sizeof names[0]; ++i) {
        if (strcmp(a, names[i].c_name) == 0) {
            return names[i].m_name;
        }
    }
    arrow = strstr(a, "->");
    if (arrow == NULL) {
        return a;
    }
    if (strncmp(a, "opts->", 6) == 0) {
        snprintf(buf, sizeof buf, "options.%s", arrow + 2);
    } else {
        snprintf(buf, sizeof buf, "%.*s.%s", (int)(arrow - a), a, arrow + 2);
    }
    return buf;
}

/* Records a failed library call: identifier kincal:<statusName>, message with the detail of
 * `e` in Matlab terms (1-based joints, poses and indices; "robot->params" -> "robot.params").
 * `what` names the item of a vectorised call (e.g. "column 3 of q"), or NULL. */
static int fail_status(kc_ctx *c, kincal_status st, const kincal_error *e, const char *what)
{
    char id[48];
    status_identifier(st, id, sizeof id);
    fail(c, id, "%s", status_explanation(st));
    if (what != NULL) {
        fail_append(c, " (%s)", what);
    }
    if (e == NULL || e->status != st) {
        return -1;
    }
    if (e->argument != NULL) {
        fail_append(c, "; argument '%s'", matlab_argument_name(e->argument));
    }
    if (quantity_name(e->quantity) != NULL) {
        fail_append(c, "; %s", quantity_name(e->quantity));
    }
    if (e->joint != KINCAL_NO_INDEX) {
        fail_append(c, "; joint %.0f", one_based(e->joint));
    }
    if (e->pose != KINCAL_NO_INDEX) {
        fail_append(c, "; pose %.0f", one_based(e->pose));
    }
    if (e->index != KINCAL_NO_INDEX) {
        fail_append(c, "; element %.0f", one_based(e->index));
    }
    if (e->expected != KINCAL_NO_INDEX) {
        fail_append(c, "; expected %.0f", (double)e->expected);
    }
    if (e->found != KINCAL_NO_INDEX) {
        fail_append(c, "; found %.0f", (double)e->found);
    }
    if (e->value == e->value) {
        fail_append(c, "; value %.15g", e->value);
    }
    if (e->lower == e->lower || e->upper == e->upper) {
        fail_append(c, "; limits [%.15g, %.15g]", e->lower, e->upper);
    }
    if (e->residual_pos_m == e->residual_pos_m || e->residual_rot_rad == e->residual_rot_rad) {
        fail_append(c, "; best residual %.3g m, %.3g rad", e->residual_pos_m, e->residual_rot_rad);
    }
    if (e->iterations != 0) {
        fail_append(c, "; iterations %u", (unsigned)e->iterations);
    }
    return -1;
}

/* ------------------------------------------------------------------------------------------ */
/* Input helpers                                                                              */
/* ------------------------------------------------------------------------------------------ */

static int is_default(const mxArray *a)
{
    return a == NULL || mxIsEmpty(a);
}

static const char *class_of(const mxArray *a)
{
    return mxGetClassName(a);
}

/* A real, dense, finite double array; `finite` 0 skips the finiteness check. */
static int check_double(kc_ctx *c, const mxArray *a, const char *name, int finite)
{
    size_t i, n;
    const double *p;
    if (!mxIsDouble(a) || mxIsComplex(a) || mxIsSparse(a)) {
        return fail(c, "badClass", "argument '%s' must be a real dense double array, got %s%s%s",
                    name, mxIsComplex(a) ? "complex " : "", mxIsSparse(a) ? "sparse " : "",
                    class_of(a));
    }
    if (!finite) {
        return 0;
    }
    n = mxGetNumberOfElements(a);
    p = KC_DOUBLES(a);
    for (i = 0; i < n; ++i) {
        if (!mxIsFinite(p[i])) {
            return fail(c, "nonFinite", "argument '%s' must be finite: element %.0f is %g", name,
                        one_based(i), p[i]);
        }
    }
    return 0;
}

/* Describes the size of `a` as "RxC" or "AxBxC" into buf. */
static const char *size_str(const mxArray *a, char *buf, size_t len)
{
    mwSize nd = mxGetNumberOfDimensions(a);
    const mwSize *d = mxGetDimensions(a);
    size_t k = 0;
    mwSize i;
    buf[0] = '\0';
    for (i = 0; i < nd && k + 24 < len; ++i) {
        int n = snprintf(buf + k, len - k, i ? "x%lu" : "%lu", (unsigned long)d[i]);
        if (n < 0) {
            break;
        }
        k += (size_t)n;
    }
    return buf;
}

static void dim_str(size_t n, char *buf, size_t len)
{
    if (n == KC_ANY) {
        snprintf(buf, len, "M");
    } else {
        snprintf(buf, len, "%lu", (unsigned long)n);
    }
}

/* A real dense finite double matrix of `rows` x `cols` (KC_ANY: any). */
static int get_real_matrix(kc_ctx *c, const mxArray *a, const char *name, size_t rows,
                           size_t cols, const double **out)
{
    char got[64], r[24], k[24];
    if (check_double(c, a, name, 1) != 0) {
        return -1;
    }
    if (mxGetNumberOfDimensions(a) != 2 || (rows != KC_ANY && mxGetM(a) != rows) ||
        (cols != KC_ANY && mxGetN(a) != cols)) {
        dim_str(rows, r, sizeof r);
        dim_str(cols, k, sizeof k);
        return fail(c, "badSize", "argument '%s' must be %sx%s, got %s", name, r, k,
                    size_str(a, got, sizeof got));
    }
    *out = KC_DOUBLES(a);
    return 0;
}

/* A real finite vector of `n` elements (row or column). */
static int get_vector(kc_ctx *c, const mxArray *a, const char *name, size_t n, const double **out)
{
    char got[64];
    if (check_double(c, a, name, 1) != 0) {
        return -1;
    }
    if (mxGetNumberOfDimensions(a) != 2 || mxGetNumberOfElements(a) != n ||
        (mxGetM(a) != 1 && mxGetN(a) != 1)) {
        return fail(c, "badSize", "argument '%s' must be a vector of %lu elements, got %s", name,
                    (unsigned long)n, size_str(a, got, sizeof got));
    }
    *out = KC_DOUBLES(a);
    return 0;
}

static int get_scalar(kc_ctx *c, const mxArray *a, const char *name, double *out)
{
    const double *p;
    if (get_vector(c, a, name, 1, &p) != 0) {
        return -1;
    }
    *out = p[0];
    return 0;
}

/* A scalar holding a non-negative integer no larger than `max`. */
static int get_count(kc_ctx *c, const mxArray *a, const char *name, double max, size_t *out)
{
    double v;
    if (get_scalar(c, a, name, &v) != 0) {
        return -1;
    }
    if (v < 0 || v > max || v != (double)(size_t)v) {
        return fail(c, "badValue", "argument '%s' must be an integer in 0..%.0f, got %.17g", name,
                    max, v);
    }
    *out = (size_t)v;
    return 0;
}

/* A 1-based number from Matlab (1..count) as the zero-based index of the C ABI: the only
 * place where the index base changes on the way in. */
static int zero_based_index(kc_ctx *c, double v, const char *name, size_t count,
                            size_t *zero_based)
{
    if (!(v >= 1 && v <= (double)count) || v != (double)(size_t)v) {
        return fail(c, "indexOutOfRange", "argument '%s' must be an integer in 1..%lu, got %.17g",
                    name, (unsigned long)count, v);
    }
    *zero_based = (size_t)v - 1;
    return 0;
}

/* A stack of 4x4 poses: 4x4 or 4x4xM, real dense finite double. */
static int get_poses(kc_ctx *c, const mxArray *a, const char *name, size_t *m, const double **out)
{
    char got[64];
    mwSize nd;
    const mwSize *d;
    if (check_double(c, a, name, 1) != 0) {
        return -1;
    }
    nd = mxGetNumberOfDimensions(a);
    d = mxGetDimensions(a);
    if (nd > 3 || d[0] != 4 || d[1] != 4) {
        return fail(c, "badSize", "argument '%s' must be 4x4 or 4x4xM, got %s", name,
                    size_str(a, got, sizeof got));
    }
    *m = nd == 3 ? (size_t)d[2] : 1;
    *out = KC_DOUBLES(a);
    return 0;
}

/* A char row vector, copied into buf. */
static int get_string(kc_ctx *c, const mxArray *a, const char *name, char *buf, size_t len)
{
    if (!mxIsChar(a) || (mxGetM(a) > 1 && mxGetNumberOfElements(a) > 0) ||
        mxGetNumberOfDimensions(a) != 2) {
        return fail(c, "badClass", "argument '%s' must be a character row vector, got %s", name,
                    class_of(a));
    }
    if (mxGetNumberOfElements(a) >= len || mxGetString(a, buf, (mwSize)len) != 0) {
        return fail(c, "badSize", "argument '%s' is too long (at most %lu characters)", name,
                    (unsigned long)(len - 1));
    }
    return 0;
}

/* Maps a name to a number through a NULL-terminated table. */
typedef struct kc_name {
    const char *name;
    uint32_t value;
} kc_name;

static int get_choice(kc_ctx *c, const mxArray *a, const char *name, const kc_name *table,
                      uint32_t *out)
{
    char buf[64];
    const kc_name *t;
    if (get_string(c, a, name, buf, sizeof buf) != 0) {
        return -1;
    }
    for (t = table; t->name != NULL; ++t) {
        if (strcmp(t->name, buf) == 0) {
            *out = t->value;
            return 0;
        }
    }
    fail(c, "badValue", "argument '%s': unknown value '%s'; expected one of", name, buf);
    for (t = table; t->name != NULL; ++t) {
        fail_append(c, "%s '%s'", t == table ? "" : ",", t->name);
    }
    return -1;
}

static const mxArray *get_field(kc_ctx *c, const mxArray *s, const char *sname, const char *field)
{
    const mxArray *f = mxGetField(s, 0, field);
    if (f == NULL) {
        fail(c, "missingField", "argument '%s' has no field '%s'", sname, field);
    }
    return f;
}

/* A 1x1 struct whose fields are all in `allowed` (NULL-terminated). */
static int check_struct(kc_ctx *c, const mxArray *s, const char *name, const char *const *allowed)
{
    int i, n;
    if (!mxIsStruct(s) || mxGetNumberOfElements(s) != 1) {
        return fail(c, "badClass", "argument '%s' must be a 1x1 struct, got %s", name,
                    class_of(s));
    }
    if (allowed == NULL) {
        return 0;
    }
    n = mxGetNumberOfFields(s);
    for (i = 0; i < n; ++i) {
        const char *f = mxGetFieldNameByNumber(s, i);
        const char *const *a;
        for (a = allowed; *a != NULL; ++a) {
            if (strcmp(*a, f) == 0) {
                break;
            }
        }
        if (*a == NULL) {
            fail(c, "unknownField", "argument '%s': unknown field '%s'; known fields:", name, f);
            for (a = allowed; *a != NULL; ++a) {
                fail_append(c, " %s", *a);
            }
            return -1;
        }
    }
    return 0;
}

/* A struct field that is a real finite vector of `n` elements, copied into `dst`. */
static int copy_field_vector(kc_ctx *c, const mxArray *s, const char *sname, const char *field,
                             size_t n, double *dst)
{
    char name[96];
    const double *p;
    const mxArray *f = get_field(c, s, sname, field);
    if (f == NULL) {
        return -1;
    }
    snprintf(name, sizeof name, "%s.%s", sname, field);
    if (get_vector(c, f, name, n, &p) != 0) {
        return -1;
    }
    memcpy(dst, p, n * sizeof *dst);
    return 0;
}

/* ------------------------------------------------------------------------------------------ */
/* Robot <-> struct                                                                           */
/* ------------------------------------------------------------------------------------------ */

/* Fields of the robot struct (see kincal_robot.m). `name` and `labels` are informative: they
 * are written on output and ignored on input. */
static const char *const ROBOT_FIELDS[] = {
    "name", "n_joints", "length_param", "joint_kind", "params", "labels", "nominal", "limits",
    "link_masses_kg", "tool_mass_kg", "gravity", NULL,
};

static int get_robot(kc_ctx *c, const mxArray *s, kincal_robot *r)
{
    const char *name = "robot";
    const mxArray *f;
    size_t n, i, np, ng;
    const double *p;
    kincal_error err;
    kincal_status st;

    memset(r, 0, sizeof *r);
    if (check_struct(c, s, name, ROBOT_FIELDS) != 0) {
        return -1;
    }
    if ((f = get_field(c, s, name, "n_joints")) == NULL ||
        get_count(c, f, "robot.n_joints", KINCAL_MAX_JOINTS, &n) != 0) {
        return -1;
    }
    if (n < 1) {
        return fail(c, "badJointCount", "argument 'robot.n_joints' must be 1..%d, got 0",
                    KINCAL_MAX_JOINTS);
    }
    r->n_joints = (uint32_t)n;
    np = kincal_num_params(n);
    ng = kincal_num_geometric_params(n);

    if ((f = get_field(c, s, name, "length_param")) == NULL ||
        get_vector(c, f, "robot.length_param", n, &p) != 0) {
        return -1;
    }
    for (i = 0; i < n; ++i) {
        if (p[i] != 0.0 && p[i] != 1.0) {
            return fail(c, "badValue",
                        "argument 'robot.length_param': link %.0f must be 0 (d) or 1 (beta), "
                        "got %.17g",
                        one_based(i), p[i]);
        }
        r->length_param[i] = (uint32_t)p[i];
    }
    /* Optional (structs written before prismatic joints have none): all revolute. */
    if (mxGetField(s, 0, "joint_kind") != NULL) {
        if ((f = get_field(c, s, name, "joint_kind")) == NULL ||
            get_vector(c, f, "robot.joint_kind", n, &p) != 0) {
            return -1;
        }
        for (i = 0; i < n; ++i) {
            if (p[i] != 0.0 && p[i] != 1.0 && p[i] != 2.0) {
                return fail(c, "badValue",
                            "argument 'robot.joint_kind': joint %.0f must be 0 (revolute), 1 "
                            "(prismatic) or 2 (sensor), got %.17g",
                            one_based(i), p[i]);
            }
            r->joint_kind[i] = (uint32_t)p[i];
        }
    }
    if (copy_field_vector(c, s, name, "params", np, r->params) != 0 ||
        copy_field_vector(c, s, name, "nominal", ng, r->nominal) != 0) {
        return -1;
    }
    if ((f = get_field(c, s, name, "limits")) == NULL ||
        get_real_matrix(c, f, "robot.limits", n, 2, &p) != 0) {
        return -1;
    }
    for (i = 0; i < n; ++i) {
        r->limits_lower[i] = p[i];
        r->limits_upper[i] = p[n + i];
    }
    if (copy_field_vector(c, s, name, "link_masses_kg", n, r->link_masses_kg) != 0 ||
        copy_field_vector(c, s, name, "tool_mass_kg", 1, &r->tool_mass_kg) != 0 ||
        copy_field_vector(c, s, name, "gravity", 3, r->gravity) != 0) {
        return -1;
    }
    st = kincal_robot_validate(r, &err);
    if (st != KINCAL_STATUS_OK) {
        return fail_status(c, st, &err, NULL);
    }
    return 0;
}

static mxArray *column(const double *v, size_t n)
{
    mxArray *a = mxCreateDoubleMatrix((mwSize)n, 1, mxREAL);
    if (n > 0) {
        memcpy(KC_DOUBLES(a), v, n * sizeof *v);
    }
    return a;
}

/* The robot as a struct; `name` is stored as given. */
static int put_robot(kc_ctx *c, const kincal_robot *r, const char *robot_name, mxArray **out)
{
    size_t n = r->n_joints, np = kincal_num_params(n), ng = kincal_num_geometric_params(n), i;
    mxArray *s, *labels, *lp, *lim;
    double *d;
    kincal_error err;
    kincal_status st;

    labels = mxCreateCellMatrix((mwSize)np, 1);
    for (i = 0; i < np; ++i) {
        char label[KINCAL_LABEL_CAPACITY];
        st = kincal_robot_param_label(r, i, label, sizeof label, &err);
        if (st != KINCAL_STATUS_OK) {
            mxDestroyArray(labels);
            return fail_status(c, st, &err, "parameter labels");
        }
        mxSetCell(labels, (mwIndex)i, mxCreateString(label));
    }
    s = mxCreateStructMatrix(1, 1, 0, NULL);
    for (i = 0; ROBOT_FIELDS[i] != NULL; ++i) {
        mxAddField(s, ROBOT_FIELDS[i]);
    }
    mxSetField(s, 0, "name", mxCreateString(robot_name));
    mxSetField(s, 0, "n_joints", mxCreateDoubleScalar((double)n));
    lp = mxCreateDoubleMatrix(1, (mwSize)n, mxREAL);
    d = KC_DOUBLES(lp);
    for (i = 0; i < n; ++i) {
        d[i] = (double)r->length_param[i];
    }
    mxSetField(s, 0, "length_param", lp);
    lp = mxCreateDoubleMatrix(1, (mwSize)n, mxREAL);
    d = KC_DOUBLES(lp);
    for (i = 0; i < n; ++i) {
        d[i] = (double)r->joint_kind[i];
    }
    mxSetField(s, 0, "joint_kind", lp);
    mxSetField(s, 0, "params", column(r->params, np));
    mxSetField(s, 0, "labels", labels);
    mxSetField(s, 0, "nominal", column(r->nominal, ng));
    lim = mxCreateDoubleMatrix((mwSize)n, 2, mxREAL);
    d = KC_DOUBLES(lim);
    for (i = 0; i < n; ++i) {
        d[i] = r->limits_lower[i];
        d[n + i] = r->limits_upper[i];
    }
    mxSetField(s, 0, "limits", lim);
    mxSetField(s, 0, "link_masses_kg", column(r->link_masses_kg, n));
    mxSetField(s, 0, "tool_mass_kg", mxCreateDoubleScalar(r->tool_mass_kg));
    mxSetField(s, 0, "gravity", column(r->gravity, 3));
    *out = s;
    return 0;
}

/* The `name` field of a robot struct, or "" (informative only). */
static void robot_name(const mxArray *s, char *buf, size_t len)
{
    const mxArray *f = mxIsStruct(s) ? mxGetField(s, 0, "name") : NULL;
    buf[0] = '\0';
    if (f != NULL && mxIsChar(f) && mxGetNumberOfElements(f) < len) {
        mxGetString(f, buf, (mwSize)len);
    }
}

/* ------------------------------------------------------------------------------------------ */
/* Joint auxiliary inputs (approach directions, temperature)                                   */
/* ------------------------------------------------------------------------------------------ */

static const char *const AUX_FIELDS[] = {"approach", "temp_c", NULL};

/* `aux` is [] or a struct with optional fields approach (N x M) and temp_c (1 x M). */
typedef struct kc_aux {
    const double *approach; /* N x M or NULL */
    const double *temp_c;   /* 1 x M or NULL */
} kc_aux;

static int get_aux(kc_ctx *c, const mxArray *a, size_t n, size_t m, kc_aux *aux)
{
    const mxArray *f;
    aux->approach = NULL;
    aux->temp_c = NULL;
    if (is_default(a)) {
        return 0;
    }
    if (check_struct(c, a, "aux", AUX_FIELDS) != 0) {
        return -1;
    }
    f = mxGetField(a, 0, "approach");
    if (f != NULL && !is_default(f) &&
        get_real_matrix(c, f, "approach", n, m, &aux->approach) != 0) {
        return -1;
    }
    f = mxGetField(a, 0, "temp_c");
    if (f != NULL && !is_default(f) && get_real_matrix(c, f, "temp_c", 1, m, &aux->temp_c) != 0) {
        return -1;
    }
    return 0;
}

/* The kincal_joint_aux of column j, or NULL when there is nothing to pass. */
static const kincal_joint_aux *aux_at(const kc_aux *aux, size_t n, size_t j, kincal_joint_aux *buf)
{
    size_t i;
    if (aux->approach == NULL && aux->temp_c == NULL) {
        return NULL;
    }
    memset(buf, 0, sizeof *buf);
    if (aux->approach != NULL) {
        buf->has_approach = 1;
        for (i = 0; i < n; ++i) {
            buf->approach[i] = aux->approach[j * n + i];
        }
    }
    if (aux->temp_c != NULL) {
        buf->has_temp = 1;
        buf->temp_c = aux->temp_c[j];
    }
    return buf;
}

static mxArray *create_poses(size_t m)
{
    mwSize dims[3];
    dims[0] = 4;
    dims[1] = 4;
    dims[2] = (mwSize)m;
    return mxCreateNumericArray(3, dims, mxDOUBLE_CLASS, mxREAL);
}

static const char *column_of(char *buf, size_t len, const char *name, size_t j, size_t m)
{
    if (m <= 1) {
        return NULL;
    }
    snprintf(buf, len, "column %.0f of %s", one_based(j), name);
    return buf;
}

/* ------------------------------------------------------------------------------------------ */
/* Operations                                                                                 */
/* ------------------------------------------------------------------------------------------ */

typedef int (*kc_handler)(kc_ctx *c, int nlhs, mxArray *plhs[], const mxArray *prhs[]);

/* version() -> char */
static int op_version(kc_ctx *c, int nlhs, mxArray *plhs[], const mxArray *prhs[])
{
    (void)c;
    (void)nlhs;
    (void)prhs;
    plhs[0] = mxCreateString(kincal_version());
    return 0;
}

/* status_table() -> codes (K x 1), identifiers (K x 1 cell), texts (K x 1 cell): every status
 * the library knows, with the identifier this gateway raises for it. */
static int op_status_table(kc_ctx *c, int nlhs, mxArray *plhs[], const mxArray *prhs[])
{
    uint32_t code;
    size_t k = 0, count = 0;
    double *codes;
    (void)c;
    (void)prhs;
    for (code = 0; code < 1000; ++code) {
        if (strcmp(kincal_status_str(code), "unknown kincal status code") != 0) {
            ++count;
        }
    }
    plhs[0] = mxCreateDoubleMatrix((mwSize)count, 1, mxREAL);
    codes = KC_DOUBLES(plhs[0]);
    if (nlhs > 1) {
        plhs[1] = mxCreateCellMatrix((mwSize)count, 1);
    }
    if (nlhs > 2) {
        plhs[2] = mxCreateCellMatrix((mwSize)count, 1);
    }
    for (code = 0; code < 1000; ++code) {
        const char *s = kincal_status_str(code);
        char id[64] = "kincal:";
        if (strcmp(s, "unknown kincal status code") == 0) {
            continue;
        }
        codes[k] = (double)code;
        status_identifier(code, id + 7, sizeof id - 7);
        if (nlhs > 1) {
            mxSetCell(plhs[1], (mwIndex)k, mxCreateString(id));
        }
        if (nlhs > 2) {
            mxSetCell(plhs[2], (mwIndex)k, mxCreateString(s));
        }
        ++k;
    }
    return 0;
}

static const kc_name ARIA_MODELS[] = {
    {"aria", KINCAL_ARIA_MODEL_NOMINAL},
    {"aria_true", KINCAL_ARIA_MODEL_VIRTUAL_TRUTH},
    {"aria_real", KINCAL_ARIA_MODEL_REAL_IDENTIFIED},
    {NULL, 0},
};

/* robot_aria(name) -> robot */
static int op_robot_aria(kc_ctx *c, int nlhs, mxArray *plhs[], const mxArray *prhs[])
{
    uint32_t model;
    kincal_robot r;
    kincal_error err;
    kincal_status st;
    char name[32];
    (void)nlhs;
    if (get_choice(c, prhs[0], "name", ARIA_MODELS, &model) != 0) {
        return -1;
    }
    st = kincal_robot_aria(&r, model, &err);
    if (st != KINCAL_STATUS_OK) {
        return fail_status(c, st, &err, NULL);
    }
    get_string(c, prhs[0], "name", name, sizeof name);
    return put_robot(c, &r, name, &plhs[0]);
}

/* robot_check(robot) -> robot: validates a struct and returns it with fresh labels */
static int op_robot_check(kc_ctx *c, int nlhs, mxArray *plhs[], const mxArray *prhs[])
{
    kincal_robot r;
    char name[64];
    (void)nlhs;
    if (get_robot(c, prhs[0], &r) != 0) {
        return -1;
    }
    robot_name(prhs[0], name, sizeof name);
    return put_robot(c, &r, name, &plhs[0]);
}

/* robot_init(links N x 5, limits N x 2, name) -> robot */
static int op_robot_init(kc_ctx *c, int nlhs, mxArray *plhs[], const mxArray *prhs[])
{
    const double *links, *limits;
    double links_rm[5 * KINCAL_MAX_JOINTS], limits_rm[2 * KINCAL_MAX_JOINTS];
    size_t n, i, k;
    char name[64];
    kincal_robot r;
    kincal_error err;
    kincal_status st;
    (void)nlhs;
    if (get_real_matrix(c, prhs[0], "links", KC_ANY, 5, &links) != 0) {
        return -1;
    }
    n = mxGetM(prhs[0]);
    if (n < 1 || n > KINCAL_MAX_JOINTS) {
        return fail(c, "badJointCount", "argument 'links' must have 1..%d rows, got %lu",
                    KINCAL_MAX_JOINTS, (unsigned long)n);
    }
    if (get_real_matrix(c, prhs[1], "limits", n, 2, &limits) != 0 ||
        get_string(c, prhs[2], "name", name, sizeof name) != 0) {
        return -1;
    }
    /* Matlab is column-major, the C ABI takes the tables row-major. */
    for (i = 0; i < n; ++i) {
        for (k = 0; k < 5; ++k) {
            links_rm[5 * i + k] = links[k * n + i];
        }
        limits_rm[2 * i] = limits[i];
        limits_rm[2 * i + 1] = limits[n + i];
    }
    st = kincal_robot_init(&r, n, links_rm, 5 * n, limits_rm, 2 * n, &err);
    if (st != KINCAL_STATUS_OK) {
        return fail_status(c, st, &err, NULL);
    }
    return put_robot(c, &r, name, &plhs[0]);
}

/* robot_set(robot, what, value...) -> robot: what = 'base' | 'tool' (1x6 each, current and
 * nominal), 'mass' (value = struct link_masses_kg, tool_mass_kg, gravity), 'limits' (N x 2),
 * 'length_param' (value = [link (1-based), 0|1]), 'adopt_nominal' (value ignored). */
static const kc_name ROBOT_SETTERS[] = {
    {"base", 0}, {"tool", 1}, {"mass", 2}, {"limits", 3}, {"length_param", 4},
    {"adopt_nominal", 5}, {NULL, 0},
};
static const char *const MASS_FIELDS[] = {"link_masses_kg", "tool_mass_kg", "gravity", NULL};

static int op_robot_set(kc_ctx *c, int nlhs, mxArray *plhs[], const mxArray *prhs[])
{
    kincal_robot r;
    kincal_error err;
    kincal_status st = KINCAL_STATUS_OK;
    uint32_t what;
    const double *v;
    char name[64];
    size_t n;
    (void)nlhs;
    if (get_robot(c, prhs[0], &r) != 0 || get_choice(c, prhs[1], "what", ROBOT_SETTERS, &what)) {
        return -1;
    }
    n = r.n_joints;
    switch (what) {
    case 0:
    case 1:
        if (get_vector(c, prhs[2], what == 0 ? "base" : "tool", 6, &v) != 0) {
            return -1;
        }
        st = what == 0 ? kincal_robot_set_base(&r, v, 6, &err)
                       : kincal_robot_set_tool(&r, v, 6, &err);
        break;
    case 2: {
        double masses[KINCAL_MAX_JOINTS], tool, g[3];
        if (check_struct(c, prhs[2], "mass", MASS_FIELDS) != 0 ||
            copy_field_vector(c, prhs[2], "mass", "link_masses_kg", n, masses) != 0 ||
            copy_field_vector(c, prhs[2], "mass", "tool_mass_kg", 1, &tool) != 0 ||
            copy_field_vector(c, prhs[2], "mass", "gravity", 3, g) != 0) {
            return -1;
        }
        st = kincal_robot_set_mass(&r, masses, n, tool, g, 3, &err);
        break;
    }
    case 3: {
        double lim[2 * KINCAL_MAX_JOINTS];
        size_t i;
        if (get_real_matrix(c, prhs[2], "limits", n, 2, &v) != 0) {
            return -1;
        }
        for (i = 0; i < n; ++i) {
            lim[2 * i] = v[i];
            lim[2 * i + 1] = v[n + i];
        }
        st = kincal_robot_set_limits(&r, lim, 2 * n, &err);
        break;
    }
    case 4: {
        size_t link;
        if (get_vector(c, prhs[2], "length_param", 2, &v) != 0 ||
            zero_based_index(c, v[0], "link", n, &link) != 0) {
            return -1;
        }
        if (v[1] != 0.0 && v[1] != 1.0) {
            return fail(c, "badValue", "the length parameter must be 0 (d) or 1 (beta), got %.17g",
                        v[1]);
        }
        st = kincal_robot_set_length_param(&r, link, (uint32_t)v[1], &err);
        break;
    }
    default:
        st = kincal_robot_adopt_geometry_as_nominal(&r, &err);
        break;
    }
    if (st != KINCAL_STATUS_OK) {
        return fail_status(c, st, &err, NULL);
    }
    robot_name(prhs[0], name, sizeof name);
    return put_robot(c, &r, name, &plhs[0]);
}

/* param(robot, label) -> value;  param(robot, label, value) -> robot */
static int op_param_get(kc_ctx *c, int nlhs, mxArray *plhs[], const mxArray *prhs[])
{
    kincal_robot r;
    kincal_error err;
    kincal_status st;
    char label[KINCAL_LABEL_CAPACITY + 8];
    double v;
    (void)nlhs;
    if (get_robot(c, prhs[0], &r) != 0 ||
        get_string(c, prhs[1], "label", label, sizeof label) != 0) {
        return -1;
    }
    st = kincal_robot_get_param_by_label(&r, label, &v, &err);
    if (st != KINCAL_STATUS_OK) {
        fail_status(c, st, &err, NULL);
        fail_append(c, "; label '%s'", label);
        return -1;
    }
    plhs[0] = mxCreateDoubleScalar(v);
    return 0;
}

static int op_param_set(kc_ctx *c, int nlhs, mxArray *plhs[], const mxArray *prhs[])
{
    kincal_robot r;
    kincal_error err;
    kincal_status st;
    char label[KINCAL_LABEL_CAPACITY + 8], name[64];
    double v;
    (void)nlhs;
    if (get_robot(c, prhs[0], &r) != 0 ||
        get_string(c, prhs[1], "label", label, sizeof label) != 0 ||
        get_scalar(c, prhs[2], "value", &v) != 0) {
        return -1;
    }
    st = kincal_robot_set_param_by_label(&r, label, v, &err);
    if (st != KINCAL_STATUS_OK) {
        fail_status(c, st, &err, NULL);
        fail_append(c, "; label '%s'", label);
        return -1;
    }
    robot_name(prhs[0], name, sizeof name);
    return put_robot(c, &r, name, &plhs[0]);
}

/* An effect mask from a cell array of effect names (or one name, or [] = none). */
static int get_effects(kc_ctx *c, const mxArray *a, const char *name, uint32_t *mask)
{
    size_t i, n;
    char buf[64];
    *mask = 0;
    if (is_default(a)) {
        return 0;
    }
    if (mxIsChar(a)) {
        n = 1;
    } else if (mxIsCell(a)) {
        n = mxGetNumberOfElements(a);
    } else {
        return fail(c, "badClass", "argument '%s' must be a cell array of effect names, got %s",
                    name, class_of(a));
    }
    for (i = 0; i < n; ++i) {
        const mxArray *e = mxIsChar(a) ? a : mxGetCell(a, (mwIndex)i);
        uint32_t effect;
        kincal_error err;
        kincal_status st;
        if (e == NULL || get_string(c, e, name, buf, sizeof buf) != 0) {
            return e == NULL ? fail(c, "badClass", "argument '%s' has an empty cell", name) : -1;
        }
        st = kincal_effect_from_name(buf, &effect, &err);
        if (st != KINCAL_STATUS_OK) {
            fail_status(c, st, &err, NULL);
            fail_append(c, "; effect '%s'", buf);
            return -1;
        }
        *mask |= (uint32_t)1u << effect;
    }
    return 0;
}

/* Effect names of a mask as a 1 x K cell. */
static mxArray *effect_names(uint32_t mask)
{
    uint32_t e;
    size_t k = 0, count = 0;
    mxArray *out;
    for (e = 0; e < 32; ++e) {
        if ((mask >> e) & 1u && kincal_effect_name(e) != NULL) {
            ++count;
        }
    }
    out = mxCreateCellMatrix(1, (mwSize)count);
    for (e = 0; e < 32; ++e) {
        if ((mask >> e) & 1u && kincal_effect_name(e) != NULL) {
            mxSetCell(out, (mwIndex)k++, mxCreateString(kincal_effect_name(e)));
        }
    }
    return out;
}

/* param_mask(robot, effects) -> logical P x 1 (parameters identified by default) */
static int op_param_mask(kc_ctx *c, int nlhs, mxArray *plhs[], const mxArray *prhs[])
{
    kincal_robot r;
    kincal_error err;
    kincal_status st;
    uint32_t effects;
    uint8_t mask[KINCAL_MAX_PARAMS];
    size_t np, i;
    mxLogical *out;
    (void)nlhs;
    if (get_robot(c, prhs[0], &r) != 0 || get_effects(c, prhs[1], "effects", &effects) != 0) {
        return -1;
    }
    np = kincal_num_params(r.n_joints);
    st = kincal_robot_param_mask(&r, effects, mask, np, &err);
    if (st != KINCAL_STATUS_OK) {
        return fail_status(c, st, &err, NULL);
    }
    plhs[0] = mxCreateLogicalMatrix((mwSize)np, 1);
    out = mxGetLogicals(plhs[0]);
    for (i = 0; i < np; ++i) {
        out[i] = mask[i] != 0;
    }
    return 0;
}

/* effects(robot) -> 1 x K cell of the active effects; effect_names() -> every effect */
static int op_active_effects(kc_ctx *c, int nlhs, mxArray *plhs[], const mxArray *prhs[])
{
    kincal_robot r;
    kincal_error err;
    kincal_status st;
    uint32_t mask;
    (void)nlhs;
    if (get_robot(c, prhs[0], &r) != 0) {
        return -1;
    }
    st = kincal_robot_active_effects(&r, &mask, &err);
    if (st != KINCAL_STATUS_OK) {
        return fail_status(c, st, &err, NULL);
    }
    plhs[0] = effect_names(mask);
    return 0;
}

static int op_effect_names(kc_ctx *c, int nlhs, mxArray *plhs[], const mxArray *prhs[])
{
    (void)c;
    (void)nlhs;
    (void)prhs;
    plhs[0] = effect_names(KINCAL_EFFECTS_ALL);
    return 0;
}

/* clear_effects(robot, effects) -> robot */
static int op_clear_effects(kc_ctx *c, int nlhs, mxArray *plhs[], const mxArray *prhs[])
{
    kincal_robot r;
    kincal_error err;
    kincal_status st;
    uint32_t effects;
    char name[64];
    (void)nlhs;
    if (get_robot(c, prhs[0], &r) != 0 || get_effects(c, prhs[1], "effects", &effects) != 0) {
        return -1;
    }
    st = kincal_robot_clear_effects(&r, effects, &err);
    if (st != KINCAL_STATUS_OK) {
        return fail_status(c, st, &err, NULL);
    }
    robot_name(prhs[0], name, sizeof name);
    return put_robot(c, &r, name, &plhs[0]);
}

/* fk(robot, q N x M, aux) -> T 4x4xM */
static int op_fk(kc_ctx *c, int nlhs, mxArray *plhs[], const mxArray *prhs[])
{
    kincal_robot r;
    kincal_error err;
    kincal_status st;
    const double *q;
    kc_aux aux;
    kincal_joint_aux ab;
    size_t n, m, j;
    double *t;
    char what[64];
    (void)nlhs;
    if (get_robot(c, prhs[0], &r) != 0) {
        return -1;
    }
    n = r.n_joints;
    if (get_real_matrix(c, prhs[1], "q", n, KC_ANY, &q) != 0) {
        return -1;
    }
    m = mxGetN(prhs[1]);
    if (get_aux(c, prhs[2], n, m, &aux) != 0) {
        return -1;
    }
    plhs[0] = create_poses(m);
    t = KC_DOUBLES(plhs[0]);
    for (j = 0; j < m; ++j) {
        st = kincal_fk(&r, q + j * n, n, aux_at(&aux, n, j, &ab), t + 16 * j, 16, &err);
        if (st != KINCAL_STATUS_OK) {
            return fail_status(c, st, &err, column_of(what, sizeof what, "q", j, m));
        }
    }
    return 0;
}

/* frames(robot, q N x 1, aux) -> 4x4x(N+2) */
static int op_frames(kc_ctx *c, int nlhs, mxArray *plhs[], const mxArray *prhs[])
{
    kincal_robot r;
    kincal_error err;
    kincal_status st;
    const double *q;
    kc_aux aux;
    kincal_joint_aux ab;
    size_t n;
    (void)nlhs;
    if (get_robot(c, prhs[0], &r) != 0) {
        return -1;
    }
    n = r.n_joints;
    if (get_real_matrix(c, prhs[1], "q", n, 1, &q) != 0 || get_aux(c, prhs[2], n, 1, &aux) != 0) {
        return -1;
    }
    plhs[0] = create_poses(n + 2);
    st = kincal_fk_frames(&r, q, n, aux_at(&aux, n, 0, &ab), KC_DOUBLES(plhs[0]), 16 * (n + 2),
                          &err);
    if (st != KINCAL_STATUS_OK) {
        return fail_status(c, st, &err, NULL);
    }
    return 0;
}

static const kc_name JACOBIAN_COLUMNS[] = {{"geometric", 0}, {"all", 1}, {NULL, 0}};

/* jacobian(robot, q N x 1, aux, 'geometric'|'all') -> J 6 x P, T 4x4 */
static int op_jacobian(kc_ctx *c, int nlhs, mxArray *plhs[], const mxArray *prhs[])
{
    kincal_robot r;
    kincal_error err;
    kincal_status st;
    const double *q;
    kc_aux aux;
    kincal_joint_aux ab;
    size_t n, p;
    uint32_t cols;
    double t[16];
    if (get_robot(c, prhs[0], &r) != 0) {
        return -1;
    }
    n = r.n_joints;
    if (get_real_matrix(c, prhs[1], "q", n, 1, &q) != 0 || get_aux(c, prhs[2], n, 1, &aux) != 0 ||
        get_choice(c, prhs[3], "columns", JACOBIAN_COLUMNS, &cols) != 0) {
        return -1;
    }
    p = cols ? kincal_num_params(n) : kincal_num_geometric_params(n);
    plhs[0] = mxCreateDoubleMatrix(6, (mwSize)p, mxREAL);
    st = kincal_jacobian(&r, q, n, aux_at(&aux, n, 0, &ab), KC_DOUBLES(plhs[0]), 6 * p, t, 16,
                         &err);
    if (st != KINCAL_STATUS_OK) {
        return fail_status(c, st, &err, NULL);
    }
    if (nlhs > 1) {
        plhs[1] = mxCreateDoubleMatrix(4, 4, mxREAL);
        memcpy(KC_DOUBLES(plhs[1]), t, sizeof t);
    }
    return 0;
}

static const char *const IK_FIELDS[] = {
    "max_iterations", "first_solution", "extra_seeds", "tol_pos_m", "tol_rot_rad", NULL,
};

static int get_ik_options(kc_ctx *c, const mxArray *a, kincal_ik_options *o)
{
    const mxArray *f;
    kincal_error err;
    kincal_status st = kincal_ik_options_default(o, &err);
    size_t v;
    if (st != KINCAL_STATUS_OK) {
        return fail_status(c, st, &err, NULL);
    }
    if (is_default(a)) {
        return 0;
    }
    if (check_struct(c, a, "options", IK_FIELDS) != 0) {
        return -1;
    }
    if ((f = mxGetField(a, 0, "max_iterations")) != NULL) {
        if (get_count(c, f, "options.max_iterations", 4294967295.0, &v) != 0) {
            return -1;
        }
        o->max_iterations = (uint32_t)v;
    }
    if ((f = mxGetField(a, 0, "first_solution")) != NULL) {
        if (mxIsLogicalScalar(f)) {
            o->first_solution = mxIsLogicalScalarTrue(f) ? 1u : 0u;
        } else if (get_count(c, f, "options.first_solution", 1, &v) != 0) {
            return -1;
        } else {
            o->first_solution = (uint32_t)v;
        }
    }
    if ((f = mxGetField(a, 0, "extra_seeds")) != NULL) {
        if (get_count(c, f, "options.extra_seeds", 1e6, &v) != 0) {
            return -1;
        }
        o->extra_seeds = v;
    }
    if ((f = mxGetField(a, 0, "tol_pos_m")) != NULL &&
        get_scalar(c, f, "options.tol_pos_m", &o->tol_pos_m) != 0) {
        return -1;
    }
    if ((f = mxGetField(a, 0, "tol_rot_rad")) != NULL &&
        get_scalar(c, f, "options.tol_rot_rad", &o->tol_rot_rad) != 0) {
        return -1;
    }
    return 0;
}

/* ik(robot, T 4x4xM, seed N x 1 or N x M, aux, options) -> q N x M, info struct 1 x M */
static const char *const IK_INFO_FIELDS[] = {
    "residual_pos_m", "residual_rot_rad", "iterations", "seed", NULL,
};

static int op_ik(kc_ctx *c, int nlhs, mxArray *plhs[], const mxArray *prhs[])
{
    kincal_robot r;
    kincal_error err;
    kincal_status st;
    kincal_ik_options opts;
    kincal_ik_info info;
    kincal_joint_aux ab;
    kc_aux aux;
    const double *t, *seed;
    double *q;
    size_t n, m, ms, j;
    char what[64];
    if (get_robot(c, prhs[0], &r) != 0) {
        return -1;
    }
    n = r.n_joints;
    if (get_poses(c, prhs[1], "target", &m, &t) != 0 ||
        get_real_matrix(c, prhs[2], "seed", n, KC_ANY, &seed) != 0) {
        return -1;
    }
    ms = mxGetN(prhs[2]);
    if (ms != 1 && ms != m) {
        return fail(c, "badSize", "argument 'seed' must be %lux1 or %lux%lu, got %lux%lu",
                    (unsigned long)n, (unsigned long)n, (unsigned long)m, (unsigned long)n,
                    (unsigned long)ms);
    }
    if (get_aux(c, prhs[3], n, m, &aux) != 0 || get_ik_options(c, prhs[4], &opts) != 0) {
        return -1;
    }
    plhs[0] = mxCreateDoubleMatrix((mwSize)n, (mwSize)m, mxREAL);
    q = KC_DOUBLES(plhs[0]);
    if (nlhs > 1) {
        plhs[1] = mxCreateStructMatrix(1, (mwSize)m, 4, (const char **)IK_INFO_FIELDS);
    }
    for (j = 0; j < m; ++j) {
        st = kincal_ik(&r, t + 16 * j, 16, seed + (ms == 1 ? 0 : j * n), n,
                       aux_at(&aux, n, j, &ab), &opts, q + j * n, n, &info, &err);
        if (st != KINCAL_STATUS_OK) {
            return fail_status(c, st, &err, column_of(what, sizeof what, "target", j, m));
        }
        if (nlhs > 1) {
            mxSetField(plhs[1], (mwIndex)j, "residual_pos_m",
                       mxCreateDoubleScalar(info.residual_pos_m));
            mxSetField(plhs[1], (mwIndex)j, "residual_rot_rad",
                       mxCreateDoubleScalar(info.residual_rot_rad));
            mxSetField(plhs[1], (mwIndex)j, "iterations",
                       mxCreateDoubleScalar((double)info.iterations));
            mxSetField(plhs[1], (mwIndex)j, "seed", mxCreateDoubleScalar((double)info.seed_index));
        }
    }
    return 0;
}

static const kc_name ORIENTATION_ERRORS[] = {
    {"exact", KINCAL_ORIENTATION_ERROR_EXACT},
    {"small_angle", KINCAL_ORIENTATION_ERROR_SMALL_ANGLE},
    {NULL, 0},
};

/* pose_error(measured 4x4xM, model 4x4xM or 4x4, form) -> 6 x M [dp (m); dphi (rad)] */
static int op_pose_error(kc_ctx *c, int nlhs, mxArray *plhs[], const mxArray *prhs[])
{
    const double *meas, *model;
    size_t m, mm, j;
    uint32_t form;
    double *e;
    kincal_error err;
    kincal_status st;
    char what[64];
    (void)nlhs;
    if (get_poses(c, prhs[0], "measured", &m, &meas) != 0 ||
        get_poses(c, prhs[1], "model", &mm, &model) != 0 ||
        get_choice(c, prhs[2], "form", ORIENTATION_ERRORS, &form) != 0) {
        return -1;
    }
    if (mm != m && mm != 1) {
        return fail(c, "badSize", "argument 'model' must be 4x4 or 4x4x%lu like 'measured', got "
                    "4x4x%lu", (unsigned long)m, (unsigned long)mm);
    }
    plhs[0] = mxCreateDoubleMatrix(6, (mwSize)m, mxREAL);
    e = KC_DOUBLES(plhs[0]);
    for (j = 0; j < m; ++j) {
        st = kincal_pose_error(meas + 16 * j, 16, model + (mm == 1 ? 0 : 16 * j), 16, form,
                               e + 6 * j, 6, &err);
        if (st != KINCAL_STATUS_OK) {
            return fail_status(c, st, &err, column_of(what, sizeof what, "the poses", j, m));
        }
    }
    return 0;
}

/* Conversions between representations, column by column:
 * pose_from_xyzrpy (6 x M -> 4x4xM), pose_to_xyzrpy (4x4xM -> 6 x M),
 * pose_from_pq (7 x M -> 4x4xM), pose_to_pq (4x4xM -> 7 x M). */
typedef kincal_status (*kc_to_pose)(const double *, size_t, double *, size_t, kincal_error *);

static int convert_to_poses(kc_ctx *c, mxArray *plhs[], const mxArray *a, const char *name,
                            size_t rows, kc_to_pose f)
{
    const double *v;
    size_t m, j;
    double *t;
    kincal_error err;
    kincal_status st;
    char what[64];
    if (get_real_matrix(c, a, name, rows, KC_ANY, &v) != 0) {
        return -1;
    }
    m = mxGetN(a);
    plhs[0] = create_poses(m);
    t = KC_DOUBLES(plhs[0]);
    for (j = 0; j < m; ++j) {
        st = f(v + rows * j, rows, t + 16 * j, 16, &err);
        if (st != KINCAL_STATUS_OK) {
            return fail_status(c, st, &err, column_of(what, sizeof what, name, j, m));
        }
    }
    return 0;
}

static int convert_from_poses(kc_ctx *c, mxArray *plhs[], const mxArray *a, size_t rows,
                              kc_to_pose f)
{
    const double *t;
    size_t m, j;
    double *v;
    kincal_error err;
    kincal_status st;
    char what[64];
    if (get_poses(c, a, "T", &m, &t) != 0) {
        return -1;
    }
    plhs[0] = mxCreateDoubleMatrix((mwSize)rows, (mwSize)m, mxREAL);
    v = KC_DOUBLES(plhs[0]);
    for (j = 0; j < m; ++j) {
        st = f(t + 16 * j, 16, v + rows * j, rows, &err);
        if (st != KINCAL_STATUS_OK) {
            return fail_status(c, st, &err, column_of(what, sizeof what, "the poses", j, m));
        }
    }
    return 0;
}

static int op_pose_from_xyzrpy(kc_ctx *c, int nlhs, mxArray *plhs[], const mxArray *prhs[])
{
    (void)nlhs;
    return convert_to_poses(c, plhs, prhs[0], "xyzrpy", 6, kincal_pose_from_xyz_rpy);
}

static int op_pose_to_xyzrpy(kc_ctx *c, int nlhs, mxArray *plhs[], const mxArray *prhs[])
{
    (void)nlhs;
    return convert_from_poses(c, plhs, prhs[0], 6, kincal_pose_to_xyz_rpy);
}

static int op_pose_from_pq(kc_ctx *c, int nlhs, mxArray *plhs[], const mxArray *prhs[])
{
    (void)nlhs;
    return convert_to_poses(c, plhs, prhs[0], "pq", 7, kincal_pose_from_pq);
}

static int op_pose_to_pq(kc_ctx *c, int nlhs, mxArray *plhs[], const mxArray *prhs[])
{
    (void)nlhs;
    return convert_from_poses(c, plhs, prhs[0], 7, kincal_pose_to_pq);
}

/* aria_tool() -> poses 4x4x10 (Table 2), seed 6 x 1 */
static int op_aria_tool(kc_ctx *c, int nlhs, mxArray *plhs[], const mxArray *prhs[])
{
    size_t l;
    double *t;
    kincal_error err;
    kincal_status st;
    (void)prhs;
    plhs[0] = create_poses(KINCAL_ARIA_NUM_TOOL_POSES);
    t = KC_DOUBLES(plhs[0]);
    for (l = 0; l < KINCAL_ARIA_NUM_TOOL_POSES; ++l) {
        st = kincal_aria_tool_pose(l, t + 16 * l, 16, &err);
        if (st != KINCAL_STATUS_OK) {
            return fail_status(c, st, &err, NULL);
        }
    }
    if (nlhs > 1) {
        plhs[1] = mxCreateDoubleMatrix(KINCAL_ARIA_NUM_JOINTS, 1, mxREAL);
        st = kincal_aria_tool_seed(KC_DOUBLES(plhs[1]), KINCAL_ARIA_NUM_JOINTS, &err);
        if (st != KINCAL_STATUS_OK) {
            return fail_status(c, st, &err, NULL);
        }
    }
    return 0;
}

/* gravity_torques(robot, q N x M) -> N x M [N m] */
static int op_gravity_torques(kc_ctx *c, int nlhs, mxArray *plhs[], const mxArray *prhs[])
{
    kincal_robot r;
    kincal_error err;
    kincal_status st;
    const double *q;
    size_t n, m, j;
    double *tau;
    char what[64];
    (void)nlhs;
    if (get_robot(c, prhs[0], &r) != 0) {
        return -1;
    }
    n = r.n_joints;
    if (get_real_matrix(c, prhs[1], "q", n, KC_ANY, &q) != 0) {
        return -1;
    }
    m = mxGetN(prhs[1]);
    plhs[0] = mxCreateDoubleMatrix((mwSize)n, (mwSize)m, mxREAL);
    tau = KC_DOUBLES(plhs[0]);
    for (j = 0; j < m; ++j) {
        st = kincal_gravity_torques(&r, q + j * n, n, tau + j * n, n, &err);
        if (st != KINCAL_STATUS_OK) {
            return fail_status(c, st, &err, column_of(what, sizeof what, "q", j, m));
        }
    }
    return 0;
}

/* joint_angles(robot, q N x M, aux) -> N x M */
static int op_joint_angles(kc_ctx *c, int nlhs, mxArray *plhs[], const mxArray *prhs[])
{
    kincal_robot r;
    kincal_error err;
    kincal_status st;
    const double *q;
    kc_aux aux;
    kincal_joint_aux ab;
    size_t n, m, j;
    double *out;
    char what[64];
    (void)nlhs;
    if (get_robot(c, prhs[0], &r) != 0) {
        return -1;
    }
    n = r.n_joints;
    if (get_real_matrix(c, prhs[1], "q", n, KC_ANY, &q) != 0) {
        return -1;
    }
    m = mxGetN(prhs[1]);
    if (get_aux(c, prhs[2], n, m, &aux) != 0) {
        return -1;
    }
    plhs[0] = mxCreateDoubleMatrix((mwSize)n, (mwSize)m, mxREAL);
    out = KC_DOUBLES(plhs[0]);
    for (j = 0; j < m; ++j) {
        st = kincal_joint_angles(&r, q + j * n, n, aux_at(&aux, n, j, &ab), out + j * n, n, &err);
        if (st != KINCAL_STATUS_OK) {
            return fail_status(c, st, &err, column_of(what, sizeof what, "q", j, m));
        }
    }
    return 0;
}

/* check_limits(robot, q N x M) -> nothing; fails with kincal:outOfLimits naming joint and
 * column (1-based) */
static int op_check_limits(kc_ctx *c, int nlhs, mxArray *plhs[], const mxArray *prhs[])
{
    kincal_robot r;
    kincal_error err;
    kincal_status st;
    const double *q;
    size_t n, m, j;
    char what[64];
    (void)nlhs;
    (void)plhs;
    if (get_robot(c, prhs[0], &r) != 0) {
        return -1;
    }
    n = r.n_joints;
    if (get_real_matrix(c, prhs[1], "q", n, KC_ANY, &q) != 0) {
        return -1;
    }
    m = mxGetN(prhs[1]);
    for (j = 0; j < m; ++j) {
        st = kincal_robot_check_limits(&r, q + j * n, n, &err);
        if (st != KINCAL_STATUS_OK) {
            return fail_status(c, st, &err, column_of(what, sizeof what, "q", j, m));
        }
    }
    return 0;
}

/* ------------------------------------------------------------------------------------------ */
/* Observability and pose selection                                                           */
/* ------------------------------------------------------------------------------------------ */

#if defined(KINCAL_MAX_SELECT)
#define KC_HAS_OBSERVABILITY 1

static const kc_name SCALINGS[] = {
    {"none", KINCAL_SCALING_KIND_NONE},
    {"unit", KINCAL_SCALING_KIND_UNIT_COLUMNS},
    {"tolerance", KINCAL_SCALING_KIND_TOLERANCE},
    {NULL, 0},
};

static const kc_name OBS_INDICES[] = {
    {"o", KINCAL_OBS_INDEX_O},       {"o1", KINCAL_OBS_INDEX_O1},
    {"o2", KINCAL_OBS_INDEX_O2},     {"o3", KINCAL_OBS_INDEX_O3},
    {"o4", KINCAL_OBS_INDEX_O4},     {"o5", KINCAL_OBS_INDEX_O5},
    {"aopt", KINCAL_OBS_INDEX_A_OPT}, {"dopt", KINCAL_OBS_INDEX_D_OPT},
    {NULL, 0},
};

/* params: [] (the robot's geometric set) or a P x 1 logical / 0-1 mask over robot.params.
 * Sets *mask to NULL for [] and counts the parameters in *n_params. */
static int get_param_mask(kc_ctx *c, const kincal_robot *r, const mxArray *a, uint8_t *buf,
                          const uint8_t **mask, size_t *n_params)
{
    size_t np = kincal_num_params(r->n_joints), i;
    kincal_error err;
    kincal_status st;
    *n_params = 0;
    if (is_default(a)) {
        *mask = NULL;
        st = kincal_robot_param_mask(r, 0, buf, np, &err);
        if (st != KINCAL_STATUS_OK) {
            return fail_status(c, st, &err, NULL);
        }
    } else if (mxIsLogical(a) && mxGetNumberOfElements(a) == np) {
        const mxLogical *lg = mxGetLogicals(a);
        for (i = 0; i < np; ++i) {
            buf[i] = lg[i] ? 1 : 0;
        }
        *mask = buf;
    } else {
        const double *p;
        if (get_vector(c, a, "params", np, &p) != 0) {
            return -1;
        }
        for (i = 0; i < np; ++i) {
            if (p[i] != 0.0 && p[i] != 1.0) {
                return fail(c, "badValue", "argument 'params': element %.0f must be 0 or 1",
                            one_based(i));
            }
            buf[i] = p[i] != 0.0;
        }
        *mask = buf;
    }
    for (i = 0; i < np; ++i) {
        *n_params += buf[i] != 0;
    }
    return 0;
}

/* scaling name and tolerances ([length_m angle_rad] or [] unless 'tolerance') */
static int get_scaling(kc_ctx *c, const mxArray *name, const mxArray *tol, kincal_scaling *s)
{
    const double *t;
    if (get_choice(c, name, "scaling", SCALINGS, &s->kind) != 0) {
        return -1;
    }
    s->length_m = 1.0;
    s->angle_rad = 1.0;
    if (s->kind == KINCAL_SCALING_KIND_TOLERANCE) {
        if (get_vector(c, tol, "tolerance", 2, &t) != 0) {
            return -1;
        }
        s->length_m = t[0];
        s->angle_rad = t[1];
    }
    return 0;
}

/* Aligned scratch of `bytes` bytes (freed with the call). */
static void *aligned_scratch(kc_ctx *c, size_t bytes)
{
    char *raw;
    if (bytes == 0) {
        fail(c, "capacityExceeded", "no workspace size for these parameters");
        return NULL;
    }
    raw = (char *)kc_alloc(c, bytes + KINCAL_WORKSPACE_ALIGN);
    if (raw == NULL) {
        return NULL;
    }
    return raw + (KINCAL_WORKSPACE_ALIGN - (size_t)((uintptr_t)raw % KINCAL_WORKSPACE_ALIGN)) %
                     KINCAL_WORKSPACE_ALIGN;
}

static const char *const INDICES_FIELDS[] = {
    "o", "o1", "o2", "o3", "o4", "o5", "a_optimality", "d_optimality", "sigma_min",
    "sigma_max", "poses", "params", NULL,
};

static mxArray *indices_struct(const kincal_observability_indices *i)
{
    mxArray *s = mxCreateStructMatrix(1, 1, 12, (const char **)INDICES_FIELDS);
    mxSetField(s, 0, "o", mxCreateDoubleScalar(i->o));
    mxSetField(s, 0, "o1", mxCreateDoubleScalar(i->o1));
    mxSetField(s, 0, "o2", mxCreateDoubleScalar(i->o2));
    mxSetField(s, 0, "o3", mxCreateDoubleScalar(i->o3));
    mxSetField(s, 0, "o4", mxCreateDoubleScalar(i->o4));
    mxSetField(s, 0, "o5", mxCreateDoubleScalar(i->o5));
    mxSetField(s, 0, "a_optimality", mxCreateDoubleScalar(i->a_optimality));
    mxSetField(s, 0, "d_optimality", mxCreateDoubleScalar(i->d_optimality));
    mxSetField(s, 0, "sigma_min", mxCreateDoubleScalar(i->sigma_min));
    mxSetField(s, 0, "sigma_max", mxCreateDoubleScalar(i->sigma_max));
    mxSetField(s, 0, "poses", mxCreateDoubleScalar((double)i->poses));
    mxSetField(s, 0, "params", mxCreateDoubleScalar((double)i->params));
    return s;
}

/* observability(robot, q N x M, params, scaling, tolerance) -> indices struct, sv p x 1 */
static int op_observability(kc_ctx *c, int nlhs, mxArray *plhs[], const mxArray *prhs[])
{
    kincal_robot r;
    kincal_error err;
    kincal_status st;
    kincal_scaling sc;
    kincal_observability_indices ind;
    uint8_t buf[KINCAL_MAX_PARAMS];
    const uint8_t *mask;
    const double *q;
    size_t n, m, np, p;
    void *ws;
    size_t ws_len;
    mxArray *sv;
    if (get_robot(c, prhs[0], &r) != 0) {
        return -1;
    }
    n = r.n_joints;
    np = kincal_num_params(n);
    if (get_real_matrix(c, prhs[1], "q", n, KC_ANY, &q) != 0 ||
        get_param_mask(c, &r, prhs[2], buf, &mask, &p) != 0 ||
        get_scaling(c, prhs[3], prhs[4], &sc) != 0) {
        return -1;
    }
    m = mxGetN(prhs[1]);
    ws_len = kincal_observability_workspace_size(p);
    if ((ws = aligned_scratch(c, ws_len)) == NULL) {
        return -1;
    }
    sv = mxCreateDoubleMatrix((mwSize)p, 1, mxREAL);
    st = kincal_observability(&r, q, m, n * m, mask, np, &sc, ws, ws_len, &ind, KC_DOUBLES(sv),
                              p, &err);
    if (st != KINCAL_STATUS_OK) {
        mxDestroyArray(sv);
        return fail_status(c, st, &err, NULL);
    }
    plhs[0] = indices_struct(&ind);
    if (nlhs > 1) {
        plhs[1] = sv;
    } else {
        mxDestroyArray(sv);
    }
    return 0;
}

static const char *const SELECTION_FIELDS[] = {
    "value", "initial_value", "exchange_value", "evaluations", "exchanges", "refinements",
    "start", "indices", NULL,
};

/* select_poses(robot, pool N x K, m, params, scaling, tolerance, objective, seed,
 *              region 3 x 2 [min max] or [], joint_margin_rad) -> q N x m, selection struct */
static int op_select_poses(kc_ctx *c, int nlhs, mxArray *plhs[], const mxArray *prhs[])
{
    kincal_robot r;
    kincal_error err;
    kincal_status st;
    kincal_scaling sc;
    kincal_selection sel;
    kincal_region region;
    const kincal_region *reg = NULL;
    uint8_t buf[KINCAL_MAX_PARAMS];
    const uint8_t *mask;
    const double *pool, *g;
    uint32_t objective;
    size_t n, k, m, np, p, seed, i;
    double margin;
    void *ws;
    size_t ws_len;
    mxArray *q_out, *s;
    if (get_robot(c, prhs[0], &r) != 0) {
        return -1;
    }
    n = r.n_joints;
    np = kincal_num_params(n);
    if (get_real_matrix(c, prhs[1], "pool", n, KC_ANY, &pool) != 0 ||
        get_count(c, prhs[2], "m", (double)KINCAL_MAX_SELECT, &m) != 0 ||
        get_param_mask(c, &r, prhs[3], buf, &mask, &p) != 0 ||
        get_scaling(c, prhs[4], prhs[5], &sc) != 0 ||
        get_choice(c, prhs[6], "objective", OBS_INDICES, &objective) != 0 ||
        get_count(c, prhs[7], "seed", 9007199254740992.0, &seed) != 0 ||
        get_scalar(c, prhs[9], "joint_margin_rad", &margin) != 0) {
        return -1;
    }
    if (!is_default(prhs[8])) {
        if (get_real_matrix(c, prhs[8], "region", 3, 2, &g) != 0) {
            return -1;
        }
        for (i = 0; i < 3; ++i) {
            region.min_m[i] = g[i];
            region.max_m[i] = g[3 + i];
        }
        reg = &region;
    }
    k = mxGetN(prhs[1]);
    ws_len = kincal_select_workspace_size(p, k);
    if ((ws = aligned_scratch(c, ws_len)) == NULL) {
        return -1;
    }
    q_out = mxCreateDoubleMatrix((mwSize)n, (mwSize)m, mxREAL);
    st = kincal_select_poses(&r, pool, k, n * k, m, mask, np, &sc, objective, (uint64_t)seed,
                             reg, margin, ws, ws_len, KC_DOUBLES(q_out), n * m, &sel, &err);
    if (st != KINCAL_STATUS_OK) {
        mxDestroyArray(q_out);
        return fail_status(c, st, &err, NULL);
    }
    plhs[0] = q_out;
    if (nlhs > 1) {
        s = mxCreateStructMatrix(1, 1, 8, (const char **)SELECTION_FIELDS);
        mxSetField(s, 0, "value", mxCreateDoubleScalar(sel.value));
        mxSetField(s, 0, "initial_value", mxCreateDoubleScalar(sel.initial_value));
        mxSetField(s, 0, "exchange_value", mxCreateDoubleScalar(sel.exchange_value));
        mxSetField(s, 0, "evaluations", mxCreateDoubleScalar((double)sel.evaluations));
        mxSetField(s, 0, "exchanges", mxCreateDoubleScalar((double)sel.exchanges));
        mxSetField(s, 0, "refinements", mxCreateDoubleScalar((double)sel.refinements));
        mxSetField(s, 0, "start", mxCreateDoubleScalar(one_based(sel.start)));
        mxSetField(s, 0, "indices", indices_struct(&sel.indices));
        plhs[1] = s;
    }
    return 0;
}

static const char *const CLUSTER_FIELDS[] = {
    "chosen", "spread", "value", "target", "within_tolerance", "occupied_cubes", NULL,
};

/* cluster_select(robot, pool N x K, m, params, scaling, scaling tolerance, objective,
 *                region 3 x 2 [min max], cube_m, tolerance) -> q N x m, info struct
 * (chosen: 1-based pool columns; target 1-based). The paper's workspace-clustering design. */
static int op_cluster_select(kc_ctx *c, int nlhs, mxArray *plhs[], const mxArray *prhs[])
{
    kincal_robot r;
    kincal_error err;
    kincal_status st;
    kincal_scaling sc;
    kincal_cluster_selection sel;
    kincal_region region;
    uint8_t buf[KINCAL_MAX_PARAMS];
    const uint8_t *mask;
    const double *pool, *g;
    uint32_t objective;
    size_t n, k, m, np, p, i, j;
    size_t chosen[KINCAL_MAX_SELECT];
    double cube_m, tolerance;
    void *ws;
    size_t ws_len;
    mxArray *q_out, *s, *idx;
    if (get_robot(c, prhs[0], &r) != 0) {
        return -1;
    }
    n = r.n_joints;
    np = kincal_num_params(n);
    if (get_real_matrix(c, prhs[1], "pool", n, KC_ANY, &pool) != 0 ||
        get_count(c, prhs[2], "m", (double)KINCAL_MAX_SELECT, &m) != 0 ||
        get_param_mask(c, &r, prhs[3], buf, &mask, &p) != 0 ||
        get_scaling(c, prhs[4], prhs[5], &sc) != 0 ||
        get_choice(c, prhs[6], "objective", OBS_INDICES, &objective) != 0 ||
        get_real_matrix(c, prhs[7], "region", 3, 2, &g) != 0 ||
        get_scalar(c, prhs[8], "cube_m", &cube_m) != 0 ||
        get_scalar(c, prhs[9], "tolerance", &tolerance) != 0) {
        return -1;
    }
    for (i = 0; i < 3; ++i) {
        region.min_m[i] = g[i];
        region.max_m[i] = g[3 + i];
    }
    k = mxGetN(prhs[1]);
    ws_len = kincal_cluster_workspace_size(p, k, &region, cube_m);
    if (ws_len == 0) {
        return fail(c, "invalidArgument", "no workspace size for %lu parameters, %lu candidates "
                    "and cubes of %g m in the region (a cube side > 0 and a valid region?)",
                    (unsigned long)p, (unsigned long)k, cube_m);
    }
    if ((ws = aligned_scratch(c, ws_len)) == NULL) {
        return -1;
    }
    st = kincal_cluster_select(&r, pool, k, n * k, m, mask, np, &sc, objective, &region, cube_m,
                               tolerance, ws, ws_len, chosen, m, &sel, &err);
    if (st != KINCAL_STATUS_OK) {
        return fail_status(c, st, &err, NULL);
    }
    q_out = mxCreateDoubleMatrix((mwSize)n, (mwSize)m, mxREAL);
    idx = mxCreateDoubleMatrix(1, (mwSize)m, mxREAL);
    for (j = 0; j < m; ++j) {
        memcpy(KC_DOUBLES(q_out) + j * n, pool + chosen[j] * n, n * sizeof(double));
        KC_DOUBLES(idx)[j] = one_based(chosen[j]);
    }
    plhs[0] = q_out;
    if (nlhs > 1) {
        s = mxCreateStructMatrix(1, 1, 6, (const char **)CLUSTER_FIELDS);
        mxSetField(s, 0, "chosen", idx);
        mxSetField(s, 0, "spread", mxCreateDoubleScalar(sel.spread));
        mxSetField(s, 0, "value", mxCreateDoubleScalar(sel.value));
        mxSetField(s, 0, "target", mxCreateDoubleScalar(one_based(sel.target)));
        mxSetField(s, 0, "within_tolerance", mxCreateLogicalScalar(sel.within_tolerance != 0));
        mxSetField(s, 0, "occupied_cubes", mxCreateDoubleScalar((double)sel.occupied_cubes));
        plhs[1] = s;
    } else {
        mxDestroyArray(idx);
    }
    return 0;
}
#endif /* KINCAL_MAX_SELECT */

/* ------------------------------------------------------------------------------------------ */
/* Identification, identifiability, validation (with the C ABI's identification exports)      */
/* ------------------------------------------------------------------------------------------ */

#if defined(KINCAL_WORKSPACE_ALIGN)
#define KC_HAS_IDENTIFY 1

static const kc_name ALGORITHMS[] = {
    {"ols", 0}, {"opt1", 1}, {"opt2", 2}, {NULL, 0},
};

static const char *algorithm_name(uint32_t a)
{
    const kc_name *t;
    for (t = ALGORITHMS; t->name != NULL; ++t) {
        if (t->value == a) {
            return t->name;
        }
    }
    return "?";
}

/* The measurements of a call: views of the Matlab arrays (q N x M is the row-major M x N
 * table the C ABI wants; T 4x4xM is M column-major poses), plus scratch copies of the masks
 * and the per-pose auxiliary inputs. */
static int get_measurements(kc_ctx *c, const kincal_robot *r, const mxArray *q_arg,
                            const mxArray *t_arg, const mxArray *components,
                            const mxArray *aux_arg, kincal_measurements *m)
{
    size_t n = r->n_joints, l, mt, j;
    const double *q, *t, *comp;
    kc_aux aux;
    memset(m, 0, sizeof *m);
    if (get_real_matrix(c, q_arg, "q", n, KC_ANY, &q) != 0 ||
        get_poses(c, t_arg, "T", &mt, &t) != 0) {
        return -1;
    }
    l = mxGetN(q_arg);
    if (mt != l) {
        return fail(c, "badSize", "argument 'T' must be 4x4x%lu (one pose per column of q), "
                    "got 4x4x%lu", (unsigned long)l, (unsigned long)mt);
    }
    m->n_poses = l;
    m->q = q;
    m->q_len = n * l;
    m->poses = t;
    m->poses_len = 16 * l;
    if (!is_default(components)) {
        uint8_t *masks;
        if (get_real_matrix(c, components, "components", 1, l, &comp) != 0) {
            return -1;
        }
        masks = (uint8_t *)kc_alloc(c, l);
        if (masks == NULL) {
            return -1;
        }
        for (j = 0; j < l; ++j) {
            if (comp[j] < 0 || comp[j] > 255 || comp[j] != (double)(uint8_t)comp[j]) {
                return fail(c, "badValue", "argument 'components': pose %.0f must be a bit "
                            "mask 1..63, got %.17g", one_based(j), comp[j]);
            }
            masks[j] = (uint8_t)comp[j];
        }
        m->masks = masks;
        m->masks_len = l;
    }
    if (get_aux(c, aux_arg, n, l, &aux) != 0) {
        return -1;
    }
    if (aux.approach != NULL || aux.temp_c != NULL) {
        kincal_joint_aux *a = (kincal_joint_aux *)kc_alloc(c, l * sizeof *a);
        if (a == NULL) {
            return -1;
        }
        for (j = 0; j < l; ++j) {
            aux_at(&aux, n, j, &a[j]);
        }
        m->aux = a;
        m->aux_len = l;
    }
    return 0;
}

static const char *const IDENTIFY_FIELDS[] = {
    "algorithm", "effects", "requested", "lower", "upper", "max_iterations",
    "allow_data_deficiency", "orientation", "xtol", "ftol", "abs_cost_tol", "rank_tol",
    "weight_pos", "weight_rot", "pose_weights", "prior", "prior_sigma", NULL,
};

/* options.pose_weights (1 x M, >= 0; 0 holds a pose out) into the measurements: the values
 * are the caller's array, viewed (the library checks them). */
static int get_pose_weights(kc_ctx *c, const mxArray *options, kincal_measurements *m)
{
    const mxArray *f;
    const double *w;
    if (is_default(options) || (f = mxGetField(options, 0, "pose_weights")) == NULL ||
        is_default(f)) {
        return 0;
    }
    if (get_vector(c, f, "options.pose_weights", m->n_poses, &w) != 0) {
        return -1;
    }
    m->weights = w;
    m->weights_len = m->n_poses;
    return 0;
}

/* Identification options: the library's defaults for the robot, algorithm and effects, then
 * the fields the caller set. `requested` is a logical or 0/1 P x 1 mask over robot.params;
 * `lower`/`upper` are P x 1 absolute OPT1 intervals (+-Inf allowed). */
static int get_identify_options(kc_ctx *c, const kincal_robot *r, const mxArray *a,
                                kincal_identify_options *o)
{
    uint32_t alg = 0, effects = 0;
    const mxArray *f;
    size_t np = kincal_num_params(r->n_joints), i, v;
    kincal_error err;
    kincal_status st;
    if (!is_default(a) && check_struct(c, a, "options", IDENTIFY_FIELDS) != 0) {
        return -1;
    }
    f = is_default(a) ? NULL : mxGetField(a, 0, "algorithm");
    if (f != NULL && get_choice(c, f, "algorithm", ALGORITHMS, &alg) != 0) {
        return -1;
    }
    f = is_default(a) ? NULL : mxGetField(a, 0, "effects");
    if (f != NULL && get_effects(c, f, "effects", &effects) != 0) {
        return -1;
    }
    st = kincal_identify_options_default(r, alg, effects, o, &err);
    if (st != KINCAL_STATUS_OK) {
        return fail_status(c, st, &err, NULL);
    }
    if (is_default(a)) {
        return 0;
    }
    if ((f = mxGetField(a, 0, "requested")) != NULL && !is_default(f)) {
        if (mxIsLogical(f) && mxGetNumberOfElements(f) == np) {
            const mxLogical *lg = mxGetLogicals(f);
            for (i = 0; i < np; ++i) {
                o->requested[i] = lg[i] ? 1 : 0;
            }
        } else {
            const double *p;
            if (get_vector(c, f, "options.requested", np, &p) != 0) {
                return -1;
            }
            for (i = 0; i < np; ++i) {
                if (p[i] != 0.0 && p[i] != 1.0) {
                    return fail(c, "badValue", "argument 'options.requested': element %.0f "
                                "must be 0 or 1", one_based(i));
                }
                o->requested[i] = p[i] != 0.0;
            }
        }
    }
    for (i = 0; i < 2; ++i) {
        const char *name = i == 0 ? "lower" : "upper";
        double *dst = i == 0 ? o->lower : o->upper;
        if ((f = mxGetField(a, 0, name)) != NULL && !is_default(f)) {
            char full[32];
            snprintf(full, sizeof full, "options.%s", name);
            /* +-Inf is an open end; NaN is refused by the library. */
            if (check_double(c, f, full, 0) != 0) {
                return -1;
            }
            if (mxGetNumberOfElements(f) != np || (mxGetM(f) != 1 && mxGetN(f) != 1)) {
                return fail(c, "badSize", "argument '%s' must be a vector of %lu elements",
                            full, (unsigned long)np);
            }
            memcpy(dst, KC_DOUBLES(f), np * sizeof *dst);
        }
    }
    /* prior = [length_m, angle_rad]: the library's per-kind link prior around the robot;
     * prior_sigma = P x 1 sigmas (Inf: none), applied after it. */
    if ((f = mxGetField(a, 0, "prior")) != NULL && !is_default(f)) {
        const double *p;
        if (get_vector(c, f, "options.prior", 2, &p) != 0) {
            return -1;
        }
        st = kincal_identify_options_set_prior(r, p[0], p[1], o, &err);
        if (st != KINCAL_STATUS_OK) {
            return fail_status(c, st, &err, NULL);
        }
    }
    if ((f = mxGetField(a, 0, "prior_sigma")) != NULL && !is_default(f)) {
        if (check_double(c, f, "options.prior_sigma", 0) != 0) {
            return -1;
        }
        if (mxGetNumberOfElements(f) != np || (mxGetM(f) != 1 && mxGetN(f) != 1)) {
            return fail(c, "badSize", "argument 'options.prior_sigma' must be a vector of %lu "
                        "elements", (unsigned long)np);
        }
        memcpy(o->prior_sigma, KC_DOUBLES(f), np * sizeof *o->prior_sigma);
    }
    if ((f = mxGetField(a, 0, "max_iterations")) != NULL) {
        if (get_count(c, f, "options.max_iterations", 4294967295.0, &v) != 0) {
            return -1;
        }
        o->max_iterations = (uint32_t)v;
    }
    if ((f = mxGetField(a, 0, "allow_data_deficiency")) != NULL) {
        if (mxIsLogicalScalar(f)) {
            o->allow_data_deficiency = mxIsLogicalScalarTrue(f) ? 1u : 0u;
        } else if (get_count(c, f, "options.allow_data_deficiency", 1, &v) != 0) {
            return -1;
        } else {
            o->allow_data_deficiency = (uint32_t)v;
        }
    }
    if ((f = mxGetField(a, 0, "orientation")) != NULL &&
        get_choice(c, f, "options.orientation", ORIENTATION_ERRORS, &o->orientation) != 0) {
        return -1;
    }
    {
        static const char *const names[] = {"xtol", "ftol", "abs_cost_tol", "rank_tol",
                                            "weight_pos", "weight_rot"};
        double *dsts[6];
        dsts[0] = &o->xtol;
        dsts[1] = &o->ftol;
        dsts[2] = &o->abs_cost_tol;
        dsts[3] = &o->rank_tol;
        dsts[4] = &o->weight_pos;
        dsts[5] = &o->weight_rot;
        for (i = 0; i < 6; ++i) {
            char full[32];
            snprintf(full, sizeof full, "options.%s", names[i]);
            if ((f = mxGetField(a, 0, names[i])) != NULL && get_scalar(c, f, full, dsts[i]) != 0) {
                return -1;
            }
        }
    }
    return 0;
}

/* Scratch workspace of the identification calls, aligned to KINCAL_WORKSPACE_ALIGN. */
static int get_workspace(kc_ctx *c, const kincal_robot *r, const kincal_measurements *m,
                         const kincal_identify_options *o, void **ws, size_t *ws_len)
{
    size_t np = kincal_num_params(r->n_joints), n_req = 0, i, bytes;
    char *raw;
    for (i = 0; i < np; ++i) {
        n_req += o->requested[i] != 0;
    }
    bytes = kincal_identify_workspace_size(r->n_joints, m->n_poses, n_req);
    if (bytes == 0) {
        return fail(c, "capacityExceeded", "no workspace size for %lu poses and %lu requested "
                    "parameters", (unsigned long)m->n_poses, (unsigned long)n_req);
    }
    raw = (char *)kc_alloc(c, bytes + KINCAL_WORKSPACE_ALIGN);
    if (raw == NULL) {
        return -1;
    }
    *ws = raw + (KINCAL_WORKSPACE_ALIGN - (size_t)((uintptr_t)raw % KINCAL_WORKSPACE_ALIGN)) %
                    KINCAL_WORKSPACE_ALIGN;
    *ws_len = bytes;
    return 0;
}

/* A P x 1 logical of a byte mask. */
static mxArray *mask_array(const uint8_t *mask, size_t np)
{
    mxArray *a = mxCreateLogicalMatrix((mwSize)np, 1);
    mxLogical *l = mxGetLogicals(a);
    size_t i;
    for (i = 0; i < np; ++i) {
        l[i] = mask[i] != 0;
    }
    return a;
}

/* The labels of the parameters in a mask (1 x K cell). */
static mxArray *mask_labels(const kincal_robot *r, const uint8_t *mask, size_t np)
{
    size_t i, k = 0, count = 0;
    mxArray *a;
    for (i = 0; i < np; ++i) {
        count += mask[i] != 0;
    }
    a = mxCreateCellMatrix(1, (mwSize)count);
    for (i = 0; i < np; ++i) {
        char label[KINCAL_LABEL_CAPACITY];
        if (mask[i] == 0) {
            continue;
        }
        if (kincal_robot_param_label(r, i, label, sizeof label, NULL) != KINCAL_STATUS_OK) {
            snprintf(label, sizeof label, "#%.0f", one_based(i));
        }
        mxSetCell(a, (mwIndex)k++, mxCreateString(label));
    }
    return a;
}

static mxArray *label_of(const kincal_robot *r, size_t index)
{
    char label[KINCAL_LABEL_CAPACITY];
    if (index == KINCAL_NO_INDEX) {
        return mxCreateString("");
    }
    if (kincal_robot_param_label(r, index, label, sizeof label, NULL) != KINCAL_STATUS_OK) {
        snprintf(label, sizeof label, "#%.0f", one_based(index));
    }
    return mxCreateString(label);
}

static const char *const ANALYSIS_FIELDS[] = {
    "rank", "condition_number", "singular_values", "requested", "identifiable",
    "structural", "data_deficient", "requested_labels", "identifiable_labels",
    "structural_labels", "data_deficient_labels", "partner", "partner_cosine", NULL,
};

static mxArray *analysis_struct(const kincal_robot *r, const kincal_identifiability *a)
{
    size_t np = kincal_num_params(r->n_joints), i;
    mxArray *s = mxCreateStructMatrix(1, 1, 13, (const char **)ANALYSIS_FIELDS);
    mxArray *partner = mxCreateCellMatrix((mwSize)np, 1);
    mxArray *cosine = mxCreateDoubleMatrix((mwSize)np, 1, mxREAL);
    size_t nsv = a->n_singular_values < KINCAL_MAX_PARAMS ? a->n_singular_values
                                                          : KINCAL_MAX_PARAMS;
    for (i = 0; i < np; ++i) {
        mxSetCell(partner, (mwIndex)i, label_of(r, a->partner[i]));
        KC_DOUBLES(cosine)[i] = a->partner_cosine[i];
    }
    mxSetField(s, 0, "rank", mxCreateDoubleScalar((double)a->rank));
    mxSetField(s, 0, "condition_number", mxCreateDoubleScalar(a->condition_number));
    mxSetField(s, 0, "singular_values", column(a->singular_values, nsv));
    mxSetField(s, 0, "requested", mask_array(a->requested, np));
    mxSetField(s, 0, "identifiable", mask_array(a->identifiable, np));
    mxSetField(s, 0, "structural", mask_array(a->structural, np));
    mxSetField(s, 0, "data_deficient", mask_array(a->data_deficient, np));
    mxSetField(s, 0, "requested_labels", mask_labels(r, a->requested, np));
    mxSetField(s, 0, "identifiable_labels", mask_labels(r, a->identifiable, np));
    mxSetField(s, 0, "structural_labels", mask_labels(r, a->structural, np));
    mxSetField(s, 0, "data_deficient_labels", mask_labels(r, a->data_deficient, np));
    mxSetField(s, 0, "partner", partner);
    mxSetField(s, 0, "partner_cosine", cosine);
    return s;
}

static const char *const STATS_FIELDS[] = {
    "poses", "rows", "cost", "rms_pos_m", "max_pos_m", "rms_rot_rad", "max_rot_rad", NULL,
};

static mxArray *stats_struct(const kincal_residual_stats *t)
{
    mxArray *s = mxCreateStructMatrix(1, 1, 7, (const char **)STATS_FIELDS);
    mxSetField(s, 0, "poses", mxCreateDoubleScalar((double)t->poses));
    mxSetField(s, 0, "rows", mxCreateDoubleScalar((double)t->rows));
    mxSetField(s, 0, "cost", mxCreateDoubleScalar(t->cost));
    mxSetField(s, 0, "rms_pos_m", mxCreateDoubleScalar(t->rms_pos_m));
    mxSetField(s, 0, "max_pos_m", mxCreateDoubleScalar(t->max_pos_m));
    mxSetField(s, 0, "rms_rot_rad", mxCreateDoubleScalar(t->rms_rot_rad));
    mxSetField(s, 0, "max_rot_rad", mxCreateDoubleScalar(t->max_rot_rad));
    return s;
}

static const char *const REPORT_FIELDS[] = {
    "algorithm", "iterations", "analysis", "initial", "fitted", "sigma2", "std_errors",
    "at_bound", "at_bound_labels", "correlations", "n_correlated", "prior_chi2", "prior_rows",
    NULL,
};
static const char *const CORRELATION_FIELDS[] = {"a", "b", "rho", NULL};

static mxArray *report_struct(const kincal_robot *r, const kincal_identify_report *p)
{
    size_t np = kincal_num_params(r->n_joints), i;
    size_t nc = p->n_correlated < KINCAL_MAX_CORRELATED_PAIRS ? p->n_correlated
                                                              : KINCAL_MAX_CORRELATED_PAIRS;
    mxArray *s = mxCreateStructMatrix(1, 1, 13, (const char **)REPORT_FIELDS);
    mxArray *corr = mxCreateStructMatrix(1, (mwSize)nc, 3, (const char **)CORRELATION_FIELDS);
    for (i = 0; i < nc; ++i) {
        mxSetField(corr, (mwIndex)i, "a", label_of(r, p->correlated[i].a));
        mxSetField(corr, (mwIndex)i, "b", label_of(r, p->correlated[i].b));
        mxSetField(corr, (mwIndex)i, "rho", mxCreateDoubleScalar(p->correlated[i].rho));
    }
    mxSetField(s, 0, "algorithm", mxCreateString(algorithm_name(p->algorithm)));
    mxSetField(s, 0, "iterations", mxCreateDoubleScalar((double)p->iterations));
    mxSetField(s, 0, "analysis", analysis_struct(r, &p->analysis));
    mxSetField(s, 0, "initial", stats_struct(&p->initial));
    mxSetField(s, 0, "fitted", stats_struct(&p->fitted));
    mxSetField(s, 0, "sigma2", mxCreateDoubleScalar(p->sigma2));
    mxSetField(s, 0, "std_errors", column(p->std_errors, np));
    mxSetField(s, 0, "at_bound", mask_array(p->at_bound, np));
    mxSetField(s, 0, "at_bound_labels", mask_labels(r, p->at_bound, np));
    mxSetField(s, 0, "correlations", corr);
    mxSetField(s, 0, "n_correlated", mxCreateDoubleScalar((double)p->n_correlated));
    mxSetField(s, 0, "prior_chi2", mxCreateDoubleScalar(p->prior_chi2));
    mxSetField(s, 0, "prior_rows", mxCreateDoubleScalar((double)p->prior_rows));
    return s;
}

/* identify(robot, q N x M, T 4x4xM, components 1 x M or [], aux, options) -> robot, report */
static int op_identify(kc_ctx *c, int nlhs, mxArray *plhs[], const mxArray *prhs[])
{
    kincal_robot r, out;
    kincal_measurements m;
    kincal_identify_options o;
    kincal_identify_report *report;
    kincal_error err;
    kincal_status st;
    void *ws;
    size_t ws_len;
    char name[64];
    if (get_robot(c, prhs[0], &r) != 0 ||
        get_measurements(c, &r, prhs[1], prhs[2], prhs[3], prhs[4], &m) != 0 ||
        get_identify_options(c, &r, prhs[5], &o) != 0 ||
        get_pose_weights(c, prhs[5], &m) != 0 ||
        get_workspace(c, &r, &m, &o, &ws, &ws_len) != 0) {
        return -1;
    }
    report = (kincal_identify_report *)kc_alloc(c, sizeof *report);
    if (report == NULL) {
        return -1;
    }
    st = kincal_identify(&r, &m, &o, ws, ws_len, &out, report, &err);
    if (st != KINCAL_STATUS_OK) {
        return fail_status(c, st, &err, NULL);
    }
    robot_name(prhs[0], name, sizeof name);
    if (put_robot(c, &out, name, &plhs[0]) != 0) {
        return -1;
    }
    if (nlhs > 1) {
        plhs[1] = report_struct(&r, report);
    }
    return 0;
}

/* identifiability(robot, q, T, components, aux, options) -> analysis struct */
static int op_identifiability(kc_ctx *c, int nlhs, mxArray *plhs[], const mxArray *prhs[])
{
    kincal_robot r;
    kincal_measurements m;
    kincal_identify_options o;
    kincal_identifiability *a;
    kincal_error err;
    kincal_status st;
    void *ws;
    size_t ws_len;
    (void)nlhs;
    if (get_robot(c, prhs[0], &r) != 0 ||
        get_measurements(c, &r, prhs[1], prhs[2], prhs[3], prhs[4], &m) != 0 ||
        get_identify_options(c, &r, prhs[5], &o) != 0 ||
        get_pose_weights(c, prhs[5], &m) != 0 ||
        get_workspace(c, &r, &m, &o, &ws, &ws_len) != 0) {
        return -1;
    }
    a = (kincal_identifiability *)kc_alloc(c, sizeof *a);
    if (a == NULL) {
        return -1;
    }
    st = kincal_analyze_identifiability(&r, &m, &o, ws, ws_len, a, &err);
    if (st != KINCAL_STATUS_OK) {
        return fail_status(c, st, &err, NULL);
    }
    plhs[0] = analysis_struct(&r, a);
    return 0;
}

static const char *const SUMMARY_FIELDS[] = {
    "count", "rms_pos_m", "max_pos_m", "rms_rot_rad", "max_rot_rad", "pos_ok", "rot_ok", NULL,
};

/* validate(robot, q, T, aux, targets [pos_m, rot_rad] or []) -> errors 8 x M, summary */
static int op_validate(kc_ctx *c, int nlhs, mxArray *plhs[], const mxArray *prhs[])
{
    kincal_robot r;
    kincal_measurements m;
    kincal_validation_summary sum;
    kincal_error err;
    kincal_status st;
    double target_pos = KINCAL_TARGET_POS_M, target_rot = KINCAL_TARGET_ROT_RAD;
    mxArray *s;
    if (get_robot(c, prhs[0], &r) != 0 ||
        get_measurements(c, &r, prhs[1], prhs[2], NULL, prhs[3], &m) != 0) {
        return -1;
    }
    if (!is_default(prhs[4])) {
        const double *t;
        if (get_vector(c, prhs[4], "targets", 2, &t) != 0) {
            return -1;
        }
        target_pos = t[0];
        target_rot = t[1];
    }
    plhs[0] = mxCreateDoubleMatrix(KINCAL_POSE_ERRORS_LEN, (mwSize)m.n_poses, mxREAL);
    st = kincal_validate(&r, &m, target_pos, target_rot, KC_DOUBLES(plhs[0]),
                         KINCAL_POSE_ERRORS_LEN * m.n_poses, &sum, &err);
    if (st != KINCAL_STATUS_OK) {
        return fail_status(c, st, &err, NULL);
    }
    if (nlhs > 1) {
        s = mxCreateStructMatrix(1, 1, 7, (const char **)SUMMARY_FIELDS);
        mxSetField(s, 0, "count", mxCreateDoubleScalar((double)sum.count));
        mxSetField(s, 0, "rms_pos_m", mxCreateDoubleScalar(sum.rms_pos_m));
        mxSetField(s, 0, "max_pos_m", mxCreateDoubleScalar(sum.max_pos_m));
        mxSetField(s, 0, "rms_rot_rad", mxCreateDoubleScalar(sum.rms_rot_rad));
        mxSetField(s, 0, "max_rot_rad", mxCreateDoubleScalar(sum.max_rot_rad));
        mxSetField(s, 0, "pos_ok", mxCreateLogicalScalar(sum.pos_ok != 0));
        mxSetField(s, 0, "rot_ok", mxCreateLogicalScalar(sum.rot_ok != 0));
        plhs[1] = s;
    }
    return 0;
}

/* biopsy_rotation(r_t_m, d_m, l_max_m) -> allowed orientation error [rad] (eq. 3) */
static int op_biopsy_rotation(kc_ctx *c, int nlhs, mxArray *plhs[], const mxArray *prhs[])
{
    double rt, d, l, v;
    kincal_error err;
    kincal_status st;
    (void)nlhs;
    if (get_scalar(c, prhs[0], "r_t_m", &rt) != 0 || get_scalar(c, prhs[1], "d_m", &d) != 0 ||
        get_scalar(c, prhs[2], "l_max_m", &l) != 0) {
        return -1;
    }
    st = kincal_biopsy_allowed_rotation(rt, d, l, &v, &err);
    if (st != KINCAL_STATUS_OK) {
        return fail_status(c, st, &err, NULL);
    }
    plhs[0] = mxCreateDoubleScalar(v);
    return 0;
}
#endif /* KINCAL_WORKSPACE_ALIGN */

/* ------------------------------------------------------------------------------------------ */
/* Marker registration and robots from joint axes                                             */
/* ------------------------------------------------------------------------------------------ */

/* An M x 3 Matlab matrix (column-major) as the M x 3 row-major table of the C ABI, in scratch
 * memory. `finite` 0 lets NaN through (invisible markers). */
static int get_rows3(kc_ctx *c, const mxArray *a, const char *name, size_t m, int finite,
                     double **out)
{
    const double *p;
    double *t;
    size_t i, k;
    char got[64];
    if (check_double(c, a, name, finite) != 0) {
        return -1;
    }
    if (mxGetNumberOfDimensions(a) != 2 || mxGetN(a) != 3 || (m != KC_ANY && mxGetM(a) != m)) {
        char r[24];
        dim_str(m, r, sizeof r);
        return fail(c, "badSize", "argument '%s' must be %sx3, got %s", name, r,
                    size_str(a, got, sizeof got));
    }
    m = mxGetM(a);
    p = KC_DOUBLES(a);
    t = (double *)kc_alloc(c, 3 * m * sizeof *t);
    if (t == NULL) {
        return -1;
    }
    for (i = 0; i < m; ++i) {
        for (k = 0; k < 3; ++k) {
            t[3 * i + k] = p[k * m + i];
        }
    }
    *out = t;
    return 0;
}

#if defined(KINCAL_MAX_MARKERS)
#define KC_HAS_REGISTRATION 1

static const char *const REGISTRATION_OPTION_FIELDS[] = {"sigma_m", "k_sigma", "max_outliers",
                                                         NULL};
static const char *const REGISTRATION_FIELDS[] = {"n_used", "rms_m", "consistent", "ambiguous",
                                                  "markers", NULL};
static const char *const MARKER_FIELDS[] = {
    "predicted_m", "residual_m", "distance_m", "threshold_m", "status", "swapped_with", NULL,
};

static const char *marker_status_name(uint32_t s)
{
    switch (s) {
    case KINCAL_MARKER_STATUS_INLIER: return "inlier";
    case KINCAL_MARKER_STATUS_MISSING: return "missing";
    case KINCAL_MARKER_STATUS_MOVED: return "moved";
    case KINCAL_MARKER_STATUS_SWAPPED: return "swapped";
    case KINCAL_MARKER_STATUS_SUSPECT: return "suspect";
    default: return "unknown";
    }
}

/* register(design M x 3, measured M x 3 (NaN rows: not seen), weights M x 1 or [], options
 * struct with sigma_m (required), k_sigma, max_outliers) -> T 4x4 (body in the mocap frame),
 * info struct */
static int op_register(kc_ctx *c, int nlhs, mxArray *plhs[], const mxArray *prhs[])
{
    double *design, *measured;
    const double *w = NULL;
    uint8_t *visible;
    size_t m, i, k;
    double sigma;
    const mxArray *f;
    kincal_registration_options o;
    kincal_registration *reg;
    kincal_error err;
    kincal_status st;
    if (get_rows3(c, prhs[0], "design", KC_ANY, 1, &design) != 0) {
        return -1;
    }
    m = mxGetM(prhs[0]);
    if (get_rows3(c, prhs[1], "measured", m, 0, &measured) != 0) {
        return -1;
    }
    if (!is_default(prhs[2]) && get_vector(c, prhs[2], "weights", m, &w) != 0) {
        return -1;
    }
    if (check_struct(c, prhs[3], "options", REGISTRATION_OPTION_FIELDS) != 0 ||
        (f = get_field(c, prhs[3], "options", "sigma_m")) == NULL ||
        get_scalar(c, f, "options.sigma_m", &sigma) != 0) {
        return -1;
    }
    st = kincal_registration_options_default(sigma, &o, &err);
    if (st != KINCAL_STATUS_OK) {
        return fail_status(c, st, &err, NULL);
    }
    if ((f = mxGetField(prhs[3], 0, "k_sigma")) != NULL &&
        get_scalar(c, f, "options.k_sigma", &o.k_sigma) != 0) {
        return -1;
    }
    if ((f = mxGetField(prhs[3], 0, "max_outliers")) != NULL &&
        get_count(c, f, "options.max_outliers", 1e6, &o.max_outliers) != 0) {
        return -1;
    }
    /* A marker is seen when its three coordinates are numbers: NaN marks a missing one. */
    visible = (uint8_t *)kc_alloc(c, m > 0 ? m : 1);
    reg = (kincal_registration *)kc_alloc(c, sizeof *reg);
    if (visible == NULL || reg == NULL) {
        return -1;
    }
    for (i = 0; i < m; ++i) {
        visible[i] = 1;
        for (k = 0; k < 3; ++k) {
            if (measured[3 * i + k] != measured[3 * i + k]) {
                visible[i] = 0;
            } else if (!mxIsFinite(measured[3 * i + k])) {
                return fail(c, "nonFinite", "argument 'measured': marker %.0f is infinite (NaN "
                            "marks a marker that was not seen)", one_based(i));
            }
        }
    }
    st = kincal_register(design, 3 * m, measured, 3 * m, visible, m, w, w ? m : 0, &o, reg,
                         &err);
    if (st != KINCAL_STATUS_OK) {
        return fail_status(c, st, &err, NULL);
    }
    plhs[0] = mxCreateDoubleMatrix(4, 4, mxREAL);
    memcpy(KC_DOUBLES(plhs[0]), reg->t_mocap_body, sizeof reg->t_mocap_body);
    if (nlhs > 1) {
        size_t n = reg->n_markers < KINCAL_MAX_MARKERS ? reg->n_markers : KINCAL_MAX_MARKERS;
        mxArray *s = mxCreateStructMatrix(1, 1, 5, (const char **)REGISTRATION_FIELDS);
        mxArray *mk = mxCreateStructMatrix((mwSize)n, 1, 6, (const char **)MARKER_FIELDS);
        for (i = 0; i < n; ++i) {
            const kincal_marker_fit *mf = &reg->markers[i];
            mxArray *pred = mxCreateDoubleMatrix(1, 3, mxREAL);
            mxArray *res = mxCreateDoubleMatrix(1, 3, mxREAL);
            memcpy(KC_DOUBLES(pred), mf->predicted_m, sizeof mf->predicted_m);
            memcpy(KC_DOUBLES(res), mf->residual_m, sizeof mf->residual_m);
            mxSetField(mk, (mwIndex)i, "predicted_m", pred);
            mxSetField(mk, (mwIndex)i, "residual_m", res);
            mxSetField(mk, (mwIndex)i, "distance_m", mxCreateDoubleScalar(mf->distance_m));
            mxSetField(mk, (mwIndex)i, "threshold_m", mxCreateDoubleScalar(mf->threshold_m));
            mxSetField(mk, (mwIndex)i, "status", mxCreateString(marker_status_name(mf->status)));
            mxSetField(mk, (mwIndex)i, "swapped_with",
                       mf->swapped_with == KINCAL_NO_INDEX
                           ? mxCreateDoubleMatrix(0, 0, mxREAL)
                           : mxCreateDoubleScalar(one_based(mf->swapped_with)));
        }
        mxSetField(s, 0, "n_used", mxCreateDoubleScalar((double)reg->n_used));
        mxSetField(s, 0, "rms_m", mxCreateDoubleScalar(reg->rms_m));
        mxSetField(s, 0, "consistent", mxCreateLogicalScalar(reg->consistent != 0));
        mxSetField(s, 0, "ambiguous", mxCreateLogicalScalar(reg->ambiguous != 0));
        mxSetField(s, 0, "markers", mk);
        plhs[1] = s;
    }
    return 0;
}

/* t_base_ee(t_mocap_base 4x4xM or 4x4, t_mocap_ee 4x4xM) -> 4x4xM */
static int op_t_base_ee(kc_ctx *c, int nlhs, mxArray *plhs[], const mxArray *prhs[])
{
    const double *tb, *te;
    size_t mb, me, j;
    double *out;
    kincal_error err;
    kincal_status st;
    char what[64];
    (void)nlhs;
    if (get_poses(c, prhs[0], "t_mocap_base", &mb, &tb) != 0 ||
        get_poses(c, prhs[1], "t_mocap_ee", &me, &te) != 0) {
        return -1;
    }
    if (mb != me && mb != 1) {
        return fail(c, "badSize", "argument 't_mocap_base' must be 4x4 or 4x4x%lu like "
                    "'t_mocap_ee', got 4x4x%lu", (unsigned long)me, (unsigned long)mb);
    }
    plhs[0] = create_poses(me);
    out = KC_DOUBLES(plhs[0]);
    for (j = 0; j < me; ++j) {
        st = kincal_t_base_ee(tb + (mb == 1 ? 0 : 16 * j), 16, te + 16 * j, 16, out + 16 * j, 16,
                              &err);
        if (st != KINCAL_STATUS_OK) {
            return fail_status(c, st, &err, column_of(what, sizeof what, "the poses", j, me));
        }
    }
    return 0;
}
#endif /* KINCAL_MAX_MARKERS */

/* ------------------------------------------------------------------------------------------ */
/* Where camera poses look                                                                    */
/* ------------------------------------------------------------------------------------------ */

static const kc_name AXES[] = {
    {"x", KINCAL_AXIS_X},
    {"y", KINCAL_AXIS_Y},
    {"z", KINCAL_AXIS_Z},
    {NULL, 0},
};

static const char *const VIEW_POINT_FIELDS[] = {
    "point_m", "mean_distance_m", "min_distance_m", "max_distance_m",
    "miss_rms_m", "miss_max_m", "miss_max_pose", NULL,
};

/* view_point(T 4x4xM, axis 'x'|'y'|'z') -> struct (point_m 3x1, distances, misses,
 * miss_max_pose 1-based), 4x4xM poses moved along their axis by mean_distance_m */
static int op_view_point(kc_ctx *c, int nlhs, mxArray *plhs[], const mxArray *prhs[])
{
    const double *t;
    size_t m, j;
    uint32_t axis;
    double point[3] = {0.0, 0.0, 0.0}, *moved;
    kincal_view_point_result v;
    kincal_error err;
    kincal_status st;
    char what[64];
    mxArray *p;
    if (get_poses(c, prhs[0], "T", &m, &t) != 0 ||
        get_choice(c, prhs[1], "axis", AXES, &axis) != 0) {
        return -1;
    }
    st = kincal_view_point(t, 16 * m, m, axis, &v, &err);
    if (st != KINCAL_STATUS_OK) {
        return fail_status(c, st, &err, NULL);
    }
    plhs[0] = mxCreateStructMatrix(1, 1, 7, (const char **)VIEW_POINT_FIELDS);
    p = mxCreateDoubleMatrix(3, 1, mxREAL);
    memcpy(KC_DOUBLES(p), v.point_m, sizeof v.point_m);
    mxSetField(plhs[0], 0, "point_m", p);
    mxSetField(plhs[0], 0, "mean_distance_m", mxCreateDoubleScalar(v.mean_distance_m));
    mxSetField(plhs[0], 0, "min_distance_m", mxCreateDoubleScalar(v.min_distance_m));
    mxSetField(plhs[0], 0, "max_distance_m", mxCreateDoubleScalar(v.max_distance_m));
    mxSetField(plhs[0], 0, "miss_rms_m", mxCreateDoubleScalar(v.miss_rms_m));
    mxSetField(plhs[0], 0, "miss_max_m", mxCreateDoubleScalar(v.miss_max_m));
    mxSetField(plhs[0], 0, "miss_max_pose", mxCreateDoubleScalar(one_based(v.miss_max_pose)));
    if (nlhs > 1) {
        point[axis < 3 ? axis : 2] = v.mean_distance_m;
        plhs[1] = create_poses(m);
        moved = KC_DOUBLES(plhs[1]);
        for (j = 0; j < m; ++j) {
            st = kincal_moved_to_point(t + 16 * j, 16, point, 3, moved + 16 * j, 16, &err);
            if (st != KINCAL_STATUS_OK) {
                return fail_status(c, st, &err, column_of(what, sizeof what, "the poses", j, m));
            }
        }
    }
    return 0;
}

/* robot_from_axes(points N x 3, directions N x 3, t_ref_base 4x4 or [], t_ref_tool 4x4 or [],
 * limits N x 2, name) -> robot */
static int op_robot_from_axes(kc_ctx *c, int nlhs, mxArray *plhs[], const mxArray *prhs[])
{
    double *points, *dirs, lim[2 * KINCAL_MAX_JOINTS];
    const double *tb = NULL, *tt = NULL, *l;
    size_t n, i, m;
    char name[64];
    kincal_robot r;
    kincal_error err;
    kincal_status st;
    (void)nlhs;
    if (get_rows3(c, prhs[0], "points", KC_ANY, 1, &points) != 0) {
        return -1;
    }
    n = mxGetM(prhs[0]);
    if (n < 1 || n > KINCAL_MAX_JOINTS) {
        return fail(c, "badJointCount", "argument 'points' must have 1..%d rows, got %lu",
                    KINCAL_MAX_JOINTS, (unsigned long)n);
    }
    if (get_rows3(c, prhs[1], "directions", n, 1, &dirs) != 0) {
        return -1;
    }
    if (!is_default(prhs[2]) && (get_poses(c, prhs[2], "t_ref_base", &m, &tb) != 0 || m != 1)) {
        return m != 1 ? fail(c, "badSize", "argument 't_ref_base' must be 4x4") : -1;
    }
    if (!is_default(prhs[3]) && (get_poses(c, prhs[3], "t_ref_tool", &m, &tt) != 0 || m != 1)) {
        return m != 1 ? fail(c, "badSize", "argument 't_ref_tool' must be 4x4") : -1;
    }
    if (get_real_matrix(c, prhs[4], "limits", n, 2, &l) != 0 ||
        get_string(c, prhs[5], "name", name, sizeof name) != 0) {
        return -1;
    }
    for (i = 0; i < n; ++i) {
        lim[2 * i] = l[i];
        lim[2 * i + 1] = l[n + i];
    }
    st = kincal_robot_from_axes(&r, n, points, 3 * n, dirs, 3 * n, tb, tb ? 16 : 0, tt,
                                tt ? 16 : 0, lim, 2 * n, &err);
    if (st != KINCAL_STATUS_OK) {
        return fail_status(c, st, &err, NULL);
    }
    return put_robot(c, &r, name, &plhs[0]);
}

#if defined(KINCAL_TEST_PANIC)
/* test_panic() -> raises kincal:panic: the library panics on purpose inside its panic
 * boundary (cargo feature test-panic; tests/run.sh builds this variant), which proves that a
 * Rust panic comes back as a status and Octave/Matlab survive it. */
static int op_test_panic(kc_ctx *c, int nlhs, mxArray *plhs[], const mxArray *prhs[])
{
    kincal_error err;
    kincal_status st;
    (void)nlhs;
    (void)plhs;
    (void)prhs;
    st = kincal_test_panic(&err);
    if (st != KINCAL_STATUS_OK) {
        return fail_status(c, st, &err, NULL);
    }
    return fail(c, "internal", "kincal_test_panic returned OK");
}
#endif

/* ------------------------------------------------------------------------------------------ */
/* Dispatch                                                                                   */
/* ------------------------------------------------------------------------------------------ */

/* Instrument-free calibration and the diagnosis (a file of their own, same helpers). */
#include "kincal_mex_calibration.c"

#if defined(KINCAL_STD)
/* model_read(file, variant) -> robot: a model file read by kincal-io's reader (the CLI's),
 * the stored model ('') or its 'NOM', 'OLS', 'OPT1', 'OPT2' variant. A refused file raises
 * kincal:badFile with the reader's message (file:line:column: reason). */
static int op_model_read(kc_ctx *c, int nlhs, mxArray *plhs[], const mxArray *prhs[])
{
    char path[4096];
    char variant[16];
    kincal_robot r;
    kincal_read_error re;
    kincal_error err;
    kincal_status st;
    (void)nlhs;
    if (get_string(c, prhs[0], "file", path, sizeof path) != 0 ||
        get_string(c, prhs[1], "variant", variant, sizeof variant) != 0) {
        return -1;
    }
    st = kincal_model_read(path, variant, &r, &re, &err);
    if (st == KINCAL_STATUS_BAD_FILE || st == KINCAL_STATUS_INVALID_ARGUMENT) {
        char id[48];
        status_identifier(st, id, sizeof id);
        return fail(c, id, "%s", re.message);
    }
    if (st != KINCAL_STATUS_OK) {
        return fail_status(c, st, &err, NULL);
    }
    return put_robot(c, &r, "", &plhs[0]);
}

/* A 1 x k cell of the next k NUL-terminated strings of text (advances *at). */
static mxArray *next_strings(const char *text, size_t text_len, size_t *at, size_t k, size_t rows)
{
    mxArray *cell = mxCreateCellMatrix((mwSize)rows, (mwSize)(rows > 0 ? k / rows : k));
    size_t i;
    for (i = 0; i < k && *at < text_len; ++i) {
        mxSetCell(cell, (mwIndex)i, mxCreateString(text + *at));
        *at += strlen(text + *at) + 1;
    }
    return cell;
}

static const char *const MEASUREMENT_FIELDS[] = {
    "comments", "columns", "n_joints", "n_poses", "line", "q", "T", "has_position",
    "orientation", "pose_id", "approach", "temp_c", "extra", NULL,
};

/* read_measurements(file, robot or [], flags) -> struct: a measurement CSV read by
 * kincal-io's reader (the CLI's), in SI units; kincal_read_measurements.m shapes the
 * toolbox's struct from it. A refused file raises kincal:csv with the reader's message
 * (file:line: column 'name': reason). */
static int op_read_measurements(kc_ctx *c, int nlhs, mxArray *plhs[], const mxArray *prhs[])
{
    char path[4096];
    kincal_robot r;
    const kincal_robot *robot = NULL;
    double flags_d;
    kincal_measurement_sizes z;
    kincal_measurement_buffers b;
    kincal_read_error re;
    kincal_error err;
    kincal_status st;
    size_t l, n, i, j, at = 0;
    mxArray *s, *a;
    double *d;
    (void)nlhs;
    if (get_string(c, prhs[0], "file", path, sizeof path) != 0) {
        return -1;
    }
    if (!mxIsEmpty(prhs[1])) {
        if (get_robot(c, prhs[1], &r) != 0) {
            return -1;
        }
        robot = &r;
    }
    if (get_scalar(c, prhs[2], "flags", &flags_d) != 0) {
        return -1;
    }
    st = kincal_measurements_read_sizes(path, robot, (uint32_t)flags_d, &z, &re, &err);
    if (st == KINCAL_STATUS_BAD_FILE) {
        return fail(c, "csv", "%s", re.message);
    }
    if (st != KINCAL_STATUS_OK) {
        return fail_status(c, st, &err, NULL);
    }
    if (z.has_contacts) {
        return fail(c, "csv", "%s:%lu: contact columns (point_x/y/z, target, plane, session): "
                    "the toolbox reads measured poses only; calibrate contact data with the CLI "
                    "(kincal calibrate)", path, (unsigned long)z.header_line);
    }
    l = z.n_rows;
    n = z.n_joints;
    memset(&b, 0, sizeof b);
    b.q_len = l * n;
    b.poses_len = 16 * l;
    b.masks_len = l;
    b.aux_len = l;
    b.lines_len = l;
    b.text_len = z.text_len;
    b.q = (double *)kc_alloc(c, b.q_len * sizeof(double));
    b.poses = (double *)kc_alloc(c, b.poses_len * sizeof(double));
    b.masks = (uint8_t *)kc_alloc(c, l);
    b.aux = (kincal_joint_aux *)kc_alloc(c, l * sizeof(kincal_joint_aux));
    b.lines = (size_t *)kc_alloc(c, l * sizeof(size_t));
    b.text = (char *)kc_alloc(c, z.text_len);
    if (b.q == NULL || b.poses == NULL || b.masks == NULL || b.aux == NULL || b.lines == NULL ||
        b.text == NULL) {
        return -1;
    }
    st = kincal_measurements_read(path, robot, (uint32_t)flags_d, &b, &re, &err);
    if (st == KINCAL_STATUS_BAD_FILE) {
        return fail(c, "csv", "%s", re.message);
    }
    if (st != KINCAL_STATUS_OK) {
        return fail_status(c, st, &err, NULL);
    }
    for (j = 0; j < l; ++j) {
        if (z.has_position && b.masks[j] != 0x07 && b.masks[j] != 0x3f) {
            return fail(c, "csv", "%s:%lu: some of x, y, z empty: the toolbox's struct holds "
                        "whole positions only; calibrate such data with the CLI", path,
                        (unsigned long)b.lines[j]);
        }
    }
    s = mxCreateStructMatrix(1, 1, 13, (const char **)MEASUREMENT_FIELDS);
    plhs[0] = s;
    mxSetField(s, 0, "comments", next_strings(b.text, b.text_len, &at, z.n_comments, 1));
    mxSetField(s, 0, "columns", next_strings(b.text, b.text_len, &at, z.n_columns, 1));
    mxSetField(s, 0, "n_joints", mxCreateDoubleScalar((double)n));
    mxSetField(s, 0, "n_poses", mxCreateDoubleScalar((double)l));
    a = mxCreateDoubleMatrix(1, (mwSize)l, mxREAL);
    for (j = 0, d = KC_DOUBLES(a); j < l; ++j) {
        d[j] = (double)b.lines[j];
    }
    mxSetField(s, 0, "line", a);
    /* q: the ABI's L x N row-major is Matlab's N x L column-major. */
    a = mxCreateDoubleMatrix((mwSize)n, (mwSize)l, mxREAL);
    memcpy(KC_DOUBLES(a), b.q, l * n * sizeof(double));
    mxSetField(s, 0, "q", a);
    a = create_poses(l);
    memcpy(KC_DOUBLES(a), b.poses, 16 * l * sizeof(double));
    mxSetField(s, 0, "T", a);
    mxSetField(s, 0, "has_position", mxCreateLogicalScalar(z.has_position != 0));
    mxSetField(s, 0, "orientation", mxCreateString(z.orientation == 1   ? "rpy"
                                                   : z.orientation == 2 ? "quaternion"
                                                                        : ""));
    a = mxCreateCellMatrix(z.has_pose_id ? 1 : 0, z.has_pose_id ? (mwSize)l : 0);
    mxSetField(s, 0, "pose_id", a);
    if (z.has_approach) {
        a = mxCreateDoubleMatrix((mwSize)n, (mwSize)l, mxREAL);
        for (j = 0, d = KC_DOUBLES(a); j < l; ++j) {
            for (i = 0; i < n; ++i) {
                d[j * n + i] = b.aux[j].approach[i];
            }
        }
    } else {
        a = mxCreateDoubleMatrix(0, 0, mxREAL);
    }
    mxSetField(s, 0, "approach", a);
    if (z.has_temperature) {
        a = mxCreateDoubleMatrix(1, (mwSize)l, mxREAL);
        for (j = 0, d = KC_DOUBLES(a); j < l; ++j) {
            d[j] = b.aux[j].temp_c;
        }
    } else {
        a = mxCreateDoubleMatrix(0, 0, mxREAL);
    }
    mxSetField(s, 0, "temp_c", a);
    /* Per row: pose_id (if any), then the extra cells: an L x K cell of the extras. */
    a = mxCreateCellMatrix((mwSize)l, (mwSize)z.n_extra);
    for (j = 0; j < l; ++j) {
        if (z.has_pose_id && at < b.text_len) {
            mxSetCell(mxGetField(s, 0, "pose_id"), (mwIndex)j, mxCreateString(b.text + at));
            at += strlen(b.text + at) + 1;
        }
        for (i = 0; i < z.n_extra && at < b.text_len; ++i) {
            mxSetCell(a, (mwIndex)(i * l + j), mxCreateString(b.text + at));
            at += strlen(b.text + at) + 1;
        }
    }
    mxSetField(s, 0, "extra", a);
    return 0;
}
#endif

typedef struct kc_operation {
    const char *name;
    kc_handler handler;
    int nrhs; /* exact number of arguments after the operation name */
    int nlhs; /* largest number of outputs */
} kc_operation;

static int op_operations(kc_ctx *c, int nlhs, mxArray *plhs[], const mxArray *prhs[]);

static const kc_operation OPERATIONS[] = {
    {"version", op_version, 0, 1},
    {"status_table", op_status_table, 0, 3},
    {"robot_aria", op_robot_aria, 1, 1},
    {"robot_check", op_robot_check, 1, 1},
    {"robot_init", op_robot_init, 3, 1},
    {"robot_set", op_robot_set, 3, 1},
    {"param_get", op_param_get, 2, 1},
    {"param_set", op_param_set, 3, 1},
    {"param_mask", op_param_mask, 2, 1},
    {"active_effects", op_active_effects, 1, 1},
    {"effect_names", op_effect_names, 0, 1},
    {"clear_effects", op_clear_effects, 2, 1},
    {"fk", op_fk, 3, 1},
    {"frames", op_frames, 3, 1},
    {"jacobian", op_jacobian, 4, 2},
    {"ik", op_ik, 5, 2},
    {"pose_error", op_pose_error, 3, 1},
    {"pose_from_xyzrpy", op_pose_from_xyzrpy, 1, 1},
    {"pose_to_xyzrpy", op_pose_to_xyzrpy, 1, 1},
    {"pose_from_pq", op_pose_from_pq, 1, 1},
    {"pose_to_pq", op_pose_to_pq, 1, 1},
    {"aria_tool", op_aria_tool, 0, 2},
    {"gravity_torques", op_gravity_torques, 2, 1},
    {"joint_angles", op_joint_angles, 3, 1},
    {"check_limits", op_check_limits, 2, 0},
    {"operations", op_operations, 0, 1},
#if defined(KC_HAS_IDENTIFY)
    {"identify", op_identify, 6, 2},
    {"identifiability", op_identifiability, 6, 1},
    {"validate", op_validate, 5, 2},
    {"biopsy_rotation", op_biopsy_rotation, 3, 1},
#endif
#if defined(KC_HAS_CALIBRATION)
    {"identify_constraints", op_identify_constraints, 5, 2},
    {"diagnose", op_diagnose, 7, 3},
#endif
#if defined(KC_HAS_REGISTRATION)
    {"register", op_register, 4, 2},
    {"t_base_ee", op_t_base_ee, 2, 1},
#endif
    {"robot_from_axes", op_robot_from_axes, 6, 1},
    {"view_point", op_view_point, 2, 2},
#if defined(KINCAL_STD)
    {"model_read", op_model_read, 2, 1},
    {"read_measurements", op_read_measurements, 3, 1},
#endif
#if defined(KC_HAS_OBSERVABILITY)
    {"observability", op_observability, 5, 2},
    {"select_poses", op_select_poses, 10, 2},
    {"cluster_select", op_cluster_select, 10, 2},
#endif
#if defined(KINCAL_TEST_PANIC)
    {"test_panic", op_test_panic, 0, 0},
#endif
    {NULL, NULL, 0, 0},
};

/* operations() -> 1 x K cell of the operation names this build dispatches (the set depends
 * on the exports of the linked C ABI). */
static int op_operations(kc_ctx *c, int nlhs, mxArray *plhs[], const mxArray *prhs[])
{
    const kc_operation *o;
    mwIndex k = 0;
    (void)c;
    (void)nlhs;
    (void)prhs;
    for (o = OPERATIONS; o->name != NULL; ++o) {
        ++k;
    }
    plhs[0] = mxCreateCellMatrix(1, (mwSize)k);
    for (k = 0, o = OPERATIONS; o->name != NULL; ++o, ++k) {
        mxSetCell(plhs[0], k, mxCreateString(o->name));
    }
    return 0;
}

void mexFunction(int nlhs, mxArray *plhs[], int nrhs, const mxArray *prhs[])
{
    char op[48];
    const kc_operation *o;
    kc_ctx c;
    int i, rc;

    memset(&c, 0, sizeof c);
    c.op = "mex";
    if (nrhs < 1 || !mxIsChar(prhs[0]) || mxGetNumberOfElements(prhs[0]) >= sizeof op ||
        mxGetString(prhs[0], op, (mwSize)sizeof op) != 0) {
        mexErrMsgIdAndTxt("kincal:unknownOperation",
                          "kincal_mex: the first argument must name an operation");
        return;
    }
    if (kincal_robot_size() != sizeof(kincal_robot)) {
        mexErrMsgIdAndTxt("kincal:abiMismatch",
                          "kincal_mex: include/kincal.h and the linked library disagree "
                          "(sizeof(kincal_robot) %lu vs %lu); rebuild with make_kincal",
                          (unsigned long)sizeof(kincal_robot),
                          (unsigned long)kincal_robot_size());
        return;
    }
    for (o = OPERATIONS; o->name != NULL; ++o) {
        if (strcmp(o->name, op) == 0) {
            break;
        }
    }
    if (o->name == NULL) {
        mexErrMsgIdAndTxt("kincal:unknownOperation",
                          "kincal_mex: unknown operation '%s' (the C ABI this gateway was built "
                          "against may predate it; rebuild with make_kincal)",
                          op);
        return;
    }
    c.op = o->name;
    if (nrhs - 1 != o->nrhs || nlhs > (o->nlhs > 0 ? o->nlhs : 1)) {
        mexErrMsgIdAndTxt("kincal:badArgCount",
                          "kincal_mex: operation '%s' takes %d arguments and gives at most %d "
                          "outputs (got %d arguments, %d outputs)",
                          o->name, o->nrhs, o->nlhs, nrhs - 1, nlhs);
        return;
    }
    for (i = 0; i < nlhs || i < 1; ++i) {
        plhs[i] = NULL;
    }
    rc = o->handler(&c, nlhs, plhs, prhs + 1);
    kc_free_all(&c);
    if (rc != 0) {
        /* Rust has returned and every buffer is an mxArray or on the stack: drop the partial
         * outputs, then raise (mexErrMsgIdAndTxt does not return). */
        for (i = 0; i < nlhs || i < 1; ++i) {
            if (plhs[i] != NULL) {
                mxDestroyArray(plhs[i]);
                plhs[i] = NULL;
            }
        }
        mexErrMsgIdAndTxt(c.fail.id, "%s", c.fail.msg);
    }
}
