/*
 * Gateway operations of instrument-free calibration and of the diagnosis, included by
 * kincal_mex.c (one gateway, one dispatch table; this file uses its static helpers):
 *
 *   identify_constraints(robot, q N x L, rows, constraints, options) -> robot, report
 *   diagnose(robot, q, T, components, aux, groups, options) -> model, report, geometric
 *
 * Indices from Matlab are 1-based (target, plane, session, distance ends; 0 = none); the
 * diagnosis report has the field names of the CLI's REPORT.json (mm and degrees where it
 * says so).
 */

#if defined(KINCAL_NO_GROUP) && defined(KINCAL_DIAG_MAX_CANDIDATES)
#define KC_HAS_CALIBRATION 1

static mxArray *kc_struct1(const char *const *fields)
{
    int n = 0;
    while (fields[n] != NULL) {
        ++n;
    }
    return mxCreateStructMatrix(1, 1, n, (const char **)fields);
}

static void set_num(mxArray *s, mwIndex i, const char *field, double v)
{
    mxSetField(s, i, field, mxCreateDoubleScalar(v));
}

static void set_bool(mxArray *s, mwIndex i, const char *field, int v)
{
    mxSetField(s, i, field, mxCreateLogicalScalar(v != 0));
}

/* 1-based ids (0 = none) of a 1 x L field, or NULL when absent or empty. */
static int get_ids(kc_ctx *c, const mxArray *rows, const char *field, size_t l, uint32_t none,
                   uint32_t **out, uint32_t *max_id)
{
    const mxArray *f = mxGetField(rows, 0, field);
    const double *v;
    char name[48];
    size_t k;
    *out = NULL;
    *max_id = 0;
    if (is_default(f)) {
        return 0;
    }
    snprintf(name, sizeof name, "rows.%s", field);
    if (get_vector(c, f, name, l, &v) != 0) {
        return -1;
    }
    *out = (uint32_t *)kc_alloc(c, l * sizeof **out);
    if (*out == NULL) {
        return -1;
    }
    for (k = 0; k < l; ++k) {
        if (v[k] < 0 || v[k] > 4294967294.0 || v[k] != (double)(uint32_t)v[k]) {
            return fail(c, "badValue", "argument '%s': row %.0f must be an id 1, 2, ... or 0 "
                        "(none), got %.17g", name, one_based(k), v[k]);
        }
        (*out)[k] = v[k] == 0 ? none : (uint32_t)v[k] - 1;
        if ((uint32_t)v[k] > *max_id) {
            *max_id = (uint32_t)v[k];
        }
    }
    return 0;
}

static const char *const ROWS_FIELDS[] = {"target", "plane", "session", "point", "coords", NULL};
static const char *const CONS_FIELDS[] = {"n_targets", "n_planes", "known_targets",
                                          "known_planes", "distances", NULL};

/* The rows and constraints of a call as kincal_constraint_data (scratch copies). */
static int get_constraint_data(kc_ctx *c, const kincal_robot *r, const mxArray *q_arg,
                               const mxArray *rows, const mxArray *cons,
                               kincal_constraint_data *d)
{
    size_t n = r->n_joints, l, k;
    const double *q;
    const mxArray *f;
    uint32_t max_t, max_p, max_s;
    memset(d, 0, sizeof *d);
    if (get_real_matrix(c, q_arg, "q", n, KC_ANY, &q) != 0 ||
        check_struct(c, rows, "rows", ROWS_FIELDS) != 0) {
        return -1;
    }
    l = mxGetN(q_arg);
    d->n_rows = l;
    d->q = q;
    d->q_len = n * l;
    {
        uint32_t *t, *p, *s;
        if (get_ids(c, rows, "target", l, KINCAL_NO_GROUP, &t, &max_t) != 0 ||
            get_ids(c, rows, "plane", l, KINCAL_NO_GROUP, &p, &max_p) != 0 ||
            get_ids(c, rows, "session", l, 0, &s, &max_s) != 0) {
            return -1;
        }
        d->target = t;
        d->target_len = t != NULL ? l : 0;
        d->plane = p;
        d->plane_len = p != NULL ? l : 0;
        d->session = s;
        d->session_len = s != NULL ? l : 0;
        d->n_sessions = max_s;
    }
    f = mxGetField(rows, 0, "point");
    if (!is_default(f)) {
        const double *pt;
        double *all;
        size_t cols;
        if (get_real_matrix(c, f, "rows.point", 3, KC_ANY, &pt) != 0) {
            return -1;
        }
        cols = mxGetN(f);
        if (cols != 1 && cols != l) {
            return fail(c, "badSize", "argument 'rows.point' must be 3x1 or 3x%lu",
                        (unsigned long)l);
        }
        all = (double *)kc_alloc(c, 3 * l * sizeof *all);
        if (all == NULL) {
            return -1;
        }
        for (k = 0; k < l; ++k) {
            memcpy(all + 3 * k, pt + (cols == 1 ? 0 : 3 * k), 3 * sizeof *all);
        }
        d->point = all;
        d->point_len = 3 * l;
    }
    f = mxGetField(rows, 0, "coords");
    if (!is_default(f)) {
        const double *xyz;
        uint8_t *mask;
        double *copy;
        size_t j;
        if (check_double(c, f, "rows.coords", 0) != 0) {
            return -1;
        }
        if (mxGetNumberOfDimensions(f) != 2 || mxGetM(f) != 3 || mxGetN(f) != l) {
            return fail(c, "badSize", "argument 'rows.coords' must be 3x%lu (NaN where not "
                        "measured)", (unsigned long)l);
        }
        xyz = KC_DOUBLES(f);
        mask = (uint8_t *)kc_alloc(c, l);
        copy = (double *)kc_alloc(c, 3 * l * sizeof *copy);
        if (mask == NULL || copy == NULL) {
            return -1;
        }
        for (k = 0; k < l; ++k) {
            mask[k] = 0;
            for (j = 0; j < 3; ++j) {
                double v = xyz[3 * k + j];
                if (v == v) {
                    mask[k] |= (uint8_t)(1u << j);
                }
                copy[3 * k + j] = v == v ? v : 0.0;
            }
        }
        d->coords = copy;
        d->coords_len = 3 * l;
        d->coord_mask = mask;
        d->coord_mask_len = l;
    }
    d->n_targets = max_t;
    d->n_planes = max_p;
    if (is_default(cons)) {
        return 0;
    }
    if (check_struct(c, cons, "constraints", CONS_FIELDS) != 0) {
        return -1;
    }
    if ((f = mxGetField(cons, 0, "n_targets")) != NULL && !is_default(f) &&
        get_count(c, f, "constraints.n_targets", 4294967294.0, &d->n_targets) != 0) {
        return -1;
    }
    if ((f = mxGetField(cons, 0, "n_planes")) != NULL && !is_default(f) &&
        get_count(c, f, "constraints.n_planes", 4294967294.0, &d->n_planes) != 0) {
        return -1;
    }
    f = mxGetField(cons, 0, "known_targets");
    if (!is_default(f)) {
        kincal_target *t;
        const double *v;
        if (check_double(c, f, "constraints.known_targets", 0) != 0) {
            return -1;
        }
        if (mxGetM(f) != 3 || mxGetN(f) > d->n_targets) {
            return fail(c, "badSize", "argument 'constraints.known_targets' must be 3xT, T <= "
                        "%lu targets (NaN columns: unknown)", (unsigned long)d->n_targets);
        }
        t = (kincal_target *)kc_alloc(c, (d->n_targets + 1) * sizeof *t);
        if (t == NULL) {
            return -1;
        }
        memset(t, 0, (d->n_targets + 1) * sizeof *t);
        v = KC_DOUBLES(f);
        for (k = 0; k < mxGetN(f); ++k) {
            if (v[3 * k] == v[3 * k]) {
                t[k].known = 1;
                memcpy(t[k].xyz_m, v + 3 * k, 3 * sizeof(double));
            }
        }
        d->targets = t;
        d->targets_len = d->n_targets;
    }
    f = mxGetField(cons, 0, "known_planes");
    if (!is_default(f)) {
        kincal_plane *p;
        const double *v;
        if (check_double(c, f, "constraints.known_planes", 0) != 0) {
            return -1;
        }
        if (mxGetM(f) != 4 || mxGetN(f) > d->n_planes) {
            return fail(c, "badSize", "argument 'constraints.known_planes' must be 4xP [normal; "
                        "offset_m], P <= %lu planes (NaN columns: unknown)",
                        (unsigned long)d->n_planes);
        }
        p = (kincal_plane *)kc_alloc(c, (d->n_planes + 1) * sizeof *p);
        if (p == NULL) {
            return -1;
        }
        memset(p, 0, (d->n_planes + 1) * sizeof *p);
        v = KC_DOUBLES(f);
        for (k = 0; k < mxGetN(f); ++k) {
            if (v[4 * k] == v[4 * k]) {
                p[k].known = 1;
                memcpy(p[k].normal, v + 4 * k, 3 * sizeof(double));
                p[k].offset_m = v[4 * k + 3];
            }
        }
        d->planes = p;
        d->planes_len = d->n_planes;
    }
    f = mxGetField(cons, 0, "distances");
    if (!is_default(f)) {
        const double *v;
        kincal_distance *dist;
        size_t m, cols;
        if (get_real_matrix(c, f, "constraints.distances", KC_ANY, KC_ANY, &v) != 0) {
            return -1;
        }
        m = mxGetM(f);
        cols = mxGetN(f);
        if (cols != 3 && cols != 4) {
            return fail(c, "badSize", "argument 'constraints.distances' must be Kx3 [a b m] or "
                        "Kx4 [a b m weight] (targets 1-based)");
        }
        dist = (kincal_distance *)kc_alloc(c, m * sizeof *dist);
        if (dist == NULL) {
            return -1;
        }
        for (k = 0; k < m; ++k) {
            size_t a = 0, b = 0;
            if (zero_based_index(c, v[k], "constraints.distances(:,1)", d->n_targets, &a) != 0 ||
                zero_based_index(c, v[m + k], "constraints.distances(:,2)", d->n_targets, &b) !=
                    0) {
                return -1;
            }
            dist[k].a = (uint32_t)a;
            dist[k].b = (uint32_t)b;
            dist[k].m = v[2 * m + k];
            dist[k].weight = cols == 4 ? v[3 * m + k] : 1.0;
        }
        d->distances = dist;
        d->distances_len = m;
        d->n_distances = m;
    }
    return 0;
}

static const char *const GROUP_FIELDS[] = {"point",  "normal", "offset_m", "contacts",
                                           "rms_m",  "max_m",  "mean_m",   "aspect",
                                           NULL};

static mxArray *estimates(const kincal_group_estimate *e, size_t n)
{
    mxArray *s = mxCreateStructMatrix(1, (mwSize)n, 8, (const char **)GROUP_FIELDS);
    size_t k;
    for (k = 0; k < n; ++k) {
        mxSetField(s, (mwIndex)k, "point", column(e[k].point, 3));
        mxSetField(s, (mwIndex)k, "normal", column(e[k].normal, 3));
        set_num(s, (mwIndex)k, "offset_m", e[k].offset_m);
        set_num(s, (mwIndex)k, "contacts", (double)e[k].contacts);
        set_num(s, (mwIndex)k, "rms_m", e[k].rms_m);
        set_num(s, (mwIndex)k, "max_m", e[k].max_m);
        set_num(s, (mwIndex)k, "mean_m", e[k].mean_m);
        set_num(s, (mwIndex)k, "aspect", e[k].aspect);
    }
    return s;
}

static const char *const CONS_REPORT_FIELDS[] = {
    "identify", "gauge", "gauge_labels", "external_reference", "length_reference",
    "n_instrument_rows", "n_contacts", "targets", "planes", "distances_m", NULL,
};

/* identify_constraints(robot, q N x L, rows, constraints, options) -> robot, report */
static int op_identify_constraints(kc_ctx *c, int nlhs, mxArray *plhs[], const mxArray *prhs[])
{
    kincal_robot r, out;
    kincal_constraint_data d;
    kincal_identify_options o;
    kincal_constraints_report *rep;
    kincal_group_estimate *t, *p;
    double *dist;
    kincal_error err;
    kincal_status st;
    size_t np, n_req = 0, i, bytes;
    char *raw, name[64];
    void *ws;
    if (get_robot(c, prhs[0], &r) != 0 ||
        get_constraint_data(c, &r, prhs[1], prhs[2], prhs[3], &d) != 0 ||
        get_identify_options(c, &r, prhs[4], &o) != 0) {
        return -1;
    }
    np = kincal_num_params(r.n_joints);
    for (i = 0; i < np; ++i) {
        n_req += o.requested[i] != 0;
    }
    bytes = kincal_identify_constraints_workspace_size(r.n_joints, d.n_rows, d.n_targets,
                                                       d.n_planes, d.n_distances, d.n_sessions,
                                                       n_req);
    if (bytes == 0) {
        return fail(c, "capacityExceeded", "no workspace size for %lu rows and %lu requested "
                    "parameters", (unsigned long)d.n_rows, (unsigned long)n_req);
    }
    raw = (char *)kc_alloc(c, bytes + KINCAL_WORKSPACE_ALIGN);
    rep = (kincal_constraints_report *)kc_alloc(c, sizeof *rep);
    t = (kincal_group_estimate *)kc_alloc(c, (d.n_targets + 1) * sizeof *t);
    p = (kincal_group_estimate *)kc_alloc(c, (d.n_planes + 1) * sizeof *p);
    dist = (double *)kc_alloc(c, (d.n_distances + 1) * sizeof *dist);
    if (raw == NULL || rep == NULL || t == NULL || p == NULL || dist == NULL) {
        return -1;
    }
    ws = raw + (KINCAL_WORKSPACE_ALIGN - (size_t)((uintptr_t)raw % KINCAL_WORKSPACE_ALIGN)) %
                   KINCAL_WORKSPACE_ALIGN;
    st = kincal_identify_constraints(&r, &d, &o, ws, bytes, &out, rep, t, d.n_targets, p,
                                     d.n_planes, dist, d.n_distances, &err);
    if (st != KINCAL_STATUS_OK) {
        return fail_status(c, st, &err, NULL);
    }
    robot_name(prhs[0], name, sizeof name);
    if (put_robot(c, &out, name, &plhs[0]) != 0) {
        return -1;
    }
    if (nlhs > 1) {
        mxArray *s = kc_struct1(CONS_REPORT_FIELDS);
        mxSetField(s, 0, "identify", report_struct(&r, &rep->identify));
        mxSetField(s, 0, "gauge", mask_array(rep->gauge, np));
        mxSetField(s, 0, "gauge_labels", mask_labels(&r, rep->gauge, np));
        set_bool(s, 0, "external_reference", (int)rep->external_reference);
        set_bool(s, 0, "length_reference", (int)rep->length_reference);
        set_num(s, 0, "n_instrument_rows", (double)rep->n_instrument_rows);
        set_num(s, 0, "n_contacts", (double)rep->n_contacts);
        mxSetField(s, 0, "targets", estimates(t, d.n_targets));
        mxSetField(s, 0, "planes", estimates(p, d.n_planes));
        mxSetField(s, 0, "distances_m", column(dist, d.n_distances));
        plhs[1] = s;
    }
    return 0;
}

/* ---------------------------------------------------------------------- diagnosis */

static const char *const DIAG_OPTION_FIELDS[] = {
    "sigma_pos_m", "sigma_rot_rad", "folds", "seed", "candidates", "pairs",
    "screen_outliers", "min_groups_per_fold", "z_gap", "z_significance", "z_equivalence",
    "explained_fraction", "partial_fraction", NULL,
};

static int get_diagnose_options(kc_ctx *c, const mxArray *a, kincal_diagnose_options *o)
{
    kincal_error err;
    kincal_status st = kincal_diagnose_options_default(o, &err);
    const mxArray *f;
    size_t v, i;
    static const char *const reals[] = {"sigma_pos_m", "sigma_rot_rad", "z_gap",
                                        "z_significance", "z_equivalence",
                                        "explained_fraction", "partial_fraction"};
    double *dst[7];
    if (st != KINCAL_STATUS_OK) {
        return fail_status(c, st, &err, NULL);
    }
    if (is_default(a)) {
        return 0;
    }
    if (check_struct(c, a, "options", DIAG_OPTION_FIELDS) != 0) {
        return -1;
    }
    dst[0] = &o->sigma_pos_m;
    dst[1] = &o->sigma_rot_rad;
    dst[2] = &o->z_gap;
    dst[3] = &o->z_significance;
    dst[4] = &o->z_equivalence;
    dst[5] = &o->explained_fraction;
    dst[6] = &o->partial_fraction;
    for (i = 0; i < 7; ++i) {
        char full[40];
        snprintf(full, sizeof full, "options.%s", reals[i]);
        if ((f = mxGetField(a, 0, reals[i])) != NULL && !is_default(f) &&
            get_scalar(c, f, full, dst[i]) != 0) {
            return -1;
        }
    }
    if ((f = mxGetField(a, 0, "folds")) != NULL && !is_default(f)) {
        if (get_count(c, f, "options.folds", 65535, &v) != 0) {
            return -1;
        }
        o->folds = (uint32_t)v;
    }
    if ((f = mxGetField(a, 0, "min_groups_per_fold")) != NULL && !is_default(f)) {
        if (get_count(c, f, "options.min_groups_per_fold", 65535, &v) != 0) {
            return -1;
        }
        o->min_groups_per_fold = (uint32_t)v;
    }
    if ((f = mxGetField(a, 0, "seed")) != NULL && !is_default(f)) {
        if (get_count(c, f, "options.seed", 9007199254740991.0, &v) != 0) {
            return -1;
        }
        o->fold_seed = (uint64_t)v;
    }
    if ((f = mxGetField(a, 0, "candidates")) != NULL && !is_default(f) &&
        get_effects(c, f, "options.candidates", &o->candidates) != 0) {
        return -1;
    }
    for (i = 0; i < 2; ++i) {
        const char *fname = i == 0 ? "pairs" : "screen_outliers";
        uint32_t *flag = i == 0 ? &o->pairs : &o->screen_outliers;
        if ((f = mxGetField(a, 0, fname)) != NULL && !is_default(f)) {
            if (mxIsLogicalScalar(f)) {
                *flag = mxIsLogicalScalarTrue(f) ? 1u : 0u;
            } else {
                char full[40];
                snprintf(full, sizeof full, "options.%s", fname);
                if (get_count(c, f, full, 1, &v) != 0) {
                    return -1;
                }
                *flag = (uint32_t)v;
            }
        }
    }
    return 0;
}

#define KC_MM(x) ((x) * 1e3)
#define KC_DEG(x) ((x) * 57.29577951308232)

/* Field `field` of s(i) = the public name (REPORT.json's text) of report code `code` of
 * `kind`, from the library: the Rust diagnosis's own names, so this file keeps no table that
 * could drift; "?" for a code the library does not know. */
static void set_name(mxArray *s, mwIndex i, const char *field, uint32_t kind, uint32_t code)
{
    const char *name = kincal_diagnosis_name(kind, code);
    mxSetField(s, i, field, mxCreateString(name != NULL ? name : "?"));
}

/* NaN for a statistic the report leaves out (REPORT.json: null). */
static double finite_or_nan(double v)
{
    return v - v == 0.0 ? v : mxGetNaN();
}

static const char *const SMOOTH_FIELDS[] = {
    "evaluated", "share_of_gap", "share_pos", "share_rot", "heldout_rms_pos_mm",
    "heldout_rms_rot_deg", "z", "significant", NULL,
};

static mxArray *smooth_struct(const kincal_smooth_check *x)
{
    mxArray *s = kc_struct1(SMOOTH_FIELDS);
    set_bool(s, 0, "evaluated", (int)x->evaluated);
    set_num(s, 0, "share_of_gap", x->share_of_gap);
    set_num(s, 0, "share_pos", x->share_pos);
    set_num(s, 0, "share_rot", x->share_rot);
    set_num(s, 0, "heldout_rms_pos_mm", KC_MM(x->heldout_rms_pos_m));
    set_num(s, 0, "heldout_rms_rot_deg", KC_DEG(x->heldout_rms_rot_rad));
    set_num(s, 0, "z", finite_or_nan(x->z));
    set_bool(s, 0, "significant", (int)x->significant);
    return s;
}

static const char *const CANDIDATE_FIELDS[] = {
    "effects", "heldout_rms_pos_mm", "heldout_rms_rot_deg", "significant", "evaluated",
    "confounded_with_geometry", "improvement_z", "z_vs_best", "z_pos", "z_rot",
    "gap_closed_fraction", "gap_closed_rot_fraction", "gap_closed_total_fraction",
    "fitted_params", "distinctness", NULL,
};

static mxArray *candidates_struct(const kincal_diagnosis_report *r)
{
    size_t n = r->n_candidates < KINCAL_DIAG_MAX_CANDIDATES ? r->n_candidates
                                                            : KINCAL_DIAG_MAX_CANDIDATES;
    mxArray *s = mxCreateStructMatrix(1, (mwSize)n, 15, (const char **)CANDIDATE_FIELDS);
    size_t k;
    for (k = 0; k < n; ++k) {
        const kincal_model_score *m = &r->candidates[k];
        mwIndex i = (mwIndex)k;
        double nan = mxGetNaN();
        mxSetField(s, i, "effects", effect_names(m->effects));
        set_num(s, i, "heldout_rms_pos_mm", KC_MM(m->heldout_rms_pos_m));
        set_num(s, i, "heldout_rms_rot_deg", KC_DEG(m->heldout_rms_rot_rad));
        set_bool(s, i, "significant", (int)m->significant);
        set_bool(s, i, "evaluated", (int)m->evaluated);
        set_bool(s, i, "confounded_with_geometry", m->evaluated == 0);
        set_num(s, i, "improvement_z", m->evaluated ? finite_or_nan(m->improvement_z) : nan);
        set_num(s, i, "z_vs_best", m->evaluated ? finite_or_nan(m->z_vs_best) : nan);
        set_num(s, i, "z_pos", m->evaluated ? finite_or_nan(m->z_pos) : nan);
        set_num(s, i, "z_rot", m->evaluated ? finite_or_nan(m->z_rot) : nan);
        set_num(s, i, "gap_closed_fraction", m->gap_closed_fraction);
        set_num(s, i, "gap_closed_rot_fraction", m->gap_closed_rot_fraction);
        set_num(s, i, "gap_closed_total_fraction", m->gap_closed_total_fraction);
        set_num(s, i, "fitted_params", (double)m->fitted_params);
        set_num(s, i, "distinctness", m->distinctness);
    }
    return s;
}

static const char *const NOISE_FIELDS[] = {
    "pos_mm", "rot_deg", "pos_source", "rot_source", "dof_pos", "dof_rot",
    "repeat_subgroups", "rms_pos_mm", "rms_rot_deg", "repeats_pos_mm", "repeats_rot_deg",
    "overruled_pos", "overruled_rot", "overruled_pos_mm", "overruled_rot_deg", NULL,
};

/* Where a noise sigma came from (REPORT.json's pos_source/rot_source): "not_measured" when
 * no row measures that component type and no sigma was stated (position-only data: the
 * orientation). */
static const char *noise_source(uint32_t stated, uint32_t measured)
{
    return stated ? "stated" : measured ? "repeats" : "not_measured";
}

/* A noise-floor value, NaN (REPORT.json's null) when the component type is not measured. */
static double known_or_nan(double v, uint32_t stated, uint32_t measured)
{
    return stated || measured ? v : mxGetNaN();
}

static mxArray *noise_struct(const kincal_noise_floor *n)
{
    mxArray *s = kc_struct1(NOISE_FIELDS);
    const uint32_t sp = n->stated_pos, mp = n->measured_pos;
    const uint32_t sr = n->stated_rot, mr = n->measured_rot;
    set_num(s, 0, "pos_mm", known_or_nan(KC_MM(n->sigma_pos_m), sp, mp));
    set_num(s, 0, "rot_deg", known_or_nan(KC_DEG(n->sigma_rot_rad), sr, mr));
    mxSetField(s, 0, "pos_source", mxCreateString(noise_source(sp, mp)));
    mxSetField(s, 0, "rot_source", mxCreateString(noise_source(sr, mr)));
    set_num(s, 0, "dof_pos", known_or_nan(finite_or_nan(n->dof_pos), sp, mp));
    set_num(s, 0, "dof_rot", known_or_nan(finite_or_nan(n->dof_rot), sr, mr));
    set_num(s, 0, "repeat_subgroups", (double)n->repeat_subgroups);
    set_num(s, 0, "rms_pos_mm", known_or_nan(KC_MM(1.7320508075688772 * n->sigma_pos_m), sp, mp));
    set_num(s, 0, "rms_rot_deg",
            known_or_nan(KC_DEG(1.7320508075688772 * n->sigma_rot_rad), sr, mr));
    set_num(s, 0, "repeats_pos_mm", KC_MM(n->repeats_pos_m));
    set_num(s, 0, "repeats_rot_deg", KC_DEG(n->repeats_rot_rad));
    set_bool(s, 0, "overruled_pos", (int)n->overruled_pos);
    set_bool(s, 0, "overruled_rot", (int)n->overruled_rot);
    set_num(s, 0, "overruled_pos_mm", KC_MM(n->overruled_pos_m));
    set_num(s, 0, "overruled_rot_deg", KC_DEG(n->overruled_rot_rad));
    return s;
}

static const char *const BASELINE_FIELDS[] = {
    "heldout_rms_pos_mm", "heldout_rms_rot_deg", "insample_rms_pos_mm", "insample_rms_rot_deg",
    "expected_rms_pos_mm", "expected_rms_rot_deg", "gap_ratio", "gap_z", "gap_z_pos",
    "gap_z_rot", "gap", "fitted_params", NULL,
};

static const char *const VERDICT_FIELDS[] = {
    "effects", "status", "confounded_with", "confounded_candidates", "gap_closed_fraction",
    "gap_closed_rot_fraction", "gap_closed_total_fraction", "reason", "reason_part",
    "reason_z", "reason_effects", "beyond_library", "beyond_library_share", "heldout_rms_pos_mm",
    "heldout_rms_rot_deg", "remaining_gap_z", "remaining_gap_z_pos", "remaining_gap_z_rot",
    "remaining_gap_significant", "remaining_rms_axis", NULL,
};

static const char *const AXIS_FIELDS[] = {"x_mm", "y_mm", "z_mm", "rx_deg", "ry_deg",
                                          "rz_deg", NULL};

static const char *const WARNING_FIELDS[] = {"code", "part", "ratio", "z", "z_gap",
                                             "z_candidate", "count", NULL};

static const char *const DIAG_REPORT_FIELDS[] = {
    "method", "warnings", "suspect_rows", "noise_floor", "baseline", "candidates", "verdict",
    "explainable", "remaining_structure", "groups", "folds", NULL,
};

static mxArray *diagnosis_struct(const kincal_diagnosis_report *r)
{
    mxArray *s = kc_struct1(DIAG_REPORT_FIELDS);
    mxArray *b = kc_struct1(BASELINE_FIELDS), *v = kc_struct1(VERDICT_FIELDS);
    mxArray *axis = kc_struct1(AXIS_FIELDS), *conf, *susp, *warn;
    size_t k, nc = r->n_confounded < KINCAL_DIAG_MAX_CANDIDATES ? r->n_confounded
                                                                : KINCAL_DIAG_MAX_CANDIDATES;
    size_t ns = r->n_suspects < KINCAL_DIAG_MAX_SUSPECTS ? r->n_suspects
                                                         : KINCAL_DIAG_MAX_SUSPECTS;
    size_t nw = r->n_warnings < KINCAL_DIAG_MAX_WARNINGS ? r->n_warnings
                                                         : KINCAL_DIAG_MAX_WARNINGS;
    const kincal_model_score *base = &r->baseline;
    set_name(s, 0, "method", KINCAL_DIAGNOSIS_NAME_KIND_METHOD, r->method);
    warn = mxCreateStructMatrix(1, (mwSize)nw, 7, (const char **)WARNING_FIELDS);
    for (k = 0; k < nw; ++k) {
        const kincal_diagnosis_warning *w = &r->warnings[k];
        set_name(warn, (mwIndex)k, "code", KINCAL_DIAGNOSIS_NAME_KIND_WARNING, w->code);
        set_name(warn, (mwIndex)k, "part", KINCAL_DIAGNOSIS_NAME_KIND_PART, w->part);
        set_num(warn, (mwIndex)k, "ratio", w->ratio);
        set_num(warn, (mwIndex)k, "z", w->z);
        set_num(warn, (mwIndex)k, "z_gap", w->z_gap);
        set_num(warn, (mwIndex)k, "z_candidate", w->z_candidate);
        set_num(warn, (mwIndex)k, "count", (double)w->count);
    }
    mxSetField(s, 0, "warnings", warn);
    susp = mxCreateDoubleMatrix(1, (mwSize)ns, mxREAL);
    for (k = 0; k < ns; ++k) {
        KC_DOUBLES(susp)[k] = one_based(r->suspects[k]);
    }
    mxSetField(s, 0, "suspect_rows", susp);
    mxSetField(s, 0, "noise_floor", noise_struct(&r->noise));
    set_num(b, 0, "heldout_rms_pos_mm", KC_MM(base->heldout_rms_pos_m));
    set_num(b, 0, "heldout_rms_rot_deg", KC_DEG(base->heldout_rms_rot_rad));
    set_num(b, 0, "insample_rms_pos_mm", KC_MM(r->insample_rms_pos_m));
    set_num(b, 0, "insample_rms_rot_deg", KC_DEG(r->insample_rms_rot_rad));
    set_num(b, 0, "expected_rms_pos_mm", KC_MM(r->gap.expected_rms_pos_m));
    set_num(b, 0, "expected_rms_rot_deg", KC_DEG(r->gap.expected_rms_rot_rad));
    set_num(b, 0, "gap_ratio", r->gap.ratio);
    set_num(b, 0, "gap_z", finite_or_nan(r->gap.z));
    set_num(b, 0, "gap_z_pos", finite_or_nan(r->gap.z_pos));
    set_num(b, 0, "gap_z_rot", finite_or_nan(r->gap.z_rot));
    set_bool(b, 0, "gap", r->status != 0);
    set_num(b, 0, "fitted_params", (double)base->fitted_params);
    mxSetField(s, 0, "baseline", b);
    mxSetField(s, 0, "candidates", candidates_struct(r));
    mxSetField(v, 0, "effects", effect_names(r->effects));
    set_name(v, 0, "status", KINCAL_DIAGNOSIS_NAME_KIND_STATUS, r->status);
    mxSetField(v, 0, "confounded_with", effect_names(r->confounded_effects));
    conf = mxCreateCellMatrix(1, (mwSize)nc);
    for (k = 0; k < nc; ++k) {
        mxSetCell(conf, (mwIndex)k, effect_names(r->confounded_with[k]));
    }
    mxSetField(v, 0, "confounded_candidates", conf);
    set_num(v, 0, "gap_closed_fraction", r->gap_closed_fraction);
    set_num(v, 0, "gap_closed_rot_fraction", r->gap_closed_rot_fraction);
    set_num(v, 0, "gap_closed_total_fraction", r->gap_closed_total_fraction);
    set_name(v, 0, "reason", KINCAL_DIAGNOSIS_NAME_KIND_REASON, r->reason);
    set_name(v, 0, "reason_part", KINCAL_DIAGNOSIS_NAME_KIND_PART, r->reason_part);
    set_num(v, 0, "reason_z", r->reason_z);
    mxSetField(v, 0, "reason_effects", effect_names(r->reason_effects));
    set_name(v, 0, "beyond_library", KINCAL_DIAGNOSIS_NAME_KIND_BEYOND_LIBRARY,
             r->beyond_library);
    set_num(v, 0, "beyond_library_share", r->beyond_library_share);
    set_num(v, 0, "heldout_rms_pos_mm", KC_MM(r->heldout_rms_pos_m));
    set_num(v, 0, "heldout_rms_rot_deg", KC_DEG(r->heldout_rms_rot_rad));
    set_num(v, 0, "remaining_gap_z", finite_or_nan(r->remaining.z));
    set_num(v, 0, "remaining_gap_z_pos", finite_or_nan(r->remaining.z_pos));
    set_num(v, 0, "remaining_gap_z_rot", finite_or_nan(r->remaining.z_rot));
    set_bool(v, 0, "remaining_gap_significant", (int)r->remaining_gap_significant);
    for (k = 0; k < 6; ++k) {
        set_num(axis, 0, AXIS_FIELDS[k],
                k < 3 ? KC_MM(r->remaining_rms_axis[k]) : KC_DEG(r->remaining_rms_axis[k]));
    }
    mxSetField(v, 0, "remaining_rms_axis", axis);
    mxSetField(s, 0, "verdict", v);
    mxSetField(s, 0, "explainable", smooth_struct(&r->explainable));
    mxSetField(s, 0, "remaining_structure", smooth_struct(&r->remaining_structure));
    set_num(s, 0, "groups", (double)r->groups);
    set_num(s, 0, "folds", (double)r->folds);
    return s;
}

/* diagnose(robot, q, T, components, aux, groups 1 x M or [], options) -> model, report,
 * geometric */
static int op_diagnose(kc_ctx *c, int nlhs, mxArray *plhs[], const mxArray *prhs[])
{
    kincal_robot r, model, geometric;
    kincal_measurements m;
    kincal_diagnose_options o;
    kincal_diagnosis_report *rep;
    kincal_error err;
    kincal_status st;
    uint32_t *groups = NULL;
    size_t bytes, k;
    char *raw, name[64];
    void *ws;
    if (get_robot(c, prhs[0], &r) != 0 ||
        get_measurements(c, &r, prhs[1], prhs[2], prhs[3], prhs[4], &m) != 0 ||
        get_diagnose_options(c, prhs[6], &o) != 0) {
        return -1;
    }
    if (!is_default(prhs[5])) {
        const double *g;
        if (get_vector(c, prhs[5], "groups", m.n_poses, &g) != 0) {
            return -1;
        }
        groups = (uint32_t *)kc_alloc(c, m.n_poses * sizeof *groups);
        if (groups == NULL) {
            return -1;
        }
        for (k = 0; k < m.n_poses; ++k) {
            if (g[k] < 0 || g[k] > 4294967295.0 || g[k] != (double)(uint32_t)g[k]) {
                return fail(c, "badValue", "argument 'groups': pose %.0f must be a non-negative "
                            "integer id, got %.17g", one_based(k), g[k]);
            }
            groups[k] = (uint32_t)g[k];
        }
    }
    bytes = kincal_diagnose_workspace_size(r.n_joints, m.n_poses);
    if (bytes == 0) {
        return fail(c, "capacityExceeded", "no workspace size for %lu poses",
                    (unsigned long)m.n_poses);
    }
    raw = (char *)kc_alloc(c, bytes + KINCAL_WORKSPACE_ALIGN);
    rep = (kincal_diagnosis_report *)kc_alloc(c, sizeof *rep);
    if (raw == NULL || rep == NULL) {
        return -1;
    }
    ws = raw + (KINCAL_WORKSPACE_ALIGN - (size_t)((uintptr_t)raw % KINCAL_WORKSPACE_ALIGN)) %
                   KINCAL_WORKSPACE_ALIGN;
    st = kincal_diagnose(&r, &m, groups, groups != NULL ? m.n_poses : 0, &o, ws, bytes, &model,
                         &geometric, rep, NULL, 0, &err);
    if (st != KINCAL_STATUS_OK) {
        return fail_status(c, st, &err, NULL);
    }
    robot_name(prhs[0], name, sizeof name);
    if (put_robot(c, &model, name, &plhs[0]) != 0) {
        return -1;
    }
    if (nlhs > 1) {
        plhs[1] = diagnosis_struct(rep);
    }
    if (nlhs > 2 && put_robot(c, &geometric, name, &plhs[2]) != 0) {
        return -1;
    }
    return 0;
}

#endif /* KINCAL_NO_GROUP && KINCAL_DIAG_MAX_CANDIDATES */
