/*
 * Link-time proof that the C ABI has no panic path (tests/cpp/run.sh).
 *
 * Linked against the no_std build (`--no-default-features --features panic-never`, profile
 * `panic-never`) with -Wl,--gc-sections. That build's panic handler calls
 * kincal_panic_path_remains(), which is defined nowhere: if any function referenced here can
 * still reach a panic, the link fails with an undefined reference to it. With
 * -DKINCAL_PANIC_CANARY the deliberately panicking kincal_test_panic is referenced too, and the
 * link must fail: that shows the check can fail at all.
 *
 * Every export is referenced except those listed in NOT_PANIC_PROVEN of tests/cpp/run.sh
 * (identification and marker registration: their core kernels index arrays by loop counters
 * whose bounds the compiler cannot prove; run.sh checks that nothing else is left out). The
 * program also runs FK, IK (plain and through a prepared handle) and a validation on the
 * built-in ARIA as a smoke test of the no_std build.
 */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "kincal.h"

static int failures = 0;

/* Counts and reports a failed check with its line. */
#define CHECK(cond)                                                  \
    do {                                                             \
        if (!(cond)) {                                               \
            printf("panic_never.c:%d: check failed: %s\n", __LINE__, #cond); \
            ++failures;                                              \
        }                                                            \
    } while (0)

/* Whether kincal_diagnosis_name(kind, code) is `expected` (NULL: whether it is NULL). */
static int diagnosis_name_is(uint32_t kind, uint32_t code, const char *expected) {
    const char *name = kincal_diagnosis_name(kind, code);
    return expected == NULL ? name == NULL : name != NULL && strcmp(name, expected) == 0;
}

int main(void) {
    kincal_robot robot;
    kincal_error err;
    double q[6], t[16], pq[7], frames[16 * 8], jac[6 * 85], tau[6], angles[6], e6[6], v;
    double seed[6], q_ik[6], xyz_rpy[6], params[85];
    uint8_t mask[85];
    char label[KINCAL_LABEL_CAPACITY], text[512];
    size_t index;
    uint32_t effects, effect;
    kincal_ik_options opts;
    kincal_ik_info info;
    const double limits[2] = {-1.0, 1.0}, bad_limits[12] = {1.0, -1.0};
    const double link[5] = {0.0, 0.1, 0.2, 0.0, 0.0}, g[3] = {0.0, 0.0, -9.81};
    const double masses[6] = {1.0, -1.0, 1.0, 1.0, 1.0, 1.0};

    CHECK(kincal_robot_aria(&robot, KINCAL_ARIA_MODEL_VIRTUAL_TRUTH, &err) == KINCAL_STATUS_OK);
    CHECK(kincal_aria_tool_seed(seed, 6, &err) == KINCAL_STATUS_OK);
    CHECK(kincal_aria_tool_pose(0, t, 16, &err) == KINCAL_STATUS_OK);
    CHECK(kincal_ik_options_default(&opts, &err) == KINCAL_STATUS_OK);
    CHECK(kincal_ik(&robot, t, 16, seed, 6, NULL, &opts, q_ik, 6, &info, &err) == KINCAL_STATUS_OK);
    CHECK(kincal_fk(&robot, q_ik, 6, NULL, t, 16, &err) == KINCAL_STATUS_OK);
    CHECK(!(fabs(t[12] - 0.566) > 1e-9 || fabs(t[13] - 0.354) > 1e-9 || fabs(t[14] - 0.235) > 1e-9));
    for (int i = 0; i < 6; ++i) q[i] = 0.1 * i;
    CHECK(kincal_fk_pq(&robot, q, 6, NULL, pq, 7, &err) == KINCAL_STATUS_OK);
    {
        /* The prepared handle: the same results as the plain exports; a corrupted one refused. */
        static kincal_prepared prepared;
        double t2[16], pq2[7], q2[6], a1[6], a2[6];
        size_t n = 0;
        CHECK(kincal_prepared_size() == sizeof prepared);
        CHECK(kincal_prepare(&robot, &prepared, &err) == KINCAL_STATUS_OK);
        CHECK(kincal_prepared_validate(&prepared, &n, &err) == KINCAL_STATUS_OK && n == 6);
        CHECK(kincal_prepared_fk_pq(&prepared, q, 6, NULL, pq2, 7, &err) == KINCAL_STATUS_OK);
        CHECK(memcmp(pq, pq2, sizeof pq) == 0);
        CHECK(kincal_prepared_fk(&prepared, q_ik, 6, NULL, t2, 16, &err) == KINCAL_STATUS_OK);
        CHECK(kincal_fk(&robot, q_ik, 6, NULL, t, 16, &err) == KINCAL_STATUS_OK);
        CHECK(memcmp(t, t2, sizeof t) == 0);
        CHECK(kincal_joint_angles(&robot, q, 6, NULL, a1, 6, &err) == KINCAL_STATUS_OK);
        CHECK(kincal_prepared_joint_angles(&prepared, q, 6, NULL, a2, 6, &err) == KINCAL_STATUS_OK);
        CHECK(memcmp(a1, a2, sizeof a1) == 0);
        CHECK(kincal_aria_tool_pose(0, t2, 16, &err) == KINCAL_STATUS_OK);
        CHECK(kincal_prepared_ik(&prepared, t2, 16, seed, 6, NULL, &opts, q2, 6, &info, &err) ==
              KINCAL_STATUS_OK);
        CHECK(memcmp(q2, q_ik, sizeof q2) == 0);
        /* A damaged stored number: found by the full check (validate), not per call. */
        prepared.opaque[20] ^= 1u;
        CHECK(kincal_prepared_validate(&prepared, NULL, &err) == KINCAL_STATUS_BAD_HANDLE);
        /* A damaged guard word: refused by every call. */
        prepared.opaque[20] ^= 1u;
        prepared.opaque[2] ^= 1u;
        CHECK(kincal_prepared_fk(&prepared, q, 6, NULL, t2, 16, &err) == KINCAL_STATUS_BAD_HANDLE);
    }
    CHECK(kincal_fk_frames(&robot, q, 6, NULL, frames, 16 * 8, &err) == KINCAL_STATUS_OK);
    CHECK(kincal_jacobian(&robot, q, 6, NULL, jac, 6 * 85, t, 16, &err) == KINCAL_STATUS_OK);
    CHECK(kincal_gravity_torques(&robot, q, 6, tau, 6, &err) == KINCAL_STATUS_OK);
    CHECK(kincal_joint_angles(&robot, q, 6, NULL, angles, 6, &err) == KINCAL_STATUS_OK);
    CHECK(kincal_robot_check_limits(&robot, q, 6, &err) == KINCAL_STATUS_OK);
    CHECK(kincal_pose_error(t, 16, t, 16, KINCAL_ORIENTATION_ERROR_EXACT, e6, 6, &err) == KINCAL_STATUS_OK);
    CHECK(kincal_pose_error_pq(pq, 7, pq, 7, KINCAL_ORIENTATION_ERROR_SMALL_ANGLE, e6, 6, &err) == KINCAL_STATUS_OK);
    CHECK(kincal_pose_from_pq(pq, 7, t, 16, &err) == KINCAL_STATUS_OK);
    CHECK(kincal_pose_to_pq(t, 16, pq, 7, &err) == KINCAL_STATUS_OK);
    CHECK(kincal_pose_to_xyz_rpy(t, 16, xyz_rpy, 6, &err) == KINCAL_STATUS_OK);
    CHECK(kincal_pose_from_xyz_rpy(xyz_rpy, 6, t, 16, &err) == KINCAL_STATUS_OK);
    CHECK(kincal_robot_validate(&robot, &err) == KINCAL_STATUS_OK);
    CHECK(kincal_robot_get_params(&robot, params, 85, &err) == KINCAL_STATUS_OK);
    CHECK(kincal_robot_set_params(&robot, params, 85, &err) == KINCAL_STATUS_OK);
    CHECK(kincal_robot_get_param(&robot, 10, &v, &err) == KINCAL_STATUS_OK);
    CHECK(kincal_robot_set_param(&robot, 10, v, &err) == KINCAL_STATUS_OK);
    CHECK(kincal_robot_param_index(&robot, "compliance_2", &index, &err) == KINCAL_STATUS_OK);
    CHECK(kincal_robot_param_label(&robot, index, label, sizeof label, &err) == KINCAL_STATUS_OK);
    CHECK(kincal_robot_set_param_by_label(&robot, label, 1e-3, &err) == KINCAL_STATUS_OK);
    CHECK(kincal_robot_get_param_by_label(&robot, "compliance_2", &v, &err) == KINCAL_STATUS_OK);
    CHECK(kincal_robot_param_mask(&robot, KINCAL_EFFECTS_ALL, mask, 85, &err) == KINCAL_STATUS_OK);
    CHECK(kincal_robot_active_effects(&robot, &effects, &err) == KINCAL_STATUS_OK);
    CHECK(kincal_effect_from_name(kincal_effect_name(KINCAL_EFFECT_BACKLASH), &effect, &err) == KINCAL_STATUS_OK);
    CHECK(kincal_robot_clear_effects(&robot, effects, &err) == KINCAL_STATUS_OK);
    CHECK(kincal_robot_set_base(&robot, xyz_rpy, 6, &err) == KINCAL_STATUS_OK);
    CHECK(kincal_robot_set_tool(&robot, xyz_rpy, 6, &err) == KINCAL_STATUS_OK);
    CHECK(kincal_robot_set_limits(&robot, bad_limits, 12, &err) == KINCAL_STATUS_INVALID_LIMITS);
    CHECK(kincal_robot_set_mass(&robot, masses, 6, 0.3, g, 3, &err) == KINCAL_STATUS_INVALID_PARAMETER);
    CHECK(kincal_robot_set_length_param(&robot, 1, KINCAL_LENGTH_PARAM_BETA, &err) == KINCAL_STATUS_OK);
    CHECK(kincal_robot_set_joint_kind(&robot, 0, KINCAL_JOINT_KIND_REVOLUTE, &err) == KINCAL_STATUS_OK);
    CHECK(kincal_robot_set_joint_kind(&robot, 99, KINCAL_JOINT_KIND_PRISMATIC, &err) == KINCAL_STATUS_INDEX_OUT_OF_RANGE);
    CHECK(kincal_robot_adopt_geometry_as_nominal(&robot, &err) == KINCAL_STATUS_OK);
    CHECK(kincal_robot_init(&robot, 1, link, 5, limits, 2, &err) == KINCAL_STATUS_OK);
    CHECK(!(kincal_num_params(6) != 85 || kincal_num_geometric_params(6) != 42));
    CHECK(!(kincal_robot_size() != sizeof(kincal_robot)));
    CHECK(kincal_fk(&robot, q, 6, NULL, t, 16, &err) == KINCAL_STATUS_BAD_LENGTH);
    (void)kincal_error_describe(&err, text, sizeof text);
    {
        kincal_identify_options iopts;
        kincal_validation_summary summary;
        kincal_registration_options ropts;
        double pose[16], t_base_ee[16];
        const double q0[6] = {0.4813, 0.7750, -1.0383, 3.6605, 1.1053, -2.8499};
        kincal_measurements data = {1, q0, 6, pose, 16, NULL, 0, NULL, 0, NULL, 0};
        CHECK(kincal_robot_aria(&robot, KINCAL_ARIA_MODEL_NOMINAL, &err) == KINCAL_STATUS_OK);
        CHECK(kincal_fk(&robot, q0, 6, NULL, pose, 16, &err) == KINCAL_STATUS_OK);
        CHECK(kincal_validate(&robot, &data, KINCAL_TARGET_POS_M, KINCAL_TARGET_ROT_RAD, NULL, 0,
                              &summary, &err) == KINCAL_STATUS_OK);
        CHECK(summary.count == 1 && summary.pos_ok == 1 && summary.max_pos_m < 1e-15);
        CHECK(kincal_identify_options_default(&robot, KINCAL_ALGORITHM_OLS, 0, &iopts, &err) ==
              KINCAL_STATUS_OK);
        CHECK(kincal_identify_workspace_size(6, 10, 24) > 0);
        CHECK(kincal_registration_options_default(1e-4, &ropts, &err) == KINCAL_STATUS_OK);
        CHECK(kincal_t_base_ee(pose, 16, pose, 16, t_base_ee, 16, &err) == KINCAL_STATUS_OK);
        CHECK(kincal_biopsy_allowed_rotation(5e-3, 1.7e-3, 0.2, &v, &err) == KINCAL_STATUS_OK);
    }
    {
        /* Two cameras 1 m from the origin looking at it along +z and +x (their z axes). */
        const double views[32] = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, -1, 1,
                                  0, 0, -1, 0, 0, 1, 0, 0, 1, 0, 0, 0, -1, 0, 0, 1};
        const double point[3] = {0, 0, 1};
        double moved[16];
        kincal_view_point_result vp;
        CHECK(kincal_view_point(views, 32, 2, KINCAL_AXIS_Z, &vp, &err) == KINCAL_STATUS_OK);
        CHECK(fabs(vp.point_m[0]) < 1e-12 && fabs(vp.point_m[2]) < 1e-12);
        CHECK(kincal_moved_to_point(views, 16, point, 3, moved, 16, &err) == KINCAL_STATUS_OK);
        CHECK(fabs(moved[14]) < 1e-12);
    }
    {
        /* A planar 2R arm from its axes: both along z, through (0,0,0) and (0.5,0,0). */
        const double points[6] = {0, 0, 0, 0.5, 0, 0}, dirs[6] = {0, 0, 1, 0, 0, 1};
        const double lims[4] = {-3, 3, -3, 3}, q2[2] = {0.0, 0.0};
        double tool[16];
        CHECK(kincal_pose_from_xyz_rpy((const double[6]){0.8, 0, 0, 0, 0, 0}, 6, tool, 16, &err) ==
              KINCAL_STATUS_OK);
        CHECK(kincal_robot_from_axes(&robot, 2, points, 6, dirs, 6, NULL, 0, tool, 16, lims, 4,
                                     &err) == KINCAL_STATUS_OK);
        CHECK(kincal_fk(&robot, q2, 2, NULL, t, 16, &err) == KINCAL_STATUS_OK);
        CHECK(fabs(t[12] - 0.8) < 1e-12 && fabs(t[13]) < 1e-12);
    }
    /* The diagnosis's public names (REPORT.json's text) of the report's codes. */
    CHECK(diagnosis_name_is(KINCAL_DIAGNOSIS_NAME_KIND_WARNING,
                            KINCAL_DIAGNOSIS_WARNING_CODE_REPEATS_DRIFT, "repeats_drift"));
    CHECK(diagnosis_name_is(KINCAL_DIAGNOSIS_NAME_KIND_STATUS,
                            KINCAL_DIAGNOSIS_STATUS_PARTIALLY_EXPLAINED, "partially_explained"));
    CHECK(diagnosis_name_is(KINCAL_DIAGNOSIS_NAME_KIND_REASON,
                            KINCAL_DIAGNOSIS_REASON_CONFOUNDED_WITH_SESSIONS,
                            "confounded_with_sessions"));
    CHECK(diagnosis_name_is(KINCAL_DIAGNOSIS_NAME_KIND_PART, KINCAL_DIAGNOSIS_PART_BOTH,
                            "position and rotation"));
    CHECK(diagnosis_name_is(KINCAL_DIAGNOSIS_NAME_KIND_PART, KINCAL_DIAGNOSIS_PART_NONE, ""));
    CHECK(diagnosis_name_is(KINCAL_DIAGNOSIS_NAME_KIND_METHOD,
                            KINCAL_DIAGNOSIS_METHOD_IN_SAMPLE_NESTED, "in_sample_nested"));
    CHECK(diagnosis_name_is(KINCAL_DIAGNOSIS_NAME_KIND_BEYOND_LIBRARY,
                            KINCAL_BEYOND_LIBRARY_NOT_A_FUNCTION_OF_Q, "not_a_function_of_q"));
    CHECK(diagnosis_name_is(KINCAL_DIAGNOSIS_NAME_KIND_WARNING, 0, NULL));
    CHECK(diagnosis_name_is(KINCAL_DIAGNOSIS_NAME_KIND_WARNING,
                            KINCAL_DIAGNOSIS_WARNING_CODE_REPEATS_DRIFT + 1, NULL));
    CHECK(diagnosis_name_is(KINCAL_DIAGNOSIS_NAME_KIND_BEYOND_LIBRARY + 1, 0, NULL));
#if defined(KINCAL_PANIC_CANARY)
    CHECK(kincal_test_panic(&err) == KINCAL_STATUS_PANIC);
#endif
    printf("panic-never build %s: %s; %s\n", kincal_version(), text,
           kincal_status_str(KINCAL_STATUS_OK));
    if (failures != 0) {
        printf("%d checks failed\n", failures);
        return 1;
    }
    return 0;
}
