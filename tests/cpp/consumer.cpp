// C++17 consumer of the kincal C ABI (tests/cpp/run.sh builds it against the staticlib and the
// cdylib with -Wall -Wextra -Werror -pedantic).
//
// What it checks, from C++ through the header only:
// - forward kinematics of the built-in ARIA against an independent C++ implementation of the
//   Hayati/mDH chain of spec/aria.md, reading the parameters through the parameter API;
// - literal values shared with the Rust test `values_shared_with_cpp` (ffi/src/tests/abi.rs);
// - inverse kinematics of every Table 2 pose (FK of the solution reaches the pose);
// - the prepared-model handle (kincal_prepare, kincal_prepared_*) bit-identical to the plain
//   exports, and NULL, zeroed, garbage and corrupted handles refused with a status;
// - a Jacobian column against the analytic formula of eq. (13a) built from kincal_fk_frames;
// - effects on the model, pose error in both forms;
// - the documented status codes for bad arguments (NULL, short buffers, NaN, wrong joint
//   count, corrupt robot struct, unknown labels), and with KINCAL_TEST_PANIC the panic boundary.
// - a full calibration of the paper's simulation study: Table 3 truth measured at the Table 2
//   tool poses, identified from Table 1 with OLS, OPT1 and OPT2, validated before and after;
// - marker registration with a hidden and a moved marker;
// - where camera poses look (kincal_view_point: cameras aimed at a known target) and a pose
//   moved to a point (kincal_moved_to_point), with their bad-argument statuses;
// - instrument-free calibration (kincal_identify_constraints): contacts made by IK on a
//   perturbed ARIA recover its parameters, targets, plane and distance to 1e-9; bad rows
//   are named;
// - the diagnosis (kincal_diagnose): a planted joint compliance is `explained` by it; the
//   report's codes named by kincal_diagnosis_name;
// - a model file the CLI wrote (KINCAL_TEST_MODEL, from run.sh) read by kincal_model_read:
//   kincal_fk_pq equals the CLI's `kincal predict` (KINCAL_TEST_PREDICT) on every row, and a
//   broken copy is refused with its line and column; the same predictions read back through
//   the measurement CSV reader (kincal_measurements_read: two calls, caller-owned buffers)
//   equal the cells parsed here, and a broken row is refused with its line and cell.

#include <kincal.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <cstddef>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <sstream>
#include <memory>
#include <string>
#include <vector>

namespace {

int g_failures = 0;
int g_checks = 0;

void check(bool ok, const std::string &what, int line) {
    ++g_checks;
    if (!ok) {
        ++g_failures;
        std::printf("consumer.cpp:%d: FAILED: %s\n", line, what.c_str());
    }
}

#define CHECK(cond) check((cond), #cond, __LINE__)

/// Checks `status == expected` and, when given, the argument named in the error detail.
void check_status(kincal_status status, kincal_status expected, const kincal_error &err,
                  const char *argument, int line) {
    std::string what = std::string("status ") + std::to_string(static_cast<unsigned>(status)) +
                       " (" + kincal_status_str(status) + "), expected " +
                       std::to_string(static_cast<unsigned>(expected));
    check(status == expected, what, line);
    check(err.status == static_cast<uint32_t>(status), "err.status mirrors the return", line);
    if (argument != nullptr) {
        const char *got = err.argument != nullptr ? err.argument : "(null)";
        check(std::strcmp(got, argument) == 0,
              std::string("argument '") + got + "', expected '" + argument + "'", line);
    }
}

#define CHECK_STATUS(call, expected, err, argument) \
    check_status((call), (expected), (err), (argument), __LINE__)

double max_abs_diff(const double *a, const double *b, size_t n) {
    double m = 0.0;
    for (size_t i = 0; i < n; ++i) m = std::fmax(m, std::fabs(a[i] - b[i]));
    return m;
}

// ------------------------------------------------------------------ independent mDH FK

using Mat4 = std::array<double, 16>;  // column-major, m[4*col + row]

Mat4 identity() {
    Mat4 m{};
    m[0] = m[5] = m[10] = m[15] = 1.0;
    return m;
}

Mat4 mul(const Mat4 &a, const Mat4 &b) {
    Mat4 c{};
    for (int col = 0; col < 4; ++col)
        for (int row = 0; row < 4; ++row) {
            double s = 0.0;
            for (int k = 0; k < 4; ++k) s += a[4 * k + row] * b[4 * col + k];
            c[4 * col + row] = s;
        }
    return c;
}

Mat4 rot(int axis, double angle) {
    Mat4 m = identity();
    const double c = std::cos(angle), s = std::sin(angle);
    const int i = (axis + 1) % 3, j = (axis + 2) % 3;
    m[4 * i + i] = c;
    m[4 * j + j] = c;
    m[4 * i + j] = s;   // R(j, i) = s
    m[4 * j + i] = -s;  // R(i, j) = -s
    return m;
}

Mat4 trans(double x, double y, double z) {
    Mat4 m = identity();
    m[12] = x;
    m[13] = y;
    m[14] = z;
    return m;
}

/// Trans(p)·Rot(r), r a rotation vector (Rodrigues).
Mat4 frame(const double v[6]) {
    Mat4 m = trans(v[0], v[1], v[2]);
    const double t = std::sqrt(v[3] * v[3] + v[4] * v[4] + v[5] * v[5]);
    if (t > 0.0) {
        const double k[3] = {v[3] / t, v[4] / t, v[5] / t};
        const double c = std::cos(t), s = std::sin(t), C = 1.0 - c;
        const double r[3][3] = {
            {c + k[0] * k[0] * C, k[0] * k[1] * C - k[2] * s, k[0] * k[2] * C + k[1] * s},
            {k[1] * k[0] * C + k[2] * s, c + k[1] * k[1] * C, k[1] * k[2] * C - k[0] * s},
            {k[2] * k[0] * C - k[1] * s, k[2] * k[1] * C + k[0] * s, c + k[2] * k[2] * C}};
        for (int row = 0; row < 3; ++row)
            for (int col = 0; col < 3; ++col) m[4 * col + row] = r[row][col];
    }
    return m;
}

/// T_e^b = T_0^b·A_1···A_N·T_e^N with A_i = Rz(q_i + θ0_i)·Tz(d_i)·Tx(a_i)·Rx(α_i)·Ry(β_i),
/// the link parameters read by label through the C API (no effects).
Mat4 reference_fk(const kincal_robot &robot, const double *q) {
    auto param = [&](const std::string &label) {
        double v = NAN;
        kincal_error err;
        CHECK(kincal_robot_get_param_by_label(&robot, label.c_str(), &v, &err) ==
              KINCAL_STATUS_OK);
        return v;
    };
    double base[6], tool[6];
    const char *names[6] = {"px", "py", "pz", "rx", "ry", "rz"};
    for (int k = 0; k < 6; ++k) {
        base[k] = param(std::string("base_") + names[k]);
        tool[k] = param(std::string("tool_") + names[k]);
    }
    Mat4 t = frame(base);
    for (uint32_t i = 1; i <= robot.n_joints; ++i) {
        const std::string n = std::to_string(i);
        t = mul(t, rot(2, q[i - 1] + param("theta0_" + n)));
        t = mul(t, trans(0.0, 0.0, param("d_" + n)));
        t = mul(t, trans(param("a_" + n), 0.0, 0.0));
        t = mul(t, rot(0, param("alpha_" + n)));
        t = mul(t, rot(1, param("beta_" + n)));
    }
    return mul(t, frame(tool));
}

kincal_robot aria(kincal_aria_model model) {
    kincal_robot r;
    kincal_error err;
    CHECK_STATUS(kincal_robot_aria(&r, model, &err), KINCAL_STATUS_OK, err, nullptr);
    return r;
}

// ------------------------------------------------------------------ shared literal values
// Keep identical to `mod shared_with_cpp` in ffi/src/tests/abi.rs.

const double Q[6] = {0.3, 0.7, -0.4, 1.1, -0.6, 0.9};
const double FK_PQ_NOMINAL[7] = {0.7141755095975209,  0.35561149467273084, 0.6386459078672299,
                                 0.6930479765324871,  -0.604655159428662,  0.3671248824646843,
                                 -0.13890990272769088};
const double FK_PQ_TRUTH[7] = {0.744165633329287,   0.34655010957859805, 0.5634775604690159,
                               0.48366787176089576, -0.7423793201311939, 0.2777715990346434,
                               -0.37118899988761694};
const double TAU_NOMINAL[6] = {0.0, -22.42315448575973, -6.734168502227332, -0.6950360241046818,
                               -0.5196913966683572, 0.0};
const double IK_Q_TRUTH_POSE1[6] = {0.43454034295052607, 0.7930473894128408,
                                    -1.0650469975285652, 4.382635158022495,
                                    1.079216589289747,   -2.813354506099495};

// ------------------------------------------------------------------ tests

void test_version_and_layout() {
    CHECK(std::strlen(kincal_version()) >= 5);
    CHECK(kincal_robot_size() == sizeof(kincal_robot));
    CHECK(kincal_num_params(6) == 85);
    CHECK(kincal_num_geometric_params(6) == 42);
    CHECK(kincal_num_params(0) == 0 && kincal_num_params(KINCAL_MAX_JOINTS + 1) == 0);
    CHECK(std::strncmp(kincal_status_str(KINCAL_STATUS_OK), "KINCAL_STATUS_OK", 16) == 0);
    CHECK(std::strcmp(kincal_status_str(12345), "unknown kincal status code") == 0);
}

void test_fk_against_reference() {
    for (auto model : {KINCAL_ARIA_MODEL_NOMINAL, KINCAL_ARIA_MODEL_VIRTUAL_TRUTH,
                       KINCAL_ARIA_MODEL_REAL_IDENTIFIED}) {
        kincal_robot r = aria(model);
        for (int k = 0; k < 5; ++k) {
            double q[6];
            for (int j = 0; j < 6; ++j) q[j] = std::sin(1.3 * k + 0.7 * j) * 1.5;
            double t[16];
            kincal_error err;
            CHECK_STATUS(kincal_fk(&r, q, 6, nullptr, t, 16, &err), KINCAL_STATUS_OK, err,
                         nullptr);
            const Mat4 ref = reference_fk(r, q);
            CHECK(max_abs_diff(t, ref.data(), 16) < 1e-12);
        }
    }
    // With a base and a tool frame as well.
    kincal_robot r = aria(KINCAL_ARIA_MODEL_VIRTUAL_TRUTH);
    const double base[6] = {0.1, -0.05, 0.02, 0.01, -0.02, 0.3};
    const double tool[6] = {0.0, 0.01, 0.12, 0.2, 0.0, -0.1};
    kincal_error err;
    CHECK_STATUS(kincal_robot_set_base(&r, base, 6, &err), KINCAL_STATUS_OK, err, nullptr);
    CHECK_STATUS(kincal_robot_set_tool(&r, tool, 6, &err), KINCAL_STATUS_OK, err, nullptr);
    double t[16];
    CHECK_STATUS(kincal_fk(&r, Q, 6, nullptr, t, 16, &err), KINCAL_STATUS_OK, err, nullptr);
    CHECK(max_abs_diff(t, reference_fk(r, Q).data(), 16) < 1e-12);
}

void test_shared_values() {
    kincal_error err;
    double pq[7];
    kincal_robot nominal = aria(KINCAL_ARIA_MODEL_NOMINAL);
    CHECK_STATUS(kincal_fk_pq(&nominal, Q, 6, nullptr, pq, 7, &err), KINCAL_STATUS_OK, err,
                 nullptr);
    CHECK(max_abs_diff(pq, FK_PQ_NOMINAL, 7) < 1e-12);
    kincal_robot truth = aria(KINCAL_ARIA_MODEL_VIRTUAL_TRUTH);
    CHECK_STATUS(kincal_fk_pq(&truth, Q, 6, nullptr, pq, 7, &err), KINCAL_STATUS_OK, err,
                 nullptr);
    CHECK(max_abs_diff(pq, FK_PQ_TRUTH, 7) < 1e-12);
    double tau[6];
    CHECK_STATUS(kincal_gravity_torques(&nominal, Q, 6, tau, 6, &err), KINCAL_STATUS_OK, err,
                 nullptr);
    CHECK(max_abs_diff(tau, TAU_NOMINAL, 6) < 1e-10);
}

void test_ik_every_tool_pose() {
    kincal_robot truth = aria(KINCAL_ARIA_MODEL_VIRTUAL_TRUTH);
    double seed[6];
    kincal_error err;
    CHECK_STATUS(kincal_aria_tool_seed(seed, 6, &err), KINCAL_STATUS_OK, err, nullptr);
    for (size_t l = 0; l < KINCAL_ARIA_NUM_TOOL_POSES; ++l) {
        double target[16], q[6], t[16];
        kincal_ik_info info;
        CHECK_STATUS(kincal_aria_tool_pose(l, target, 16, &err), KINCAL_STATUS_OK, err,
                     nullptr);
        CHECK_STATUS(kincal_ik(&truth, target, 16, seed, 6, nullptr, nullptr, q, 6, &info, &err),
                     KINCAL_STATUS_OK, err, nullptr);
        CHECK(info.residual_pos_m < 1e-9 && info.residual_rot_rad < 1e-9);
        CHECK_STATUS(kincal_fk(&truth, q, 6, nullptr, t, 16, &err), KINCAL_STATUS_OK, err,
                     nullptr);
        CHECK(max_abs_diff(t, target, 16) < 1e-9);
        CHECK_STATUS(kincal_robot_check_limits(&truth, q, 6, &err), KINCAL_STATUS_OK, err,
                     nullptr);
        if (l == 0) CHECK(max_abs_diff(q, IK_Q_TRUTH_POSE1, 6) < 1e-9);
    }
    // An unreachable target: the best residual is reported.
    double far[16], q[6] = {0, 0, 0, 0, 0, 0};
    CHECK_STATUS(kincal_aria_tool_pose(0, far, 16, &err), KINCAL_STATUS_OK, err, nullptr);
    far[12] = 5.0;
    kincal_ik_options opts;
    CHECK_STATUS(kincal_ik_options_default(&opts, &err), KINCAL_STATUS_OK, err, nullptr);
    opts.extra_seeds = 2;
    opts.max_iterations = 50;
    CHECK_STATUS(kincal_ik(&truth, far, 16, seed, 6, nullptr, &opts, q, 6, nullptr, &err),
                 KINCAL_STATUS_UNREACHABLE, err, nullptr);
    CHECK(err.residual_pos_m > 3.0);
    CHECK(q[0] == 0.0);  // outputs are written on success only
}

// The prepared-model handle: bit-identical to the plain exports on the three ARIA models and on
// a model with backlash and thermal expansion (which need aux inputs); misuse is a status.
static_assert(sizeof(kincal_prepared) == KINCAL_PREPARED_SIZE, "kincal_prepared size");
static_assert(alignof(kincal_prepared) == KINCAL_PREPARED_ALIGN, "kincal_prepared alignment");

void check_prepared_matches(const kincal_robot &r, const kincal_prepared &p,
                            const kincal_joint_aux *aux) {
    kincal_error err;
    const double qs[3][6] = {{0.3, 0.7, -0.4, 1.1, -0.6, 0.9},
                             {0.0, 0.0, 0.0, 0.0, 0.0, 0.0},
                             {-1.2, 0.2, 1.9, -2.5, 0.4, 3.0}};
    for (const auto &q : qs) {
        double t1[16], t2[16], pq1[7], pq2[7], a1[6], a2[6];
        CHECK_STATUS(kincal_fk(&r, q, 6, aux, t1, 16, &err), KINCAL_STATUS_OK, err, nullptr);
        CHECK_STATUS(kincal_prepared_fk(&p, q, 6, aux, t2, 16, &err), KINCAL_STATUS_OK, err,
                     nullptr);
        CHECK(std::memcmp(t1, t2, sizeof t1) == 0);
        CHECK_STATUS(kincal_fk_pq(&r, q, 6, aux, pq1, 7, &err), KINCAL_STATUS_OK, err, nullptr);
        CHECK_STATUS(kincal_prepared_fk_pq(&p, q, 6, aux, pq2, 7, &err), KINCAL_STATUS_OK, err,
                     nullptr);
        CHECK(std::memcmp(pq1, pq2, sizeof pq1) == 0);
        CHECK_STATUS(kincal_joint_angles(&r, q, 6, aux, a1, 6, &err), KINCAL_STATUS_OK, err,
                     nullptr);
        CHECK_STATUS(kincal_prepared_joint_angles(&p, q, 6, aux, a2, 6, &err), KINCAL_STATUS_OK,
                     err, nullptr);
        CHECK(std::memcmp(a1, a2, sizeof a1) == 0);
    }
    double seed[6];
    CHECK_STATUS(kincal_aria_tool_seed(seed, 6, &err), KINCAL_STATUS_OK, err, nullptr);
    for (size_t l = 0; l < KINCAL_ARIA_NUM_TOOL_POSES; l += 3) {
        double target[16], q1[6], q2[6];
        kincal_ik_info i1, i2;
        CHECK_STATUS(kincal_aria_tool_pose(l, target, 16, &err), KINCAL_STATUS_OK, err, nullptr);
        const kincal_status s1 =
            kincal_ik(&r, target, 16, seed, 6, aux, nullptr, q1, 6, &i1, &err);
        CHECK_STATUS(kincal_prepared_ik(&p, target, 16, seed, 6, aux, nullptr, q2, 6, &i2, &err),
                     s1, err, nullptr);
        if (s1 == KINCAL_STATUS_OK) {
            CHECK(std::memcmp(q1, q2, sizeof q1) == 0);
            CHECK(i1.residual_pos_m == i2.residual_pos_m &&
                  i1.residual_rot_rad == i2.residual_rot_rad &&
                  i1.iterations == i2.iterations && i1.seed_index == i2.seed_index);
        }
    }
}

void test_prepared_handle() {
    CHECK(kincal_prepared_size() == sizeof(kincal_prepared));
    kincal_error err;
    // Static storage, as firmware would keep it (no heap).
    static kincal_prepared prepared;
    size_t n = 0;
    for (kincal_aria_model m : {KINCAL_ARIA_MODEL_NOMINAL, KINCAL_ARIA_MODEL_VIRTUAL_TRUTH,
                                KINCAL_ARIA_MODEL_REAL_IDENTIFIED}) {
        const kincal_robot r = aria(m);
        CHECK_STATUS(kincal_prepare(&r, &prepared, &err), KINCAL_STATUS_OK, err, nullptr);
        CHECK_STATUS(kincal_prepared_validate(&prepared, &n, &err), KINCAL_STATUS_OK, err,
                     nullptr);
        CHECK(n == 6);
        check_prepared_matches(r, prepared, nullptr);
    }
    kincal_robot r = aria(KINCAL_ARIA_MODEL_VIRTUAL_TRUTH);
    CHECK_STATUS(kincal_robot_set_param_by_label(&r, "backlash_3", 0.01, &err), KINCAL_STATUS_OK,
                 err, nullptr);
    CHECK_STATUS(kincal_robot_set_param_by_label(&r, "thermal_kappa", 1e-5, &err),
                 KINCAL_STATUS_OK, err, nullptr);
    CHECK_STATUS(kincal_robot_set_param_by_label(&r, "compliance_2", 1e-3, &err),
                 KINCAL_STATUS_OK, err, nullptr);
    CHECK_STATUS(kincal_prepare(&r, &prepared, &err), KINCAL_STATUS_OK, err, nullptr);
    kincal_joint_aux aux{};
    aux.has_approach = 1;
    aux.has_temp = 1;
    const double approach[6] = {1, -1, 1, 0, 1, -1};
    std::memcpy(aux.approach, approach, sizeof approach);
    aux.temp_c = 30.0;
    check_prepared_matches(r, prepared, &aux);
    double t[16];
    CHECK_STATUS(kincal_prepared_fk(&prepared, Q, 6, nullptr, t, 16, &err),
                 KINCAL_STATUS_MISSING_INPUT, err, nullptr);

    // A copy is as good as the original.
    kincal_prepared copy;
    std::memcpy(&copy, &prepared, sizeof copy);
    CHECK_STATUS(kincal_prepared_fk(&copy, Q, 6, &aux, t, 16, &err), KINCAL_STATUS_OK, err,
                 nullptr);

    // Misuse: NULL, zeroed, garbage and corrupted storage.
    CHECK_STATUS(kincal_prepared_fk(nullptr, Q, 6, &aux, t, 16, &err),
                 KINCAL_STATUS_NULL_POINTER, err, "prepared");
    CHECK_STATUS(kincal_prepare(&r, nullptr, &err), KINCAL_STATUS_NULL_POINTER, err,
                 "prepared_out");
    auto bad = std::make_unique<kincal_prepared>();
    std::memset(bad.get(), 0, sizeof *bad);
    CHECK_STATUS(kincal_prepared_fk(bad.get(), Q, 6, &aux, t, 16, &err),
                 KINCAL_STATUS_BAD_HANDLE, err, "prepared");
    std::memset(bad.get(), 0x5a, sizeof *bad);
    CHECK_STATUS(kincal_prepared_fk_pq(bad.get(), Q, 6, &aux, t, 7, &err),
                 KINCAL_STATUS_BAD_HANDLE, err, "prepared");
    // Header and guard words (0-3) are checked on every call; a damaged stored number (words
    // 10, 200) only by kincal_prepared_validate's checksum.
    for (size_t w : {size_t{0}, size_t{1}, size_t{2}, size_t{3}, size_t{10}, size_t{200}}) {
        std::memcpy(bad.get(), &prepared, sizeof *bad);
        bad->opaque[w] ^= uint64_t{1} << (w % 64);
        if (w < 4) {
            double q[6] = {9, 9, 9, 9, 9, 9}, target[16];
            CHECK_STATUS(kincal_aria_tool_pose(0, target, 16, &err), KINCAL_STATUS_OK, err,
                         nullptr);
            CHECK_STATUS(kincal_prepared_ik(bad.get(), target, 16, Q, 6, &aux, nullptr, q, 6,
                                            nullptr, &err),
                         KINCAL_STATUS_BAD_HANDLE, err, "prepared");
            CHECK(q[0] == 9.0);
        }
        CHECK_STATUS(kincal_prepared_validate(bad.get(), nullptr, &err), KINCAL_STATUS_BAD_HANDLE,
                     err, "prepared");
    }
    // A failed prepare leaves the earlier handle intact.
    kincal_robot broken = r;
    broken.n_joints = 0;
    CHECK_STATUS(kincal_prepare(&broken, &prepared, &err), KINCAL_STATUS_BAD_JOINT_COUNT, err,
                 "robot->n_joints");
    CHECK_STATUS(kincal_prepared_validate(&prepared, &n, &err), KINCAL_STATUS_OK, err, nullptr);
}

void test_jacobian_theta0_column() {
    kincal_robot r = aria(KINCAL_ARIA_MODEL_VIRTUAL_TRUTH);
    kincal_error err;
    const size_t p = kincal_num_params(6);
    std::vector<double> jac(6 * p, NAN);
    std::vector<double> frames(16 * 8);
    CHECK_STATUS(kincal_jacobian(&r, Q, 6, nullptr, jac.data(), jac.size(), nullptr, 0, &err),
                 KINCAL_STATUS_OK, err, nullptr);
    CHECK_STATUS(kincal_fk_frames(&r, Q, 6, nullptr, frames.data(), frames.size(), &err),
                 KINCAL_STATUS_OK, err, nullptr);
    // Eq. (13a): θ0_i column = [z_{i-1} × (p_e − p_{i-1}); z_{i-1}] (frame i-1 = frames[i-1]).
    const double *pe = &frames[16 * 7 + 12];
    for (int i = 1; i <= 6; ++i) {
        size_t index = 0;
        const std::string label = "theta0_" + std::to_string(i);
        CHECK_STATUS(kincal_robot_param_index(&r, label.c_str(), &index, &err),
                     KINCAL_STATUS_OK, err, nullptr);
        const double *f = &frames[16 * (i - 1)];
        const double z[3] = {f[8], f[9], f[10]};
        const double d[3] = {pe[0] - f[12], pe[1] - f[13], pe[2] - f[14]};
        const double expected[6] = {z[1] * d[2] - z[2] * d[1], z[2] * d[0] - z[0] * d[2],
                                    z[0] * d[1] - z[1] * d[0], z[0], z[1], z[2]};
        CHECK(max_abs_diff(&jac[6 * index], expected, 6) < 1e-12);
    }
    CHECK_STATUS(kincal_jacobian(&r, Q, 6, nullptr, jac.data(), 6 * p - 6, nullptr, 0, &err),
                 KINCAL_STATUS_BAD_LENGTH, err, "jac_out");
    CHECK(err.expected == 6 * p && err.found == 6 * p - 6);
}

void test_effects_and_pose_error() {
    kincal_robot r = aria(KINCAL_ARIA_MODEL_NOMINAL);
    const kincal_robot nominal = r;
    kincal_error err;
    CHECK_STATUS(kincal_robot_set_param_by_label(&r, "compliance_2", 2e-3, &err),
                 KINCAL_STATUS_OK, err, nullptr);
    uint32_t active = 0;
    CHECK_STATUS(kincal_robot_active_effects(&r, &active, &err), KINCAL_STATUS_OK, err, nullptr);
    CHECK(active == (1u << KINCAL_EFFECT_JOINT_COMPLIANCE));
    double angles[6], t_comp[16], t_plain[16], e6[6];
    CHECK_STATUS(kincal_joint_angles(&r, Q, 6, nullptr, angles, 6, &err), KINCAL_STATUS_OK, err,
                 nullptr);
    CHECK(std::fabs(angles[1] - (Q[1] + 2e-3 * TAU_NOMINAL[1])) < 1e-12);
    CHECK_STATUS(kincal_fk(&r, Q, 6, nullptr, t_comp, 16, &err), KINCAL_STATUS_OK, err, nullptr);
    CHECK_STATUS(kincal_fk(&nominal, angles, 6, nullptr, t_plain, 16, &err), KINCAL_STATUS_OK,
                 err, nullptr);
    CHECK(max_abs_diff(t_comp, t_plain, 16) < 1e-12);
    // Pose error of the compensated against the plain model: both forms, first order equal.
    CHECK_STATUS(kincal_fk(&nominal, Q, 6, nullptr, t_plain, 16, &err), KINCAL_STATUS_OK, err,
                 nullptr);
    double exact[6], small[6];
    CHECK_STATUS(kincal_pose_error(t_comp, 16, t_plain, 16, KINCAL_ORIENTATION_ERROR_EXACT, exact,
                                   6, &err),
                 KINCAL_STATUS_OK, err, nullptr);
    CHECK_STATUS(kincal_pose_error(t_comp, 16, t_plain, 16, KINCAL_ORIENTATION_ERROR_SMALL_ANGLE,
                                   small, 6, &err),
                 KINCAL_STATUS_OK, err, nullptr);
    CHECK(std::fabs(exact[0] - (t_comp[12] - t_plain[12])) < 1e-15);
    // The two orientation forms agree to first order: they differ by O(angle²).
    const double angle = std::sqrt(exact[3] * exact[3] + exact[4] * exact[4] + exact[5] * exact[5]);
    CHECK(angle > 1e-3);
    CHECK(max_abs_diff(exact, small, 6) < angle * angle);
    CHECK(max_abs_diff(exact, small, 6) > 0.0);
    double pq_a[7], pq_b[7];
    CHECK_STATUS(kincal_pose_to_pq(t_comp, 16, pq_a, 7, &err), KINCAL_STATUS_OK, err, nullptr);
    CHECK_STATUS(kincal_pose_to_pq(t_plain, 16, pq_b, 7, &err), KINCAL_STATUS_OK, err, nullptr);
    CHECK_STATUS(kincal_pose_error_pq(pq_a, 7, pq_b, 7, KINCAL_ORIENTATION_ERROR_EXACT, e6, 6,
                                      &err),
                 KINCAL_STATUS_OK, err, nullptr);
    CHECK(max_abs_diff(e6, exact, 6) < 1e-12);
    CHECK_STATUS(kincal_robot_clear_effects(&r, KINCAL_EFFECTS_ALL, &err), KINCAL_STATUS_OK, err,
                 nullptr);
    CHECK(std::memcmp(&r, &nominal, sizeof r) == 0);
}

void test_bad_arguments() {
    kincal_robot r = aria(KINCAL_ARIA_MODEL_NOMINAL);
    kincal_error err;
    double t[16], q[6];
    std::memcpy(q, Q, sizeof q);
    // NULL pointers.
    CHECK_STATUS(kincal_fk(nullptr, q, 6, nullptr, t, 16, &err), KINCAL_STATUS_NULL_POINTER, err,
                 "robot");
    CHECK_STATUS(kincal_fk(&r, nullptr, 6, nullptr, t, 16, &err), KINCAL_STATUS_NULL_POINTER,
                 err, "q");
    CHECK_STATUS(kincal_fk(&r, q, 6, nullptr, nullptr, 16, &err), KINCAL_STATUS_NULL_POINTER,
                 err, "t_base_tool_out");
    CHECK(kincal_fk(&r, q, 6, nullptr, nullptr, 16, nullptr) == KINCAL_STATUS_NULL_POINTER);
    // Short buffers and the wrong joint count.
    CHECK_STATUS(kincal_fk(&r, q, 6, nullptr, t, 15, &err), KINCAL_STATUS_BAD_LENGTH, err,
                 "t_base_tool_out");
    CHECK(err.expected == 16 && err.found == 15);
    CHECK_STATUS(kincal_fk(&r, q, 5, nullptr, t, 16, &err), KINCAL_STATUS_BAD_LENGTH, err, "q");
    CHECK(err.expected == 6 && err.found == 5);
    double seed[6] = {0, 0, 0, 0, 0, 0}, target[16];
    CHECK_STATUS(kincal_aria_tool_pose(0, target, 16, &err), KINCAL_STATUS_OK, err, nullptr);
    CHECK_STATUS(kincal_ik(&r, target, 16, seed, 7, nullptr, nullptr, q, 6, nullptr, &err),
                 KINCAL_STATUS_BAD_LENGTH, err, "q_seed");
    // NaN.
    q[3] = NAN;
    CHECK_STATUS(kincal_fk(&r, q, 6, nullptr, t, 16, &err), KINCAL_STATUS_NON_FINITE, err, "q");
    CHECK(err.index == 3);
    q[3] = Q[3];
    target[13] = INFINITY;
    CHECK_STATUS(kincal_ik(&r, target, 16, seed, 6, nullptr, nullptr, q, 6, nullptr, &err),
                 KINCAL_STATUS_NON_FINITE, err, "target");
    CHECK(err.index == 13);
    CHECK_STATUS(kincal_robot_set_param(&r, 0, NAN, &err), KINCAL_STATUS_NON_FINITE, err,
                 "value");
    // Not a rigid transform.
    CHECK_STATUS(kincal_aria_tool_pose(0, target, 16, &err), KINCAL_STATUS_OK, err, nullptr);
    target[0] *= 1.01;
    CHECK_STATUS(kincal_ik(&r, target, 16, seed, 6, nullptr, nullptr, q, 6, nullptr, &err),
                 KINCAL_STATUS_INVALID_TRANSFORM, err, "target");
    // A corrupt robot struct.
    kincal_robot bad = r;
    bad.n_joints = KINCAL_MAX_JOINTS + 1;
    CHECK_STATUS(kincal_fk(&bad, q, 6, nullptr, t, 16, &err), KINCAL_STATUS_BAD_JOINT_COUNT, err,
                 "robot->n_joints");
    CHECK(err.found == KINCAL_MAX_JOINTS + 1 && err.expected == KINCAL_MAX_JOINTS);
    bad = r;
    bad.params[7] = NAN;
    CHECK_STATUS(kincal_fk(&bad, q, 6, nullptr, t, 16, &err), KINCAL_STATUS_NON_FINITE, err,
                 "robot->params");
    CHECK(err.index == 7);
    bad = r;
    bad.limits_lower[2] = 5.0;
    CHECK_STATUS(kincal_robot_validate(&bad, &err), KINCAL_STATUS_INVALID_LIMITS, err, nullptr);
    CHECK(err.joint == 2);
    // Labels, indices, enumerations.
    CHECK_STATUS(kincal_robot_set_param_by_label(&r, "theta0_9", 0.1, &err),
                 KINCAL_STATUS_UNKNOWN_LABEL, err, "label");
    CHECK_STATUS(kincal_robot_set_param_by_label(&r, nullptr, 0.1, &err),
                 KINCAL_STATUS_NULL_POINTER, err, "label");
    double v = 0.0;
    CHECK_STATUS(kincal_robot_get_param(&r, 85, &v, &err), KINCAL_STATUS_INDEX_OUT_OF_RANGE, err,
                 "index");
    char label[4];
    CHECK_STATUS(kincal_robot_param_label(&r, 0, label, sizeof label, &err),
                 KINCAL_STATUS_BAD_LENGTH, err, "label_out");
    CHECK(err.expected == std::strlen("theta0_1") + 1);
    CHECK_STATUS(kincal_robot_aria(&r, 7, &err), KINCAL_STATUS_INVALID_ARGUMENT, err, "model");
    CHECK_STATUS(kincal_robot_clear_effects(&r, 1u << 9, &err), KINCAL_STATUS_INVALID_ARGUMENT,
                 err, "effects");
    // Missing inputs of effects.
    CHECK_STATUS(kincal_robot_set_param_by_label(&r, "backlash_2", 0.01, &err), KINCAL_STATUS_OK,
                 err, nullptr);
    CHECK_STATUS(kincal_fk(&r, q, 6, nullptr, t, 16, &err), KINCAL_STATUS_MISSING_INPUT, err,
                 nullptr);
    CHECK(err.quantity == KINCAL_QUANTITY_APPROACH_DIRECTION);
    kincal_joint_aux aux{};
    aux.has_approach = 1;
    for (int j = 0; j < 6; ++j) aux.approach[j] = 1.0;
    CHECK_STATUS(kincal_fk(&r, q, 6, &aux, t, 16, &err), KINCAL_STATUS_OK, err, nullptr);
    // Joint limits.
    q[1] = 4.0;
    CHECK_STATUS(kincal_robot_check_limits(&r, q, 6, &err), KINCAL_STATUS_OUT_OF_LIMITS, err,
                 nullptr);
    CHECK(err.joint == 1 && err.value == 4.0 && err.upper == 3.615);
    // The error text.
    char text[512];
    const size_t n = kincal_error_describe(&err, text, sizeof text);
    CHECK(n == std::strlen(text) && std::strstr(text, "OUT_OF_LIMITS") != nullptr);
}

void test_robot_from_table() {
    // A planar 2R arm: a_1 = 0.5, a_2 = 0.3, parallel axes (link 1 identifies β).
    const double links[10] = {0, 0, 0.5, 0, 0, 0, 0, 0.3, 0, 0};
    const double limits[4] = {-3, 3, -3, 3};
    kincal_robot r;
    kincal_error err;
    CHECK_STATUS(kincal_robot_init(&r, 2, links, 10, limits, 4, &err), KINCAL_STATUS_OK, err,
                 nullptr);
    CHECK(r.n_joints == 2 && r.length_param[0] == KINCAL_LENGTH_PARAM_BETA);
    const double q[2] = {0.4, -0.9};
    double pq[7];
    CHECK_STATUS(kincal_fk_pq(&r, q, 2, nullptr, pq, 7, &err), KINCAL_STATUS_OK, err, nullptr);
    const double x = 0.5 * std::cos(0.4) + 0.3 * std::cos(0.4 - 0.9);
    const double y = 0.5 * std::sin(0.4) + 0.3 * std::sin(0.4 - 0.9);
    CHECK(std::fabs(pq[0] - x) < 1e-15 && std::fabs(pq[1] - y) < 1e-15 && pq[2] == 0.0);
    CHECK_STATUS(kincal_robot_init(&r, 0, links, 0, limits, 0, &err),
                 KINCAL_STATUS_BAD_JOINT_COUNT, err, "n_joints");
    CHECK_STATUS(kincal_robot_init(&r, 2, links, 9, limits, 4, &err), KINCAL_STATUS_BAD_LENGTH,
                 err, "links");
}

void test_full_calibration() {
    const kincal_robot nominal = aria(KINCAL_ARIA_MODEL_NOMINAL);
    const kincal_robot truth = aria(KINCAL_ARIA_MODEL_VIRTUAL_TRUTH);
    kincal_error err;
    // Simulated measurements: the truth reaching each tool pose.
    const size_t L = KINCAL_ARIA_NUM_TOOL_POSES;
    std::vector<double> q(6 * L), poses(16 * L);
    double seed[6];
    CHECK_STATUS(kincal_aria_tool_seed(seed, 6, &err), KINCAL_STATUS_OK, err, nullptr);
    for (size_t l = 0; l < L; ++l) {
        double target[16];
        CHECK_STATUS(kincal_aria_tool_pose(l, target, 16, &err), KINCAL_STATUS_OK, err, nullptr);
        CHECK_STATUS(kincal_ik(&truth, target, 16, seed, 6, nullptr, nullptr, &q[6 * l], 6,
                               nullptr, &err),
                     KINCAL_STATUS_OK, err, nullptr);
        CHECK_STATUS(kincal_fk(&truth, &q[6 * l], 6, nullptr, &poses[16 * l], 16, &err),
                     KINCAL_STATUS_OK, err, nullptr);
    }
    kincal_measurements data{};
    data.n_poses = L;
    data.q = q.data();
    data.q_len = q.size();
    data.poses = poses.data();
    data.poses_len = poses.size();

    kincal_validation_summary before, after;
    CHECK_STATUS(kincal_validate(&nominal, &data, KINCAL_TARGET_POS_M, KINCAL_TARGET_ROT_RAD,
                                 nullptr, 0, &before, &err),
                 KINCAL_STATUS_OK, err, nullptr);
    CHECK(before.count == L && before.pos_ok == 0 && before.rms_pos_m > 1e-2);

    for (auto algorithm : {KINCAL_ALGORITHM_OLS, KINCAL_ALGORITHM_OPT1, KINCAL_ALGORITHM_OPT2}) {
        kincal_identify_options opts;
        CHECK_STATUS(kincal_identify_options_default(&nominal, algorithm, 0, &opts, &err),
                     KINCAL_STATUS_OK, err, nullptr);
        // Table 3 moves θ0_4 by 0.8 rad, far outside the paper's ±5°: widen OPT1's intervals.
        for (size_t i = 0; i < kincal_num_params(6); ++i) {
            if (std::isfinite(opts.lower[i])) {
                opts.lower[i] = nominal.params[i] - 1.0;
                opts.upper[i] = nominal.params[i] + 1.0;
            }
        }
        size_t n_requested = 0;
        for (unsigned char m : opts.requested) n_requested += m != 0;
        CHECK(n_requested == 24);
        const size_t size = kincal_identify_workspace_size(6, L, n_requested);
        CHECK(size > 0);
        std::vector<std::max_align_t> workspace(size / sizeof(std::max_align_t) + 1);
        kincal_robot fitted;
        auto report = std::make_unique<kincal_identify_report>();
        // A workspace one byte short is refused with the size it needs.
        CHECK_STATUS(kincal_identify(&nominal, &data, &opts, workspace.data(), size - 1, &fitted,
                                     report.get(), &err),
                     KINCAL_STATUS_BAD_LENGTH, err, "workspace");
        CHECK(err.expected == size);
        CHECK_STATUS(kincal_identify(&nominal, &data, &opts, workspace.data(), size, &fitted,
                                     report.get(), &err),
                     KINCAL_STATUS_OK, err, nullptr);
        CHECK(report->algorithm == static_cast<uint32_t>(algorithm));
        CHECK(report->analysis.rank == 24 && report->analysis.n_singular_values == 24);
        CHECK(report->fitted.rms_pos_m < 1e-9 && report->fitted.rms_rot_rad < 1e-9);
        double worst = 0.0;
        for (size_t i = 0; i < kincal_num_params(6); ++i)
            if (report->analysis.identifiable[i] != 0)
                worst = std::fmax(worst, std::fabs(fitted.params[i] - truth.params[i]));
        CHECK(worst < 1e-8);
        std::vector<double> errors(KINCAL_POSE_ERRORS_LEN * L);
        CHECK_STATUS(kincal_validate(&fitted, &data, KINCAL_TARGET_POS_M, KINCAL_TARGET_ROT_RAD,
                                     errors.data(), errors.size(), &after, &err),
                     KINCAL_STATUS_OK, err, nullptr);
        CHECK(after.pos_ok == 1 && after.rot_ok == 1 && after.max_pos_m < 1e-9);
    }
    std::printf("full calibration: Table 3 recovered from %zu tool poses (rms before %.2f mm)\n",
                L, before.rms_pos_m * 1e3);

    // Bad measurements name the pose.
    poses[16 * 3 + 15] = 2.0;
    kincal_identify_options opts;
    CHECK_STATUS(kincal_identify_options_default(&nominal, KINCAL_ALGORITHM_OLS, 0, &opts, &err),
                 KINCAL_STATUS_OK, err, nullptr);
    const size_t size = kincal_identify_workspace_size(6, L, 24);
    std::vector<std::max_align_t> workspace(size / sizeof(std::max_align_t) + 1);
    auto analysis = std::make_unique<kincal_identifiability>();
    CHECK_STATUS(kincal_analyze_identifiability(&nominal, &data, &opts, workspace.data(), size,
                                                analysis.get(), &err),
                 KINCAL_STATUS_INVALID_TRANSFORM, err, "data->poses");
    CHECK(err.pose == 3);
    poses[16 * 3 + 15] = 1.0;
    CHECK_STATUS(kincal_analyze_identifiability(&nominal, &data, &opts, workspace.data(), size,
                                                analysis.get(), &err),
                 KINCAL_STATUS_OK, err, nullptr);
    CHECK(analysis->rank == 24 && std::isfinite(analysis->condition_number));
}

void test_registration() {
    // An asymmetric probe of five markers, rotated about z and shifted.
    const double design[15] = {0, 0, 0, 0.1, 0, 0, 0, 0.15, 0, 0, 0, 0.07, 0.05, 0.05, 0.02};
    const double c = std::cos(0.4), s = std::sin(0.4);
    double measured[15];
    for (int j = 0; j < 5; ++j) {
        const double *p = &design[3 * j];
        measured[3 * j] = c * p[0] - s * p[1] + 1.0;
        measured[3 * j + 1] = s * p[0] + c * p[1] + 2.0;
        measured[3 * j + 2] = p[2] + 0.5;
    }
    measured[6] = NAN;     // marker 2 not seen ...
    measured[12] += 5e-3;  // ... and marker 4 knocked by 5 mm
    const unsigned char visible[5] = {1, 1, 0, 1, 1};
    kincal_registration_options opts;
    kincal_error err;
    CHECK_STATUS(kincal_registration_options_default(1e-4, &opts, &err), KINCAL_STATUS_OK, err,
                 nullptr);
    auto reg = std::make_unique<kincal_registration>();
    CHECK_STATUS(kincal_register(design, 15, measured, 15, visible, 5, nullptr, 0, &opts,
                                 reg.get(), &err),
                 KINCAL_STATUS_OK, err, nullptr);
    CHECK(reg->n_markers == 5 && reg->n_used == 3);
    CHECK(reg->markers[2].status == KINCAL_MARKER_STATUS_MISSING);
    CHECK(reg->markers[4].status == KINCAL_MARKER_STATUS_MOVED);
    const double expected[16] = {c, s, 0, 0, -s, c, 0, 0, 0, 0, 1, 0, 1, 2, 0.5, 1};
    CHECK(max_abs_diff(reg->t_mocap_body, expected, 16) < 1e-12);
    CHECK_STATUS(kincal_register(design, 15, measured, 15, nullptr, 0, nullptr, 0, &opts,
                                 reg.get(), &err),
                 KINCAL_STATUS_NON_FINITE, err, "measured");
    CHECK(err.index == 6);
}

// A camera frame at `eye` whose z axis looks at `target` (column-major 4×4).
Mat4 look_at(const std::array<double, 3> &eye, const std::array<double, 3> &target) {
    auto cross = [](const std::array<double, 3> &a, const std::array<double, 3> &b) {
        return std::array<double, 3>{a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2],
                                     a[0] * b[1] - a[1] * b[0]};
    };
    auto unit = [](std::array<double, 3> a) {
        const double n = std::sqrt(a[0] * a[0] + a[1] * a[1] + a[2] * a[2]);
        for (double &x : a) x /= n;
        return a;
    };
    const auto z = unit({target[0] - eye[0], target[1] - eye[1], target[2] - eye[2]});
    const std::array<double, 3> helper =
        std::fabs(z[0]) < 0.9 ? std::array<double, 3>{1, 0, 0} : std::array<double, 3>{0, 1, 0};
    const auto x = unit(cross(helper, z));
    const auto y = cross(z, x);
    Mat4 m = identity();
    for (int k = 0; k < 3; ++k) {
        m[k] = x[k];
        m[4 + k] = y[k];
        m[8 + k] = z[k];
        m[12 + k] = eye[k];
    }
    return m;
}

void test_view_point() {
    const std::array<double, 3> target{0.5, -0.2, 0.3};
    const std::array<std::array<double, 3>, 4> eyes{{
        {1.0, -0.2, 0.3}, {0.5, 0.5, 0.4}, {0.4, -0.1, 1.2}, {1.1, 0.3, 0.9}}};
    std::vector<double> poses;
    std::array<double, 4> dist{};
    for (size_t i = 0; i < eyes.size(); ++i) {
        const Mat4 m = look_at(eyes[i], target);
        poses.insert(poses.end(), m.begin(), m.end());
        double d2 = 0.0;
        for (int k = 0; k < 3; ++k) d2 += (eyes[i][k] - target[k]) * (eyes[i][k] - target[k]);
        dist[i] = std::sqrt(d2);
    }
    kincal_error err;
    kincal_view_point_result v;
    CHECK_STATUS(kincal_view_point(poses.data(), poses.size(), 4, KINCAL_AXIS_Z, &v, &err),
                 KINCAL_STATUS_OK, err, nullptr);
    CHECK(max_abs_diff(v.point_m, target.data(), 3) < 1e-12);
    CHECK(v.miss_max_m < 1e-12 && v.miss_rms_m < 1e-12 && v.miss_max_pose < 4);
    CHECK(std::fabs(v.mean_distance_m - (dist[0] + dist[1] + dist[2] + dist[3]) / 4) < 1e-12);
    CHECK(std::fabs(v.min_distance_m - 0.5) < 1e-12);
    CHECK(std::fabs(v.max_distance_m - dist[3]) < 1e-12);
    // Each camera moved along its axis by its own distance lands on the target, not rotated.
    for (size_t i = 0; i < eyes.size(); ++i) {
        const double point[3] = {0.0, 0.0, dist[i]};
        double moved[16];
        CHECK_STATUS(kincal_moved_to_point(&poses[16 * i], 16, point, 3, moved, 16, &err),
                     KINCAL_STATUS_OK, err, nullptr);
        CHECK(max_abs_diff(moved + 12, target.data(), 3) < 1e-12);
        CHECK(max_abs_diff(moved, &poses[16 * i], 12) == 0.0);
    }
    // Bad arguments.
    CHECK_STATUS(kincal_view_point(poses.data(), 16, 1, KINCAL_AXIS_Z, &v, &err),
                 KINCAL_STATUS_TOO_FEW_DATA, err, "n_poses");
    CHECK_STATUS(kincal_view_point(poses.data(), 60, 4, KINCAL_AXIS_Z, &v, &err),
                 KINCAL_STATUS_BAD_LENGTH, err, "poses");
    CHECK_STATUS(kincal_view_point(poses.data(), 64, 4, 7, &v, &err),
                 KINCAL_STATUS_INVALID_ARGUMENT, err, "axis");
    CHECK_STATUS(kincal_view_point(nullptr, 64, 4, KINCAL_AXIS_Z, &v, &err),
                 KINCAL_STATUS_NULL_POINTER, err, "poses");
    std::vector<double> bad = poses;
    bad[16 * 2 + 13] = NAN;
    CHECK_STATUS(kincal_view_point(bad.data(), 64, 4, KINCAL_AXIS_Z, &v, &err),
                 KINCAL_STATUS_NON_FINITE, err, "poses");
    CHECK(err.pose == 2 && err.index == 16 * 2 + 13);
    bad = poses;
    for (int k = 0; k < 3; ++k) bad[16 * 1 + k] *= 1.1;  // x axis of pose 1 not unit
    CHECK_STATUS(kincal_view_point(bad.data(), 64, 4, KINCAL_AXIS_Z, &v, &err),
                 KINCAL_STATUS_INVALID_TRANSFORM, err, "poses");
    CHECK(err.pose == 1);
    // Parallel axes: two cameras side by side looking straight down.
    const Mat4 a = look_at({0, 0, 1}, {0, 0, 0}), b = look_at({0.2, 0, 1}, {0.2, 0, 0});
    double par[32];
    std::memcpy(par, a.data(), sizeof(double) * 16);
    std::memcpy(par + 16, b.data(), sizeof(double) * 16);
    CHECK_STATUS(kincal_view_point(par, 32, 2, KINCAL_AXIS_Z, &v, &err),
                 KINCAL_STATUS_RANK_DEFICIENT, err, nullptr);
    const double point[3] = {0, 0, 1};
    double moved[16];
    CHECK_STATUS(kincal_moved_to_point(poses.data(), 16, point, 2, moved, 16, &err),
                 KINCAL_STATUS_BAD_LENGTH, err, "point");
    CHECK_STATUS(kincal_moved_to_point(bad.data() + 16, 16, point, 3, moved, 16, &err),
                 KINCAL_STATUS_INVALID_TRANSFORM, err, "t");
}

void test_panic_boundary() {
#if defined(KINCAL_TEST_PANIC)
    kincal_error err;
    CHECK_STATUS(kincal_test_panic(&err), KINCAL_STATUS_PANIC, err, nullptr);
    CHECK(kincal_test_panic(nullptr) == KINCAL_STATUS_PANIC);
    std::printf("panic boundary: kincal_test_panic returned KINCAL_STATUS_PANIC\n");
#endif
}

// ------------------------------------------------------------------ instrument-free and diagnosis

/// Deterministic pseudo-random numbers (SplitMix64), the same on every platform.
struct Rng {
    uint64_t s;
    double uniform() {  // [0, 1)
        uint64_t z = (s += 0x9e3779b97f4a7c15ULL);
        z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
        z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
        return static_cast<double>((z ^ (z >> 31)) >> 11) * 0x1.0p-53;
    }
    double range(double a, double b) { return a + (b - a) * uniform(); }
    double normal() {  // Box–Muller
        const double u = 1.0 - uniform(), v = uniform();
        return std::sqrt(-2.0 * std::log(u)) * std::cos(6.283185307179586 * v);
    }
};

const double BALL[3] = {0.01, -0.02, 0.1};  // tool point in the tool frame [m]

std::array<double, 3> ball_at(const Mat4 &t) {
    std::array<double, 3> p{};
    for (int r = 0; r < 3; ++r)
        p[r] = t[12 + r] + t[r] * BALL[0] + t[4 + r] * BALL[1] + t[8 + r] * BALL[2];
    return p;
}

Mat4 fk(const kincal_robot &r, const double *q) {
    Mat4 t{};
    kincal_error err;
    CHECK_STATUS(kincal_fk(&r, q, 6, nullptr, t.data(), 16, &err), KINCAL_STATUS_OK, err, nullptr);
    return t;
}

/// Joint readings holding the ball of `robot` at `p`, the tool tilted up to `tilt` rad from
/// the orientation of `t0` (IK seeded at `q0`).
std::array<double, 6> hold(const kincal_robot &robot, const std::array<double, 3> &p,
                           const Mat4 &t0, const double *q0, double tilt, Rng &rng) {
    kincal_ik_options opts;
    kincal_error err;
    CHECK_STATUS(kincal_ik_options_default(&opts, &err), KINCAL_STATUS_OK, err, nullptr);
    opts.first_solution = 1;
    opts.extra_seeds = 4;
    std::array<double, 6> q{};
    for (int attempt = 0; attempt < 50; ++attempt) {
        double axis[3] = {rng.range(-1, 1), rng.range(-1, 1), rng.range(-1, 1)};
        const double n = std::sqrt(axis[0] * axis[0] + axis[1] * axis[1] + axis[2] * axis[2]);
        const double a = rng.range(0.0, tilt);
        const double v[6] = {0, 0, 0, axis[0] / n * a, axis[1] / n * a, axis[2] / n * a};
        Mat4 r = mul(frame(v), t0);  // tilted in the base frame
        for (int k = 0; k < 3; ++k)
            r[12 + k] = p[k] - (r[k] * BALL[0] + r[4 + k] * BALL[1] + r[8 + k] * BALL[2]);
        if (kincal_ik(&robot, r.data(), 16, q0, 6, nullptr, &opts, q.data(), 6, nullptr,
                      &err) == KINCAL_STATUS_OK)
            return q;
    }
    CHECK(!"IK of a contact failed");
    return q;
}

/// Instrument-free data made on `truth`: 6 unknown targets (5 contacts), 2 known targets
/// (3), one unknown plane (6), a distance between targets 0 and 1, and two instrument rows
/// (z only; x, y, z). Rows interleaved, not sorted by group.
struct ContactSet {
    std::vector<double> q, point, coords;
    std::vector<uint32_t> target, plane;
    std::vector<uint8_t> mask;
    std::vector<kincal_target> targets;
    std::vector<kincal_plane> planes;
    std::vector<kincal_distance> distances;
    std::vector<std::array<double, 3>> true_targets;
    std::array<double, 3> true_normal{};
    double true_offset = 0.0;

    size_t rows() const { return target.size(); }
    void push(const std::array<double, 6> &qr, uint32_t t, uint32_t p) {
        q.insert(q.end(), qr.begin(), qr.end());
        point.insert(point.end(), BALL, BALL + 3);
        coords.insert(coords.end(), {0.0, 0.0, 0.0});
        target.push_back(t);
        plane.push_back(p);
        mask.push_back(0);
    }
    kincal_constraint_data view() const {
        kincal_constraint_data d{};
        d.n_rows = rows();
        d.q = q.data();
        d.q_len = q.size();
        d.target = target.data();
        d.target_len = rows();
        d.plane = plane.data();
        d.plane_len = rows();
        d.point = point.data();
        d.point_len = point.size();
        d.coords = coords.data();
        d.coords_len = coords.size();
        d.coord_mask = mask.data();
        d.coord_mask_len = rows();
        d.n_targets = targets.size();
        d.targets = targets.data();
        d.targets_len = targets.size();
        d.n_planes = planes.size();
        d.planes = planes.data();
        d.planes_len = planes.size();
        d.n_distances = distances.size();
        d.distances = distances.data();
        d.distances_len = distances.size();
        return d;
    }
};

ContactSet contact_set(const kincal_robot &truth, uint64_t seed) {
    Rng rng{seed};
    double seed_q[6];
    kincal_error err;
    CHECK_STATUS(kincal_aria_tool_seed(seed_q, 6, &err), KINCAL_STATUS_OK, err, nullptr);
    auto near_seed = [&]() {
        std::array<double, 6> q{};
        for (int j = 0; j < 6; ++j) q[j] = seed_q[j] + rng.range(-0.5, 0.5);
        return q;
    };
    ContactSet s;
    std::vector<std::vector<std::array<double, 6>>> groups;
    for (uint32_t t = 0; t < 8; ++t) {
        const auto q0 = near_seed();
        const Mat4 t0 = fk(truth, q0.data());
        const auto p = ball_at(t0);
        const bool known = t >= 6;
        std::vector<std::array<double, 6>> g;
        for (int k = 0; k < (known ? 3 : 5); ++k) g.push_back(hold(truth, p, t0, q0.data(), 0.5, rng));
        groups.push_back(g);
        kincal_target kt{};
        kt.known = known ? 1 : 0;
        for (int k = 0; k < 3; ++k) kt.xyz_m[k] = known ? p[k] : 0.0;
        s.targets.push_back(kt);
        s.true_targets.push_back(p);
    }
    {
        const auto q0 = near_seed();
        const Mat4 t0 = fk(truth, q0.data());
        const auto c = ball_at(t0);
        const double n[3] = {0.48, -0.6, 0.64};  // unit
        const double u[3] = {0.8, 0.64, 0.0};    // ⟂ n
        const double v[3] = {n[1] * u[2] - n[2] * u[1], n[2] * u[0] - n[0] * u[2],
                             n[0] * u[1] - n[1] * u[0]};
        std::vector<std::array<double, 6>> g;
        for (int k = 0; k < 6; ++k) {
            const double a = rng.range(-0.08, 0.08), b = rng.range(-0.08, 0.08);
            std::array<double, 3> p{};
            for (int i = 0; i < 3; ++i) p[i] = c[i] + a * u[i] + b * v[i];
            g.push_back(hold(truth, p, t0, q0.data(), 0.3, rng));
        }
        groups.push_back(g);
        s.planes.push_back(kincal_plane{});
        s.true_normal = {n[0], n[1], n[2]};
        s.true_offset = n[0] * c[0] + n[1] * c[1] + n[2] * c[2];
    }
    for (size_t k = 0; k < 6; ++k)
        for (size_t g = 0; g < groups.size(); ++g)
            if (k < groups[g].size())
                s.push(groups[g][k], g < 8 ? static_cast<uint32_t>(g) : KINCAL_NO_GROUP,
                       g < 8 ? KINCAL_NO_GROUP : 0u);
    const auto &a = s.true_targets[0], &b = s.true_targets[1];
    kincal_distance d{};
    d.a = 0;
    d.b = 1;
    d.m = std::sqrt((a[0] - b[0]) * (a[0] - b[0]) + (a[1] - b[1]) * (a[1] - b[1]) +
                    (a[2] - b[2]) * (a[2] - b[2]));
    d.weight = 1.0;
    s.distances.push_back(d);
    for (uint8_t m : {uint8_t{0x4}, uint8_t{0x7}}) {
        const auto q = near_seed();
        const auto p = ball_at(fk(truth, q.data()));
        s.push(q, KINCAL_NO_GROUP, KINCAL_NO_GROUP);
        s.mask.back() = m;
        for (int k = 0; k < 3; ++k) s.coords[3 * (s.rows() - 1) + k] = p[k];
    }
    return s;
}

struct ConstraintRun {
    kincal_status status;
    kincal_error err;
    kincal_robot fitted;
    std::unique_ptr<kincal_constraints_report> report;
    std::vector<kincal_group_estimate> targets, planes;
    std::vector<double> distances;
};

ConstraintRun identify_contacts(const kincal_robot &start, const ContactSet &s) {
    ConstraintRun r{};
    kincal_identify_options opts;
    CHECK_STATUS(kincal_identify_options_default(&start, KINCAL_ALGORITHM_OLS, 0, &opts, &r.err),
                 KINCAL_STATUS_OK, r.err, nullptr);
    size_t n_req = 0;
    for (unsigned char m : opts.requested) n_req += m != 0;
    const size_t size = kincal_identify_constraints_workspace_size(
        6, s.rows(), s.targets.size(), s.planes.size(), s.distances.size(), 0, n_req);
    CHECK(size > 0);
    std::vector<std::max_align_t> ws(size / sizeof(std::max_align_t) + 1);
    r.report = std::make_unique<kincal_constraints_report>();
    r.targets.resize(s.targets.size());
    r.planes.resize(s.planes.size());
    r.distances.resize(s.distances.size());
    const kincal_constraint_data data = s.view();
    r.status = kincal_identify_constraints(
        &start, &data, &opts, ws.data(), size, &r.fitted, r.report.get(), r.targets.data(),
        r.targets.size(), r.planes.data(), r.planes.size(), r.distances.data(),
        r.distances.size(), &r.err);
    return r;
}

void test_constraints() {
    const kincal_robot nominal = aria(KINCAL_ARIA_MODEL_NOMINAL);
    // Which parameters contacts determine: from data made on the nominal arm.
    const ContactSet probe = contact_set(nominal, 5);
    const ConstraintRun p = identify_contacts(nominal, probe);
    CHECK_STATUS(p.status, KINCAL_STATUS_OK, p.err, nullptr);
    // The truth: every identifiable parameter off by up to 2 mm / 0.3°.
    kincal_robot truth = nominal;
    Rng rng{77};
    for (size_t i = 0; i < kincal_num_params(6); ++i)
        if (p.report->identify.analysis.identifiable[i] != 0) {
            char label[32];
            kincal_error err;
            CHECK_STATUS(kincal_robot_param_label(&nominal, i, label, sizeof label, &err),
                         KINCAL_STATUS_OK, err, nullptr);
            const bool length = label[0] == 'a' || label[0] == 'd' ||
                                std::strstr(label, "_p") != nullptr;
            truth.params[i] += length ? rng.range(-2e-3, 2e-3) : rng.range(-5e-3, 5e-3);
        }
    const ContactSet s = contact_set(truth, 11);
    const ConstraintRun r = identify_contacts(nominal, s);
    CHECK_STATUS(r.status, KINCAL_STATUS_OK, r.err, nullptr);
    CHECK(r.report->external_reference == 1 && r.report->length_reference == 1);
    CHECK(r.report->n_instrument_rows == 2 && r.report->n_contacts == s.rows() - 2);
    double worst = 0.0;
    size_t fitted = 0;
    for (size_t i = 0; i < kincal_num_params(6); ++i)
        if (r.report->identify.analysis.identifiable[i] != 0) {
            worst = std::fmax(worst, std::fabs(r.fitted.params[i] - truth.params[i]));
            ++fitted;
        }
    CHECK(fitted > 15 && worst < 1e-9);
    double worst_point = 0.0;
    for (size_t t = 0; t < s.targets.size(); ++t) {
        worst_point = std::fmax(worst_point, max_abs_diff(r.targets[t].point,
                                                          s.true_targets[t].data(), 3));
        CHECK(r.targets[t].rms_m < 1e-9);
    }
    CHECK(worst_point < 1e-9);
    const double sign = r.planes[0].normal[0] * s.true_normal[0] +
                                    r.planes[0].normal[1] * s.true_normal[1] +
                                    r.planes[0].normal[2] * s.true_normal[2] <
                                0
                            ? -1.0
                            : 1.0;
    for (int k = 0; k < 3; ++k) CHECK(std::fabs(sign * r.planes[0].normal[k] - s.true_normal[k]) < 1e-9);
    CHECK(std::fabs(sign * r.planes[0].offset_m - s.true_offset) < 1e-9);
    CHECK(std::fabs(r.distances[0] - s.distances[0].m) < 1e-9);
    std::printf("constraints: %zu rows, %zu parameters recovered to %.1e, targets to %.1e m\n",
                s.rows(), fitted, worst, worst_point);

    // Bad rows name the row: a target with one contact, a distance to an unknown target,
    // a target and coordinates on one row.
    ContactSet bad = s;
    std::vector<size_t> of3;
    for (size_t l = 0; l < bad.rows(); ++l)
        if (bad.target[l] == 3) of3.push_back(l);
    for (size_t k = 1; k < of3.size(); ++k) bad.target[of3[k]] = 2;
    ConstraintRun e = identify_contacts(nominal, bad);
    CHECK_STATUS(e.status, KINCAL_STATUS_BAD_GROUP, e.err, "data->target");
    CHECK(e.err.index == 3 && e.err.pose == of3[0] && e.err.found == 1 && e.err.expected == 2);
    bad = s;
    bad.distances[0].b = 9;
    e = identify_contacts(nominal, bad);
    CHECK_STATUS(e.status, KINCAL_STATUS_BAD_DISTANCE, e.err, "data->distances");
    CHECK(e.err.index == 0 && e.err.found == 9);
    bad = s;
    bad.mask[4] = 0x7;
    e = identify_contacts(nominal, bad);
    CHECK_STATUS(e.status, KINCAL_STATUS_INVALID_ARGUMENT, e.err, "data->coord_mask");
    CHECK(e.err.pose == 4);
    char text[512];
    kincal_error_describe(&e.err, text, sizeof text);
    CHECK(std::strstr(text, "pose 4") != nullptr);
}

void test_diagnosis() {
    const kincal_robot nominal = aria(KINCAL_ARIA_MODEL_NOMINAL);
    kincal_robot truth = nominal;
    kincal_error err;
    // Geometry off by a millimetre here and there, and a planted joint compliance.
    const std::pair<const char *, double> planted[] = {
        {"a_2", 1.5e-3},        {"alpha_3", 2e-3},      {"theta0_4", -3e-3},
        {"d_5", -1e-3},         {"compliance_2", 8e-4}, {"compliance_3", 6e-4},
        {"compliance_5", 4e-4}};
    for (const auto &pv : planted) {
        double v = 0.0;
        CHECK_STATUS(kincal_robot_get_param_by_label(&truth, pv.first, &v, &err),
                     KINCAL_STATUS_OK, err, nullptr);
        CHECK_STATUS(kincal_robot_set_param_by_label(&truth, pv.first, v + pv.second, &err),
                     KINCAL_STATUS_OK, err, nullptr);
    }
    // 60 poses around the tool seed, the first 20 measured twice; mocap-like noise.
    const double sigma_pos = 1e-4, sigma_rot = 0.02 * 3.141592653589793 / 180.0;
    Rng rng{2024};
    double seed_q[6];
    CHECK_STATUS(kincal_aria_tool_seed(seed_q, 6, &err), KINCAL_STATUS_OK, err, nullptr);
    std::vector<double> q, poses;
    std::vector<uint32_t> groups;
    std::vector<std::array<double, 6>> configs;
    for (int l = 0; l < 60; ++l) {
        std::array<double, 6> c{};
        for (int j = 0; j < 6; ++j) c[j] = seed_q[j] + rng.range(-0.8, 0.8);
        configs.push_back(c);
    }
    for (int pass = 0; pass < 2; ++pass)
        for (int l = 0; l < (pass == 0 ? 60 : 20); ++l) {
            const Mat4 t = fk(truth, configs[l].data());
            const double w[6] = {0, 0, 0, sigma_rot * rng.normal(), sigma_rot * rng.normal(),
                                 sigma_rot * rng.normal()};
            Mat4 m = mul(frame(w), t);
            for (int k = 0; k < 3; ++k) m[12 + k] = t[12 + k] + sigma_pos * rng.normal();
            q.insert(q.end(), configs[l].begin(), configs[l].end());
            poses.insert(poses.end(), m.begin(), m.end());
            groups.push_back(static_cast<uint32_t>(l));
        }
    kincal_measurements data{};
    data.n_poses = groups.size();
    data.q = q.data();
    data.q_len = q.size();
    data.poses = poses.data();
    data.poses_len = poses.size();
    kincal_diagnose_options opts;
    CHECK_STATUS(kincal_diagnose_options_default(&opts, &err), KINCAL_STATUS_OK, err, nullptr);
    opts.sigma_pos_m = sigma_pos;
    opts.sigma_rot_rad = sigma_rot;
    const size_t size = kincal_diagnose_workspace_size(6, groups.size());
    CHECK(size > 0);
    std::vector<std::max_align_t> ws(size / sizeof(std::max_align_t) + 1);
    kincal_robot model, geometric;
    auto report = std::make_unique<kincal_diagnosis_report>();
    std::vector<kincal_pose_diagnosis> per_pose(groups.size());
    CHECK_STATUS(kincal_diagnose(&nominal, &data, groups.data(), groups.size(), &opts, ws.data(),
                                 size, &model, &geometric, report.get(), per_pose.data(),
                                 per_pose.size(), &err),
                 KINCAL_STATUS_OK, err, nullptr);
    const uint32_t compliance = 1u << KINCAL_EFFECT_JOINT_COMPLIANCE;
    CHECK(report->status == KINCAL_DIAGNOSIS_STATUS_EXPLAINED);
    CHECK(report->effects == compliance);
    CHECK(report->reason == KINCAL_DIAGNOSIS_REASON_CLOSED);
    CHECK(report->method == KINCAL_DIAGNOSIS_METHOD_CROSS_VALIDATION);
    CHECK(report->remaining_gap_significant == 0 && report->gap.z > 3.0);
    CHECK(report->noise.stated_pos == 1 && report->noise.overruled_pos == 0);
    CHECK(report->winner < report->n_candidates &&
          report->candidates[report->winner].effects == compliance);
    CHECK(report->n_suspects == 0 && report->groups == 60 && report->folds == 5);
    // The codes' public names (REPORT.json's text) from the library, not a table of our own.
    const auto named = [](uint32_t kind, uint32_t code, const char *expected) {
        const char *name = kincal_diagnosis_name(kind, code);
        return name != nullptr && std::strcmp(name, expected) == 0;
    };
    CHECK(named(KINCAL_DIAGNOSIS_NAME_KIND_STATUS, report->status, "explained"));
    CHECK(named(KINCAL_DIAGNOSIS_NAME_KIND_REASON, report->reason, "closed"));
    CHECK(named(KINCAL_DIAGNOSIS_NAME_KIND_METHOD, report->method, "cross_validation"));
    CHECK(named(KINCAL_DIAGNOSIS_NAME_KIND_WARNING, KINCAL_DIAGNOSIS_WARNING_CODE_REPEATS_DRIFT,
                "repeats_drift"));
    CHECK(kincal_diagnosis_name(KINCAL_DIAGNOSIS_NAME_KIND_WARNING, 0) == nullptr);
    CHECK(kincal_diagnosis_name(KINCAL_DIAGNOSIS_NAME_KIND_BEYOND_LIBRARY + 1, 0) == nullptr);
    // The identified compliance is the planted one within 15 %.
    double c2 = 0.0;
    CHECK_STATUS(kincal_robot_get_param_by_label(&model, "compliance_2", &c2, &err),
                 KINCAL_STATUS_OK, err, nullptr);
    CHECK(std::fabs(c2 / 8e-4 - 1.0) < 0.15);
    std::printf("diagnosis: status %u, effects %#x, gap z %.1f, closed %.2f, remaining z %.2f, "
                "compliance_2 %.3g (planted 8e-4)\n",
                report->status, report->effects, report->gap.z, report->gap_closed_fraction,
                report->remaining.z, c2);
    CHECK(report->noise.measured_pos == 1 && report->noise.measured_rot == 1);

    // The same poses, position only (issue #14): no orientation noise floor. The report
    // says "not measured" (measured_rot 0, sigma and dof 0, rotation RMS 0), no placeholder.
    std::vector<uint8_t> masks(groups.size(), 0x07);
    data.masks = masks.data();
    data.masks_len = masks.size();
    opts.sigma_rot_rad = std::nan("");
    CHECK_STATUS(kincal_diagnose(&nominal, &data, groups.data(), groups.size(), &opts, ws.data(),
                                 size, &model, &geometric, report.get(), per_pose.data(),
                                 per_pose.size(), &err),
                 KINCAL_STATUS_OK, err, nullptr);
    const kincal_noise_floor &n = report->noise;
    CHECK(n.measured_pos == 1 && n.stated_pos == 1 && n.sigma_pos_m == sigma_pos);
    CHECK(n.measured_rot == 0 && n.stated_rot == 0);
    CHECK(n.sigma_rot_rad == 0.0 && n.dof_rot == 0.0);
    CHECK(report->heldout_rms_rot_rad == 0.0 && report->gap.expected_rms_rot_rad == 0.0);
    CHECK(report->heldout_rms_pos_m > 0.0 && std::isfinite(report->gap.z));
    for (const auto &p : per_pose) CHECK(p.residual[3] == 0.0 && p.residual[5] == 0.0);
    std::printf("diagnosis, position only: orientation not measured (sigma_rot %g, dof %g), "
                "held-out %.3f mm\n",
                n.sigma_rot_rad, n.dof_rot, report->heldout_rms_pos_m * 1e3);
}

}  // namespace

// O (eq. 17) of the ten Table 2 tool poses (IK on the nominal model), default geometric
// parameters, unit columns. Keep identical to `TABLE2_O` in ffi/src/tests/observability.rs.
const double TABLE2_O = 1.453933636665828e-2;

void test_observability_table2() {
    kincal_robot nominal = aria(KINCAL_ARIA_MODEL_NOMINAL);
    double seed[6];
    kincal_error err;
    CHECK_STATUS(kincal_aria_tool_seed(seed, 6, &err), KINCAL_STATUS_OK, err, nullptr);
    std::vector<double> qs(6 * KINCAL_ARIA_NUM_TOOL_POSES);
    for (size_t l = 0; l < KINCAL_ARIA_NUM_TOOL_POSES; ++l) {
        double target[16];
        CHECK_STATUS(kincal_aria_tool_pose(l, target, 16, &err), KINCAL_STATUS_OK, err,
                     nullptr);
        CHECK_STATUS(kincal_ik(&nominal, target, 16, seed, 6, nullptr, nullptr, &qs[6 * l], 6,
                               nullptr, &err),
                     KINCAL_STATUS_OK, err, nullptr);
    }
    const size_t size = kincal_observability_workspace_size(24);
    CHECK(size > 0);
    std::vector<std::max_align_t> workspace(size / sizeof(std::max_align_t) + 1);
    kincal_observability_indices ind;
    double sv[24];
    CHECK_STATUS(kincal_observability(&nominal, qs.data(), KINCAL_ARIA_NUM_TOOL_POSES, qs.size(),
                                      nullptr, 0, nullptr, workspace.data(), size, &ind, sv, 24,
                                      &err),
                 KINCAL_STATUS_OK, err, nullptr);
    CHECK(ind.params == 24 && ind.poses == KINCAL_ARIA_NUM_TOOL_POSES);
    CHECK(std::fabs(ind.o - TABLE2_O) < 1e-9 * TABLE2_O);
    CHECK(sv[0] == ind.sigma_max && sv[23] == ind.sigma_min);
    // A short workspace is refused with the size it needs.
    CHECK_STATUS(kincal_observability(&nominal, qs.data(), KINCAL_ARIA_NUM_TOOL_POSES, qs.size(),
                                      nullptr, 0, nullptr, workspace.data(), size - 1, &ind,
                                      nullptr, 0, &err),
                 KINCAL_STATUS_BAD_LENGTH, err, "workspace");
}

// ------------------------------------------------------------------ model files (std build)

std::vector<std::string> split_csv(const std::string &line) {
    std::vector<std::string> out;
    std::stringstream ss(line);
    std::string cell;
    while (std::getline(ss, cell, ',')) out.push_back(cell);
    return out;
}

int column_of(const std::vector<std::string> &header, const std::string &name) {
    for (size_t i = 0; i < header.size(); ++i)
        if (header[i] == name) return static_cast<int>(i);
    return -1;
}

void test_model_file_from_cli() {
    const char *model_path = std::getenv("KINCAL_TEST_MODEL");
    const char *predict_path = std::getenv("KINCAL_TEST_PREDICT");
    CHECK(model_path != nullptr && predict_path != nullptr);  // run.sh sets both
    if (model_path == nullptr || predict_path == nullptr) return;
    kincal_robot robot;
    kincal_read_error re;
    kincal_error err;
    CHECK_STATUS(kincal_model_read(model_path, nullptr, &robot, &re, &err), KINCAL_STATUS_OK, err,
                 nullptr);
    CHECK(re.line == 0 && re.message[0] == '\0');
    std::ifstream in(predict_path);
    std::string line;
    std::vector<std::string> header;
    while (std::getline(in, line) && (line.empty() || line[0] == '#')) {
    }
    header = split_csv(line);
    const int q1 = column_of(header, "q1");
    const int x = column_of(header, "x");
    CHECK(q1 >= 0 && x >= 0);
    if (q1 < 0 || x < 0) return;
    const size_t n = robot.n_joints;
    int rows = 0;
    double worst = 0.0;
    while (std::getline(in, line)) {
        if (line.empty() || line[0] == '#') continue;
        const std::vector<std::string> cells = split_csv(line);
        std::vector<double> q(n);
        double expected[7];
        for (size_t j = 0; j < n; ++j) q[j] = std::strtod(cells.at(q1 + j).c_str(), nullptr);
        for (int k = 0; k < 7; ++k) expected[k] = std::strtod(cells.at(x + k).c_str(), nullptr);
        double pq[7];
        CHECK_STATUS(kincal_fk_pq(&robot, q.data(), n, nullptr, pq, 7, &err), KINCAL_STATUS_OK,
                     err, nullptr);
        worst = std::fmax(worst, max_abs_diff(pq, expected, 7));
        ++rows;
    }
    CHECK(rows >= 10);
    // The CLI prints the shortest decimal that reads back to the same double: equal bits.
    CHECK(worst == 0.0);
    std::printf("model file from the CLI: %d rows, max |C ABI - kincal predict| = %g\n", rows,
                worst);

    // The variants the file holds (a calibrated demo model: NOM, OLS, OPT1, OPT2).
    kincal_robot nom;
    CHECK_STATUS(kincal_model_read(model_path, "NOM", &nom, &re, &err), KINCAL_STATUS_OK, err,
                 nullptr);
    CHECK(max_abs_diff(nom.params, robot.params, kincal_num_params(n)) > 0.0);

    // A broken copy: refused with the reader's line and column.
    std::ifstream whole(model_path);
    std::stringstream text;
    text << whole.rdbuf();
    std::string broken = text.str();
    const size_t at = broken.find("\"robot\"");
    CHECK(at != std::string::npos);
    broken.insert(at, "@");
    const size_t line_of_at =
        1 + static_cast<size_t>(std::count(broken.begin(), broken.begin() + at, '\n'));
    CHECK_STATUS(kincal_model_read_buffer(broken.data(), broken.size(), nullptr, &robot, &re, &err),
                 KINCAL_STATUS_BAD_FILE, err, nullptr);
    CHECK(re.line == line_of_at);
    CHECK(re.column > 0);
    CHECK(std::strncmp(re.message, "buffer:", 7) == 0);
}

void test_measurements_from_cli() {
    const char *path = std::getenv("KINCAL_TEST_PREDICT");
    if (path == nullptr) return;  // test_model_file_from_cli reports the missing variable
    kincal_measurement_sizes z;
    kincal_read_error re;
    kincal_error err;
    CHECK_STATUS(kincal_measurements_read_sizes(path, nullptr, 0, &z, &re, &err),
                 KINCAL_STATUS_OK, err, nullptr);
    CHECK(z.n_rows >= 10 && z.n_joints == 6 && z.has_position && z.orientation == 2);
    std::vector<double> q(z.n_rows * z.n_joints), poses(16 * z.n_rows);
    std::vector<size_t> lines(z.n_rows);
    std::vector<char> text(z.text_len);
    kincal_measurement_buffers b{};
    b.q = q.data();
    b.q_len = q.size();
    b.poses = poses.data();
    b.poses_len = poses.size();
    b.lines = lines.data();
    b.lines_len = lines.size();
    b.text = text.data();
    b.text_len = text.size();
    CHECK_STATUS(kincal_measurements_read(path, nullptr, 0, &b, &re, &err), KINCAL_STATUS_OK,
                 err, nullptr);
    // The same rows parsed here: q and x, y, z bit for bit.
    std::ifstream in(path);
    std::string line, whole;
    std::vector<std::string> header;
    size_t row = 0, at = 0;
    double worst = 0.0;
    while (std::getline(in, line)) {
        ++at;
        whole += line + "\n";
        if (line.empty() || line[0] == '#') continue;
        if (header.empty()) {
            header = split_csv(line);
            continue;
        }
        const std::vector<std::string> cells = split_csv(line);
        const int q1 = column_of(header, "q1");
        const int x = column_of(header, "x");
        if (q1 < 0 || x < 0 || row >= z.n_rows) break;
        CHECK(lines[row] == at);
        for (size_t j = 0; j < 6; ++j)
            worst = std::fmax(worst, std::fabs(q[row * 6 + j] -
                                               std::strtod(cells.at(q1 + j).c_str(), nullptr)));
        for (int k = 0; k < 3; ++k)
            worst = std::fmax(worst, std::fabs(poses[16 * row + 12 + k] -
                                               std::strtod(cells.at(x + k).c_str(), nullptr)));
        ++row;
    }
    CHECK(row == z.n_rows && worst == 0.0);
    std::printf("measurement CSV from the CLI: %zu rows, max |reader - strtod| = %g\n", row,
                worst);
    // A broken second cell on the last row: refused with that line and cell number.
    const size_t last = whole.rfind('\n', whole.size() - 2) + 1;
    const size_t cell = whole.find(',', last) + 1;
    whole.insert(cell, "x");
    CHECK_STATUS(kincal_measurements_read_buffer_sizes(whole.data(), whole.size(), nullptr, 0, &z,
                                                       &re, &err),
                 KINCAL_STATUS_BAD_FILE, err, nullptr);
    CHECK(re.line == at && re.column == 2);
    CHECK(std::strncmp(re.message, "buffer:", 7) == 0);
}

int main() {
    test_version_and_layout();
    test_fk_against_reference();
    test_shared_values();
    test_ik_every_tool_pose();
    test_prepared_handle();
    test_observability_table2();
    test_jacobian_theta0_column();
    test_effects_and_pose_error();
    test_bad_arguments();
    test_robot_from_table();
    test_full_calibration();
    test_registration();
    test_view_point();
    test_panic_boundary();
    test_constraints();
    test_diagnosis();
    test_model_file_from_cli();
    test_measurements_from_cli();
    std::printf("kincal %s C++ consumer: %d checks, %d failed\n", kincal_version(), g_checks,
                g_failures);
    return g_failures == 0 ? 0 : 1;
}
