/*
 * kincal: C ABI of the kincal kinematic-calibration toolkit.
 *
 * GENERATED FILE, DO NOT EDIT. It is generated from ffi/src by cbindgen 0.29.4
 * (ffi/cbindgen.toml); regenerate with
 *     KINCAL_BLESS=1 cargo test -p kincal-ffi header
 *
 * Conventions:
 * - Every fallible function returns a kincal_status (KINCAL_STATUS_OK = 0) and takes a
 *   last `kincal_error *err` for the positional detail of a failure (NULL allowed).
 * - Argument order: object, inputs, outputs (`*_out`). Every buffer is caller-owned and
 *   followed by its length in elements (`*_len`), which must equal what the call needs.
 * - Nothing is allocated and no pointer is kept after a call returns. Outputs are written
 *   on success only unless a function says otherwise.
 * - Units: metres, radians, kilograms, seconds. 4x4 poses are column-major
 *   (t[4*col + row]); quaternions are [w, x, y, z]. Indices are zero-based; parameter
 *   labels use 1-based link numbers ("theta0_3").
 * - Static strings returned by the library are never freed.
 * - Library version: kincal_version(); sizeof(kincal_robot) == kincal_robot_size(),
 *   sizeof(kincal_prepared) == kincal_prepared_size().
 */

#ifndef KINCAL_H
#define KINCAL_H

#include <stdint.h>
#include <stddef.h>
#include <stdbool.h>
/*
 "No index" marker of the size_t fields of kincal_error.
 */
#define KINCAL_NO_INDEX SIZE_MAX

/*
 File readers (kincal_model_read, ...) exist in the std library only: firmware code
 linking the no_std library defines KINCAL_NO_STD to hide their declarations.
 */
#if !defined(KINCAL_NO_STD) && !defined(KINCAL_STD)
#define KINCAL_STD 1
#endif

/*
 Joint count of ARIA.
 */
#define KINCAL_ARIA_NUM_JOINTS 6

/*
 Number of Table 2 calibration-tool poses.
 */
#define KINCAL_ARIA_NUM_TOOL_POSES 10

/*
 Mask of every effect.
 */
#define KINCAL_EFFECTS_ALL 127

/*
 Most strongly correlated parameter pairs a report lists (`kincal_identify_report`).
 */
#define KINCAL_MAX_CORRELATED_PAIRS 32

/*
 Alignment `kincal_identify` needs of its workspace pointer (`malloc` provides it).
 */
#define KINCAL_WORKSPACE_ALIGN 16

/*
 Largest `kincal_ik_options.max_iterations`.
 */
#define KINCAL_IK_MAX_ITERATIONS 1000

/*
 Largest `kincal_ik_options.extra_seeds`.
 */
#define KINCAL_IK_MAX_EXTRA_SEEDS 256

/*
 Largest `(1 + extra_seeds) * max_iterations` of `kincal_ik_options`.
 */
#define KINCAL_IK_MAX_TOTAL_ITERATIONS 20000

/*
 Largest `frames_len` of `kincal_fk_frames`: 16·(`KINCAL_MAX_JOINTS` + 2).
 */
#define KINCAL_MAX_FRAMES_LEN 224

#if defined(KINCAL_STD)
/*
 Capacity of `kincal_read_error.message` in bytes, including the terminating NUL.
 */
#define KINCAL_READ_MESSAGE_LEN 512
#endif

/*
 Largest design `kincal_select_poses` selects (`m`; the core's exchange needs 3 more slots).
 */
#define KINCAL_MAX_SELECT 61

/*
 A buffer of this many bytes holds every parameter label with its terminating NUL.
 */
#define KINCAL_LABEL_CAPACITY 32

/*
 Tolerance of the rigid-transform check of input matrices: every entry of RᵀR − I within
 this, and det R > 0.
 */
#define KINCAL_ROTATION_TOLERANCE 1e-6

/*
 Size in bytes of `kincal_prepared` (`sizeof(kincal_prepared)`; also `kincal_prepared_size()`).
 */
#define KINCAL_PREPARED_SIZE 4096

/*
 Alignment in bytes of `kincal_prepared` (`alignof(kincal_prepared)`, that of `uint64_t`).
 */
#define KINCAL_PREPARED_ALIGN 8

/*
 Number of `uint64_t` words of `kincal_prepared.opaque`: `KINCAL_PREPARED_SIZE / 8`.
 */
#define KINCAL_PREPARED_WORDS 512

/*
 Most markers on one body.
 */
#define KINCAL_MAX_MARKERS 32

/*
 Most markers `kincal_register` may exclude as outliers.
 */
#define KINCAL_MAX_OUTLIERS 3

/*
 Largest joint count of a `kincal_robot`.
 */
#define KINCAL_MAX_JOINTS 12

/*
 Capacity of `kincal_robot.params`: `kincal_num_params(KINCAL_MAX_JOINTS)` = 12·12 + 13.
 */
#define KINCAL_MAX_PARAMS 157

/*
 Capacity of `kincal_robot.nominal`: `kincal_num_geometric_params(KINCAL_MAX_JOINTS)` =
 5·12 + 12.
 */
#define KINCAL_MAX_GEOMETRIC_PARAMS 72

/*
 The paper's position target of Section 4.4: every pose error below 1 mm [m].
 */
#define KINCAL_TARGET_POS_M 0.001

/*
 The paper's orientation target: every pose error below 0.66° [rad].
 */
#define KINCAL_TARGET_ROT_RAD 0.011519173063162576

/*
 Doubles per pose in `kincal_validate`'s `errors_out`: `[e_x, e_y, e_z] (m)`,
 `[e_φx, e_φy, e_φz] (rad, exact rotation vector)`, `|e_p| (m)`, `|e_φ| (rad)`.
 */
#define KINCAL_POSE_ERRORS_LEN 8

/*
 "No target / no plane" in `kincal_constraint_data.target` and `.plane`.
 */
#define KINCAL_NO_GROUP 4294967295

/*
 A session needs at least this many rows (as `kincal calibrate`): fewer fix nothing a
 set-up adds.
 */
#define KINCAL_MIN_SESSION_ROWS 3

/*
 Plane contacts whose spread across their best-fit line, at the starting model, is below
 this fraction of their extent along it are collinear (`KINCAL_STATUS_DEGENERATE_GROUP`):
 the plane's tilt about that line is undetermined. The CLI's threshold.
 */
#define KINCAL_PLANE_MIN_ASPECT 0.1

/*
 Candidate models a report lists at most: every effect alone and every pair (7 + 21).
 */
#define KINCAL_DIAG_MAX_CANDIDATES 28

/*
 Suspect rows (gross outliers) a report lists at most.
 */
#define KINCAL_DIAG_MAX_SUSPECTS 64

/*
 Warnings a report lists at most.
 */
#define KINCAL_DIAG_MAX_WARNINGS 8

#if defined(KINCAL_STD)
/*
 `flags` bit of the measurement readers: accept joint readings outside the robot's limits.
 */
#define KINCAL_READ_ALLOW_OUT_OF_LIMITS 1
#endif

#if defined(KINCAL_STD)
/*
 `flags` bit of the measurement readers: refuse a file without the position columns x, y, z.
 */
#define KINCAL_READ_REQUIRE_POSE 2
#endif

/*
 Result of every fallible export. `KINCAL_STATUS_OK` (0) is success.

 The numbers are part of the ABI and never reused: argument errors are 100–199, numerical
 failures 200–299, internal errors 900–999 (`KINCAL_STATUS_PANIC` last). A retired code stays
 listed here as a comment. The type is 32 bits wide whatever the C compiler's enum size
 (`-fshort-enums` is the default of bare-metal ARM GCC), so in C it is `uint32_t`.
 */
enum kincal_status
#if defined(__cplusplus) || __STDC_VERSION__ >= 202311L
  : uint32_t
#endif // defined(__cplusplus) || __STDC_VERSION__ >= 202311L
 {
    /*
     Success.
     */
    KINCAL_STATUS_OK = 0,
    /*
     A required pointer argument was NULL (`kincal_error.argument` names it).
     */
    KINCAL_STATUS_NULL_POINTER = 100,
    /*
     A buffer length or count disagreed with what the call needs (`expected`, `found`);
     this includes a joint vector whose length is not the robot's joint count.
     */
    KINCAL_STATUS_BAD_LENGTH = 101,
    /*
     A number that must be finite was NaN or infinite (`argument`, `index`, `quantity`).
     */
    KINCAL_STATUS_NON_FINITE = 102,
    /*
     A joint reading lies outside the joint limits (`joint`, `value`, `lower`, `upper`).
     */
    KINCAL_STATUS_OUT_OF_LIMITS = 103,
    /*
     `kincal_robot.n_joints` is not in 1..=KINCAL_MAX_JOINTS (`found`).
     */
    KINCAL_STATUS_BAD_JOINT_COUNT = 104,
    /*
     Joint limits with lower > upper or a non-finite bound (`joint`).
     */
    KINCAL_STATUS_INVALID_LIMITS = 105,
    /*
     A model parameter the model cannot use, e.g. a negative mass or a zero quaternion
     (`index`, `value`).
     */
    KINCAL_STATUS_INVALID_PARAMETER = 106,
    /*
     An input the model needs is missing: approach directions for a model with backlash,
     temperature for a model with thermal expansion (`quantity`).
     */
    KINCAL_STATUS_MISSING_INPUT = 107,
    /*
     A parameter label or effect name is not known for this robot.
     */
    KINCAL_STATUS_UNKNOWN_LABEL = 108,
    /*
     A parameter, link or pose index is out of range (`index`, `expected` = the count).
     */
    KINCAL_STATUS_INDEX_OUT_OF_RANGE = 109,
    /*
     A 4×4 matrix is not a rigid transform: bottom row not (0, 0, 0, 1), or the rotation
     not orthonormal with determinant +1 within 1e-6 (`argument`).
     */
    KINCAL_STATUS_INVALID_TRANSFORM = 110,
    /*
     An enumeration, flag or option value outside its domain (`argument`, `index`, `value`).
     */
    KINCAL_STATUS_INVALID_ARGUMENT = 111,
    /*
     A fixed capacity is too small (`found` = needed, `expected` = capacity).
     */
    KINCAL_STATUS_CAPACITY_EXCEEDED = 112,
    /*
     Not enough data for the operation (`found`, `expected` = at least).
     */
    KINCAL_STATUS_TOO_FEW_DATA = 113,
    /*
     A pose could not be used, e.g. a degenerate measurement (`pose`).
     */
    KINCAL_STATUS_BAD_POSE = 114,
    /*
     A pointer argument is not aligned for its type (`argument`).
     */
    KINCAL_STATUS_MISALIGNED_POINTER = 115,
    /*
     A joint axis was given with a zero (or non-normalisable) direction (`joint`).
     */
    KINCAL_STATUS_DEGENERATE_AXIS = 116,
    /*
     A `kincal_prepared` handle was not filled by `kincal_prepare` of this library build, or
     has been overwritten or corrupted since (`argument`): prepare it again.
     */
    KINCAL_STATUS_BAD_HANDLE = 117,
    /*
     A group of constraint rows (target or plane) cannot be used: not contiguous, too
     few rows, or a bad known normal (`index` = group).
     */
    KINCAL_STATUS_BAD_GROUP = 118,
    /*
     A plane's contact points are collinear: its normal is undetermined (`index` = group).
     */
    KINCAL_STATUS_DEGENERATE_GROUP = 119,
    /*
     A known distance names a missing or non-target group, or has a bad length or
     weight (`index` = distance).
     */
    KINCAL_STATUS_BAD_DISTANCE = 120,
    /*
     A file could not be read or its reader refused it (std builds: `kincal_model_read`);
     the reason and its line and column are in the call's `kincal_read_error`.
     */
    KINCAL_STATUS_BAD_FILE = 121,
    /*
     Inverse kinematics found no configuration within the limits that reaches the pose
     (`residual_pos_m`, `residual_rot_rad`: the best residual found).
     */
    KINCAL_STATUS_UNREACHABLE = 200,
    /*
     An iterative method stopped at its iteration limit (`iterations`).
     */
    KINCAL_STATUS_NOT_CONVERGED = 201,
    /*
     The data do not determine enough parameters (`found` = rank, `expected` = required).
     */
    KINCAL_STATUS_RANK_DEFICIENT = 202,
    /*
     A parameter fitted under bounds ended outside them (`index`, `value`).
     */
    KINCAL_STATUS_BOUND_VIOLATED = 203,
    /*
     Every input was finite but a result is not (NaN or infinite): the inputs are too large
     for double precision, e.g. link lengths near 1e308 (`argument` = the output, `index` =
     its first bad element, `value`). Nothing is written: an OK call never leaves a
     non-finite number in an output.
     */
    KINCAL_STATUS_NON_FINITE_RESULT = 204,
    /*
     The core reported an error this version of the C ABI does not know: a bug, please
     report it.
     */
    KINCAL_STATUS_INTERNAL = 900,
    /*
     A panic was caught at the boundary: a bug, please report it. The robot and output
     buffers passed to the call may hold partial results.
     */
    KINCAL_STATUS_PANIC = 999,
};
#ifndef __cplusplus
#if __STDC_VERSION__ >= 202311L
typedef enum kincal_status kincal_status;
#else
typedef uint32_t kincal_status;
#endif // __STDC_VERSION__ >= 202311L
#endif // __cplusplus

/*
 Which input held a bad number or is missing (`kincal_error.quantity`).
 */
enum kincal_quantity
#if defined(__cplusplus) || __STDC_VERSION__ >= 202311L
  : uint32_t
#endif // defined(__cplusplus) || __STDC_VERSION__ >= 202311L
 {
    /*
     Not applicable or not known.
     */
    KINCAL_QUANTITY_NONE = 0,
    /*
     A joint reading `q`.
     */
    KINCAL_QUANTITY_JOINT_READING = 1,
    /*
     A model parameter (link, base, tool or effect).
     */
    KINCAL_QUANTITY_PARAMETER = 2,
    /*
     A measured or target position.
     */
    KINCAL_QUANTITY_POSITION = 3,
    /*
     A measured or target orientation.
     */
    KINCAL_QUANTITY_ORIENTATION = 4,
    /*
     A weight, tolerance, bound or other option.
     */
    KINCAL_QUANTITY_SETTING = 5,
    /*
     Approach directions (backlash).
     */
    KINCAL_QUANTITY_APPROACH_DIRECTION = 6,
    /*
     Arm temperature (thermal effect).
     */
    KINCAL_QUANTITY_TEMPERATURE = 7,
};
#ifndef __cplusplus
#if __STDC_VERSION__ >= 202311L
typedef enum kincal_quantity kincal_quantity;
#else
typedef uint32_t kincal_quantity;
#endif // __STDC_VERSION__ >= 202311L
#endif // __cplusplus

/*
 Which of d and β a link identifies (values of `kincal_robot.length_param`).
 */
enum kincal_length_param
#if defined(__cplusplus) || __STDC_VERSION__ >= 202311L
  : uint32_t
#endif // defined(__cplusplus) || __STDC_VERSION__ >= 202311L
 {
    /*
     Identify d, keep β at its nominal value (non-parallel consecutive axes).
     */
    KINCAL_LENGTH_PARAM_D = 0,
    /*
     Identify β, keep d at its nominal value (parallel consecutive axes).
     */
    KINCAL_LENGTH_PARAM_BETA = 1,
};
#ifndef __cplusplus
#if __STDC_VERSION__ >= 202311L
typedef enum kincal_length_param kincal_length_param;
#else
typedef uint32_t kincal_length_param;
#endif // __STDC_VERSION__ >= 202311L
#endif // __cplusplus

/*
 What a joint's reading moves (values of `kincal_robot.joint_kind`).
 */
enum kincal_joint_kind
#if defined(__cplusplus) || __STDC_VERSION__ >= 202311L
  : uint32_t
#endif // defined(__cplusplus) || __STDC_VERSION__ >= 202311L
 {
    /*
     Rotation about the joint axis: `Rz(q + θ0)·Tz(d)·…`, reading and limits in radians.
     */
    KINCAL_JOINT_KIND_REVOLUTE = 0,
    /*
     Translation along the joint axis: `Rz(θ0)·Tz(d + q)·…`, reading and limits in metres;
     its cyclic effect parameters must be zero.
     */
    KINCAL_JOINT_KIND_PRISMATIC = 1,
    /*
     A passive revolute joint read by a sensor (inclinometer or accelerometer tilt),
     reading in radians: not commanded (IK holds it at the seed's reading); its gain is
     the joint_scale parameter; its cyclic and backlash parameters must be zero.
     */
    KINCAL_JOINT_KIND_SENSOR = 2,
};
#ifndef __cplusplus
#if __STDC_VERSION__ >= 202311L
typedef enum kincal_joint_kind kincal_joint_kind;
#else
typedef uint32_t kincal_joint_kind;
#endif // __STDC_VERSION__ >= 202311L
#endif // __cplusplus

/*
 A non-geometric effect. In effect masks (`uint32_t effects`), bit k stands for effect k,
 e.g. `(1u << KINCAL_EFFECT_JOINT_COMPLIANCE) | (1u << KINCAL_EFFECT_BACKLASH)`.
 */
enum kincal_effect
#if defined(__cplusplus) || __STDC_VERSION__ >= 202311L
  : uint32_t
#endif // defined(__cplusplus) || __STDC_VERSION__ >= 202311L
 {
    /*
     `base_frame`: measured poses are expressed in a base frame off by a small rigid
     transform (parameters `base_px` … `base_rz`).
     */
    KINCAL_EFFECT_BASE_FRAME = 0,
    /*
     `tool_frame`: the probe/tool frame is off (`tool_px` … `tool_rz`).
     */
    KINCAL_EFFECT_TOOL_FRAME = 1,
    /*
     `joint_compliance`: Δθ_j = c_j·τ_j(q), τ_j the gravity torque (`compliance_j`,
     rad/(N·m)).
     */
    KINCAL_EFFECT_JOINT_COMPLIANCE = 2,
    /*
     `joint_scale`: Δθ_j = k_j·q_j (`scale_j`).
     */
    KINCAL_EFFECT_JOINT_SCALE = 3,
    /*
     `joint_cyclic`: Δθ_j = a·sin q + b·cos q + c·sin 2q + d·cos 2q (`cyclic_sin1_j`,
     `cyclic_cos1_j`, `cyclic_sin2_j`, `cyclic_cos2_j`, rad).
     */
    KINCAL_EFFECT_JOINT_CYCLIC = 4,
    /*
     `backlash`: Δθ_j = b_j·s_j, s_j the approach direction (`backlash_j`, rad); needs
     approach directions in `kincal_joint_aux`.
     */
    KINCAL_EFFECT_BACKLASH = 5,
    /*
     `thermal`: every d and a times 1 + κ·(T − 20 °C) (`thermal_kappa`, 1/K); needs the
     temperature in `kincal_joint_aux`.
     */
    KINCAL_EFFECT_THERMAL = 6,
};
#ifndef __cplusplus
#if __STDC_VERSION__ >= 202311L
typedef enum kincal_effect kincal_effect;
#else
typedef uint32_t kincal_effect;
#endif // __STDC_VERSION__ >= 202311L
#endif // __cplusplus

/*
 Which orientation error `kincal_pose_error*` report.
 */
enum kincal_orientation_error
#if defined(__cplusplus) || __STDC_VERSION__ >= 202311L
  : uint32_t
#endif // defined(__cplusplus) || __STDC_VERSION__ >= 202311L
 {
    /*
     Eq. (16) of the ARIA paper: S(Δφ) = (R_meas − R_model)·R_modelᵀ, skew part taken.
     First-order accurate; what the paper uses for small calibration errors.
     */
    KINCAL_ORIENTATION_ERROR_SMALL_ANGLE = 0,
    /*
     The exact rotation vector log(R_meas·R_modelᵀ), right for any error size.
     */
    KINCAL_ORIENTATION_ERROR_EXACT = 1,
};
#ifndef __cplusplus
#if __STDC_VERSION__ >= 202311L
typedef enum kincal_orientation_error kincal_orientation_error;
#else
typedef uint32_t kincal_orientation_error;
#endif // __STDC_VERSION__ >= 202311L
#endif // __cplusplus

/*
 Which built-in ARIA model `kincal_robot_aria` writes.
 */
enum kincal_aria_model
#if defined(__cplusplus) || __STDC_VERSION__ >= 202311L
  : uint32_t
#endif // defined(__cplusplus) || __STDC_VERSION__ >= 202311L
 {
    /*
     Table 1 nominal geometry with joint limits (eq. 2; q3 lower limit assumed −π) and the
     assumed mass model.
     */
    KINCAL_ARIA_MODEL_NOMINAL = 0,
    /*
     Table 3: the virtual "true" robot of the paper's simulation study (nominal geometry
     Table 1).
     */
    KINCAL_ARIA_MODEL_VIRTUAL_TRUTH = 1,
    /*
     Table 4: the real robot identified from motion-capture data (nominal geometry Table 1).
     */
    KINCAL_ARIA_MODEL_REAL_IDENTIFIED = 2,
};
#ifndef __cplusplus
#if __STDC_VERSION__ >= 202311L
typedef enum kincal_aria_model kincal_aria_model;
#else
typedef uint32_t kincal_aria_model;
#endif // __STDC_VERSION__ >= 202311L
#endif // __cplusplus

/*
 The identification algorithms of the paper (Section 4.1.3).
 */
enum kincal_algorithm
#if defined(__cplusplus) || __STDC_VERSION__ >= 202311L
  : uint32_t
#endif // defined(__cplusplus) || __STDC_VERSION__ >= 202311L
 {
    /*
     Gauss–Newton with the minimum-norm least-squares step (Matlab `lsqminnorm`).
     */
    KINCAL_ALGORITHM_OLS = 0,
    /*
     Bounded fit inside the prior intervals `lower`/`upper` of the options (`fmincon` in
     the paper): projected Levenberg–Marquardt; parameters ending on a bound are reported.
     */
    KINCAL_ALGORITHM_OPT1 = 1,
    /*
     Levenberg–Marquardt with MINPACK's trust region (`lsqnonlin`).
     */
    KINCAL_ALGORITHM_OPT2 = 2,
};
#ifndef __cplusplus
#if __STDC_VERSION__ >= 202311L
typedef enum kincal_algorithm kincal_algorithm;
#else
typedef uint32_t kincal_algorithm;
#endif // __STDC_VERSION__ >= 202311L
#endif // __cplusplus

/*
 What the registration concluded about one marker (`kincal_marker_fit.status`).
 */
enum kincal_marker_status
#if defined(__cplusplus) || __STDC_VERSION__ >= 202311L
  : uint32_t
#endif // defined(__cplusplus) || __STDC_VERSION__ >= 202311L
 {
    /*
     Used in the fit and consistent with it.
     */
    KINCAL_MARKER_STATUS_INLIER = 0,
    /*
     Masked as not seen.
     */
    KINCAL_MARKER_STATUS_MISSING = 1,
    /*
     Excluded: off by more than its threshold and not explained by a swap.
     */
    KINCAL_MARKER_STATUS_MOVED = 2,
    /*
     Excluded: its label is swapped with marker `swapped_with`.
     */
    KINCAL_MARKER_STATUS_SWAPPED = 3,
    /*
     Used, but above its threshold in a fit no exclusion could make consistent.
     */
    KINCAL_MARKER_STATUS_SUSPECT = 4,
};
#ifndef __cplusplus
#if __STDC_VERSION__ >= 202311L
typedef enum kincal_marker_status kincal_marker_status;
#else
typedef uint32_t kincal_marker_status;
#endif // __STDC_VERSION__ >= 202311L
#endif // __cplusplus

/*
 How the Jacobian columns are scaled before the singular values are taken.
 */
enum kincal_scaling_kind
#if defined(__cplusplus) || __STDC_VERSION__ >= 202311L
  : uint32_t
#endif // defined(__cplusplus) || __STDC_VERSION__ >= 202311L
 {
    /*
     Raw columns (metres per metre, metres per radian): the indices depend on units.
     */
    KINCAL_SCALING_KIND_NONE = 0,
    /*
     Every column divided by its norm over the pose set (the default; the convention of
     the identifiability condition number).
     */
    KINCAL_SCALING_KIND_UNIT_COLUMNS = 1,
    /*
     Columns times the expected error of their parameter: `length_m` for lengths,
     `angle_rad` for angles (effect parameters unscaled).
     */
    KINCAL_SCALING_KIND_TOLERANCE = 2,
};
#ifndef __cplusplus
#if __STDC_VERSION__ >= 202311L
typedef enum kincal_scaling_kind kincal_scaling_kind;
#else
typedef uint32_t kincal_scaling_kind;
#endif // __STDC_VERSION__ >= 202311L
#endif // __cplusplus

/*
 The observability indices; all are "larger is better".
 */
enum kincal_obs_index
#if defined(__cplusplus) || __STDC_VERSION__ >= 202311L
  : uint32_t
#endif // defined(__cplusplus) || __STDC_VERSION__ >= 202311L
 {
    /*
     Eq. (17): σ_min/σ_max.
     */
    KINCAL_OBS_INDEX_O = 0,
    /*
     Borm–Menq: (σ_1···σ_p)^(1/p)/√m.
     */
    KINCAL_OBS_INDEX_O1 = 1,
    /*
     Inverse condition number (equal to O).
     */
    KINCAL_OBS_INDEX_O2 = 2,
    /*
     σ_min.
     */
    KINCAL_OBS_INDEX_O3 = 3,
    /*
     Noise amplification σ_min²/σ_max.
     */
    KINCAL_OBS_INDEX_O4 = 4,
    /*
     1/σ_max.
     */
    KINCAL_OBS_INDEX_O5 = 5,
    /*
     A-optimality 1/Σ σ⁻¹.
     */
    KINCAL_OBS_INDEX_A_OPT = 6,
    /*
     D-optimality ln det(JᵀJ).
     */
    KINCAL_OBS_INDEX_D_OPT = 7,
};
#ifndef __cplusplus
#if __STDC_VERSION__ >= 202311L
typedef enum kincal_obs_index kincal_obs_index;
#else
typedef uint32_t kincal_obs_index;
#endif // __STDC_VERSION__ >= 202311L
#endif // __cplusplus

/*
 A frame axis: the viewing direction of a camera frame (`KINCAL_AXIS_Z` for the optical
 frame of OpenCV, ROS `*_optical_frame` and most calibration toolboxes). Passed as a
 `uint32_t`.
 */
enum kincal_axis
#if defined(__cplusplus) || __STDC_VERSION__ >= 202311L
  : uint32_t
#endif // defined(__cplusplus) || __STDC_VERSION__ >= 202311L
 {
    /*
     The frame's x axis.
     */
    KINCAL_AXIS_X = 0,
    /*
     The frame's y axis.
     */
    KINCAL_AXIS_Y = 1,
    /*
     The frame's z axis.
     */
    KINCAL_AXIS_Z = 2,
};
#ifndef __cplusplus
#if __STDC_VERSION__ >= 202311L
typedef enum kincal_axis kincal_axis;
#else
typedef uint32_t kincal_axis;
#endif // __STDC_VERSION__ >= 202311L
#endif // __cplusplus

/*
 The verdict's status (REPORT.json `verdict.status`).
 */
enum kincal_diagnosis_status
#if defined(__cplusplus) || __STDC_VERSION__ >= 202311L
  : uint32_t
#endif // defined(__cplusplus) || __STDC_VERSION__ >= 202311L
 {
    /*
     `no_gap`: the geometric model is already at the noise floor.
     */
    KINCAL_DIAGNOSIS_STATUS_NO_GAP = 0,
    /*
     `explained`: the verdict's effects close most of the gap and what remains is noise.
     */
    KINCAL_DIAGNOSIS_STATUS_EXPLAINED = 1,
    /*
     `partially_explained`: a significant but smaller share, or a remaining gap.
     */
    KINCAL_DIAGNOSIS_STATUS_PARTIALLY_EXPLAINED = 2,
    /*
     `unexplained`: a gap no candidate closes significantly.
     */
    KINCAL_DIAGNOSIS_STATUS_UNEXPLAINED = 3,
};
#ifndef __cplusplus
#if __STDC_VERSION__ >= 202311L
typedef enum kincal_diagnosis_status kincal_diagnosis_status;
#else
typedef uint32_t kincal_diagnosis_status;
#endif // __STDC_VERSION__ >= 202311L
#endif // __cplusplus

/*
 How the candidates were judged (REPORT.json `method`).
 */
enum kincal_diagnosis_method
#if defined(__cplusplus) || __STDC_VERSION__ >= 202311L
  : uint32_t
#endif // defined(__cplusplus) || __STDC_VERSION__ >= 202311L
 {
    /*
     `cross_validation`: k-fold on held-out pose groups.
     */
    KINCAL_DIAGNOSIS_METHOD_CROSS_VALIDATION = 0,
    /*
     `in_sample_nested`: too few pose groups; likelihood-ratio test with the noise floor.
     */
    KINCAL_DIAGNOSIS_METHOD_IN_SAMPLE_NESTED = 1,
};
#ifndef __cplusplus
#if __STDC_VERSION__ >= 202311L
typedef enum kincal_diagnosis_method kincal_diagnosis_method;
#else
typedef uint32_t kincal_diagnosis_method;
#endif // __STDC_VERSION__ >= 202311L
#endif // __cplusplus

/*
 Why the status (REPORT.json `verdict.reason`).
 */
enum kincal_diagnosis_reason
#if defined(__cplusplus) || __STDC_VERSION__ >= 202311L
  : uint32_t
#endif // defined(__cplusplus) || __STDC_VERSION__ >= 202311L
 {
    /*
     `at_noise_floor`.
     */
    KINCAL_DIAGNOSIS_REASON_AT_NOISE_FLOOR = 0,
    /*
     `closed`.
     */
    KINCAL_DIAGNOSIS_REASON_CLOSED = 1,
    /*
     `remaining_gap` (`reason_z`, `reason_part`).
     */
    KINCAL_DIAGNOSIS_REASON_REMAINING_GAP = 2,
    /*
     `remaining_structure` (`reason_z`: the smooth model's paired z).
     */
    KINCAL_DIAGNOSIS_REASON_REMAINING_STRUCTURE = 3,
    /*
     `worsens` (`reason_z` negative, `reason_part`).
     */
    KINCAL_DIAGNOSIS_REASON_WORSENS = 4,
    /*
     `small_share`.
     */
    KINCAL_DIAGNOSIS_REASON_SMALL_SHARE = 5,
    /*
     `no_significant_candidate`.
     */
    KINCAL_DIAGNOSIS_REASON_NO_SIGNIFICANT_CANDIDATE = 6,
    /*
     `does_not_extrapolate` (`reason_z`: the worst half-range split's z; `reason_joint`).
     */
    KINCAL_DIAGNOSIS_REASON_DOES_NOT_EXTRAPOLATE = 7,
    /*
     `form_not_determined` (`reason_z`: the out-of-library alternative's paired z, below
     the equivalence threshold: the library's form is not singled out by the data;
     `reason_effects`: whose form).
     */
    KINCAL_DIAGNOSIS_REASON_FORM_NOT_DETERMINED = 8,
    /*
     `confounded_with_sessions`: the candidates that improve significantly are all
     confounded with the sessions (the C ABI diagnoses one session: not produced there).
     */
    KINCAL_DIAGNOSIS_REASON_CONFOUNDED_WITH_SESSIONS = 9,
};
#ifndef __cplusplus
#if __STDC_VERSION__ >= 202311L
typedef enum kincal_diagnosis_reason kincal_diagnosis_reason;
#else
typedef uint32_t kincal_diagnosis_reason;
#endif // __STDC_VERSION__ >= 202311L
#endif // __cplusplus

/*
 Position, rotation or both (`reason_part`, warning `part`); 0 = not applicable.
 */
enum kincal_diagnosis_part
#if defined(__cplusplus) || __STDC_VERSION__ >= 202311L
  : uint32_t
#endif // defined(__cplusplus) || __STDC_VERSION__ >= 202311L
 {
    /*
     Not applicable.
     */
    KINCAL_DIAGNOSIS_PART_NONE = 0,
    /*
     Position rows.
     */
    KINCAL_DIAGNOSIS_PART_POSITION = 1,
    /*
     Rotation rows.
     */
    KINCAL_DIAGNOSIS_PART_ROTATION = 2,
    /*
     Both.
     */
    KINCAL_DIAGNOSIS_PART_BOTH = 3,
};
#ifndef __cplusplus
#if __STDC_VERSION__ >= 202311L
typedef enum kincal_diagnosis_part kincal_diagnosis_part;
#else
typedef uint32_t kincal_diagnosis_part;
#endif // __STDC_VERSION__ >= 202311L
#endif // __cplusplus

/*
 What lies beyond the library (REPORT.json `verdict.beyond_library`).
 */
enum kincal_beyond_library
#if defined(__cplusplus) || __STDC_VERSION__ >= 202311L
  : uint32_t
#endif // defined(__cplusplus) || __STDC_VERSION__ >= 202311L
 {
    /*
     `not_applicable`: no open gap, or the check did not run.
     */
    KINCAL_BEYOND_LIBRARY_NOT_APPLICABLE = 0,
    /*
     `smooth_effect`: a smooth function of q closes more (`beyond_library_share`).
     */
    KINCAL_BEYOND_LIBRARY_SMOOTH_EFFECT = 1,
    /*
     `not_a_function_of_q`.
     */
    KINCAL_BEYOND_LIBRARY_NOT_A_FUNCTION_OF_Q = 2,
};
#ifndef __cplusplus
#if __STDC_VERSION__ >= 202311L
typedef enum kincal_beyond_library kincal_beyond_library;
#else
typedef uint32_t kincal_beyond_library;
#endif // __STDC_VERSION__ >= 202311L
#endif // __cplusplus

/*
 Warning codes (REPORT.json `warnings[].code`).
 */
enum kincal_diagnosis_warning_code
#if defined(__cplusplus) || __STDC_VERSION__ >= 202311L
  : uint32_t
#endif // defined(__cplusplus) || __STDC_VERSION__ >= 202311L
 {
    /*
     `noise_vs_repeats`: the repeats scatter `ratio` × the stated σ (`z`, `part`).
     */
    KINCAL_DIAGNOSIS_WARNING_CODE_NOISE_VS_REPEATS = 1,
    /*
     `noise_vs_residuals`: the residuals are below the stated σ, √(χ²/dof) = `ratio`.
     */
    KINCAL_DIAGNOSIS_WARNING_CODE_NOISE_VS_RESIDUALS = 2,
    /*
     `gap_despite_gap_test`: no gap by the gap test (`z_gap`) but a candidate improves
     significantly (`z_candidate`).
     */
    KINCAL_DIAGNOSIS_WARNING_CODE_GAP_DESPITE_GAP_TEST = 3,
    /*
     `too_many_suspects`: `count` rows failed the outlier test; none excluded.
     */
    KINCAL_DIAGNOSIS_WARNING_CODE_TOO_MANY_SUSPECTS = 4,
    /*
     `repeats_drift`: the repeats' differences follow the order of the rows (serial `z`,
     `part`; `ratio` their σ over the stated one, NaN when none was stated): the stated
     σ stays the floor.
     */
    KINCAL_DIAGNOSIS_WARNING_CODE_REPEATS_DRIFT = 5,
};
#ifndef __cplusplus
#if __STDC_VERSION__ >= 202311L
typedef enum kincal_diagnosis_warning_code kincal_diagnosis_warning_code;
#else
typedef uint32_t kincal_diagnosis_warning_code;
#endif // __STDC_VERSION__ >= 202311L
#endif // __cplusplus

/*
 Which code `kincal_diagnosis_name` names.
 */
enum kincal_diagnosis_name_kind
#if defined(__cplusplus) || __STDC_VERSION__ >= 202311L
  : uint32_t
#endif // defined(__cplusplus) || __STDC_VERSION__ >= 202311L
 {
    /*
     A `kincal_diagnosis_status`.
     */
    KINCAL_DIAGNOSIS_NAME_KIND_STATUS = 0,
    /*
     A `kincal_diagnosis_reason`.
     */
    KINCAL_DIAGNOSIS_NAME_KIND_REASON = 1,
    /*
     A `kincal_diagnosis_part`.
     */
    KINCAL_DIAGNOSIS_NAME_KIND_PART = 2,
    /*
     A `kincal_diagnosis_warning_code`.
     */
    KINCAL_DIAGNOSIS_NAME_KIND_WARNING = 3,
    /*
     A `kincal_diagnosis_method`.
     */
    KINCAL_DIAGNOSIS_NAME_KIND_METHOD = 4,
    /*
     A `kincal_beyond_library`.
     */
    KINCAL_DIAGNOSIS_NAME_KIND_BEYOND_LIBRARY = 5,
};
#ifndef __cplusplus
#if __STDC_VERSION__ >= 202311L
typedef enum kincal_diagnosis_name_kind kincal_diagnosis_name_kind;
#else
typedef uint32_t kincal_diagnosis_name_kind;
#endif // __STDC_VERSION__ >= 202311L
#endif // __cplusplus

/*
 Where and why a call failed: a caller-owned plain struct (pass NULL when the detail is not
 wanted; it need not be initialised). Every export that takes one overwrites all of it before
 returning: `status` = the returned code, the fields that code documents set, the others
 cleared (indices `KINCAL_NO_INDEX`, numbers NaN, `argument` NULL, `iterations` 0).
 Indices are zero-based.
 */
typedef struct kincal_error {
    /*
     The status the call returned (a `kincal_status` value).
     */
    uint32_t status;
    /*
     Which input held the bad number or is missing (a `kincal_quantity` value; 0 = none).
     */
    uint32_t quantity;
    /*
     Name of the offending argument or struct field as in the header (e.g. `"q"`,
     `"robot->params"`): a static NUL-terminated string, or NULL when not known. Never free it.
     */
    const char *argument;
    /*
     Element index within that argument, or the parameter index (`KINCAL_NO_INDEX` if none).
     */
    size_t index;
    /*
     Joint (zero-based; `KINCAL_NO_INDEX` if none).
     */
    size_t joint;
    /*
     Pose (zero-based; `KINCAL_NO_INDEX` if none).
     */
    size_t pose;
    /*
     Length, count, rank or capacity that was needed (`KINCAL_NO_INDEX` if none).
     */
    size_t expected;
    /*
     Length, count or rank that was given or found (`KINCAL_NO_INDEX` if none).
     */
    size_t found;
    /*
     The offending value (NaN if none).
     */
    double value;
    /*
     Lower limit [rad] for `KINCAL_STATUS_OUT_OF_LIMITS` (NaN otherwise).
     */
    double lower;
    /*
     Upper limit [rad] for `KINCAL_STATUS_OUT_OF_LIMITS` (NaN otherwise).
     */
    double upper;
    /*
     Best position residual [m] for `KINCAL_STATUS_UNREACHABLE` (NaN otherwise).
     */
    double residual_pos_m;
    /*
     Best orientation residual [rad] for `KINCAL_STATUS_UNREACHABLE` (NaN otherwise).
     */
    double residual_rot_rad;
    /*
     Iterations performed, for `KINCAL_STATUS_NOT_CONVERGED` (0 otherwise).
     */
    uint32_t iterations;
} kincal_error;

/*
 A robot model with 1..=`KINCAL_MAX_JOINTS` revolute or prismatic joints: Hayati/mDH geometry, base and
 tool frames, joint limits, point-mass model and effect parameters. Caller-owned plain data:
 declare it anywhere (stack, static, flash), fill it with `kincal_robot_init` or
 `kincal_robot_aria`, edit it with the `kincal_robot_*` setters or directly, and pass it to
 every call. The library keeps no pointer to it and allocates nothing.

 Every call validates the fields it uses and ignores entries beyond the joint count.
 `sizeof(kincal_robot)` must equal `kincal_robot_size()` (checks that header and library
 agree).

 Units: metres, radians, kilograms, seconds.
 */
typedef struct kincal_robot {
    /*
     Number of joints N, 1..=`KINCAL_MAX_JOINTS`.
     */
    uint32_t n_joints;
    /*
     Per link: `KINCAL_LENGTH_PARAM_D` (0) or `KINCAL_LENGTH_PARAM_BETA` (1).
     */
    uint32_t length_param[KINCAL_MAX_JOINTS];
    /*
     Per joint: `KINCAL_JOINT_KIND_REVOLUTE` (0, what a zeroed struct holds),
     `KINCAL_JOINT_KIND_PRISMATIC` (1) or `KINCAL_JOINT_KIND_SENSOR` (2).
     */
    uint32_t joint_kind[KINCAL_MAX_JOINTS];
    /*
     Current parameters, first `kincal_num_params(N)` = 12N + 13 entries, in the flat layout
     of the core: `5i..5i+5` link i+1 [θ0, d, a, α, β]; `5N..5N+6` base [px, py, pz, rx, ry,
     rz] (Trans(p)·Rot(r), r a rotation vector); `5N+6..5N+12` tool, same form; then
     compliance (N) [rad/(N·m)], scale (N), cyclic (4N: sin q, cos q, sin 2q, cos 2q per
     joint) [rad], backlash (N) [rad], thermal κ [1/K]. Labels: `kincal_robot_param_label`.
     */
    double params[KINCAL_MAX_PARAMS];
    /*
     Nominal geometry (the description's), first `kincal_num_geometric_params(N)` = 5N + 12
     entries in the same layout as `params` (links, base, tool). Gravity torques are
     evaluated with it, so calibrating `params` does not move the mass model.
     */
    double nominal[KINCAL_MAX_GEOMETRIC_PARAMS];
    /*
     Lower joint limits [rad] ([m] for a prismatic joint), inclusive.
     */
    double limits_lower[KINCAL_MAX_JOINTS];
    /*
     Upper joint limits [rad] ([m] for a prismatic joint), inclusive.
     */
    double limits_upper[KINCAL_MAX_JOINTS];
    /*
     Mass of each link [kg], at the midpoint between the origins of frames k−1 and k.
     */
    double link_masses_kg[KINCAL_MAX_JOINTS];
    /*
     Mass of the tool [kg], at the end-effector origin.
     */
    double tool_mass_kg;
    /*
     Gravity in the base frame [m/s²].
     */
    double gravity[3];
} kincal_robot;

/*
 Options of `kincal_identify` and `kincal_analyze_identifiability`; fill them with
 `kincal_identify_options_default`, then edit. Plain data, no pointers.
 */
typedef struct kincal_identify_options {
    /*
     A `kincal_algorithm`.
     */
    uint32_t algorithm;
    /*
     Iteration limit (default 200); reaching it is `KINCAL_STATUS_NOT_CONVERGED`.
     */
    uint32_t max_iterations;
    /*
     Non-zero: fit the identifiable subset even when the data leave some generically
     identifiable parameters undetermined, at the initial or at the fitted model
     (otherwise `KINCAL_STATUS_RANK_DEFICIENT`).
     */
    uint32_t allow_data_deficiency;
    /*
     Orientation error of the cost, a `kincal_orientation_error` (default exact).
     */
    uint32_t orientation;
    /*
     Relative step tolerance (default 1e-12).
     */
    double xtol;
    /*
     Relative cost-reduction tolerance (default 1e-14).
     */
    double ftol;
    /*
     Absolute cost below which the fit is exact (default 1e-28).
     */
    double abs_cost_tol;
    /*
     Identifiability tolerance on unit-scaled Jacobian columns (default 1e-6).
     */
    double rank_tol;
    /*
     Weight of each position row [1/m²] (default 1).
     */
    double weight_pos;
    /*
     Weight of each rotation row [1/rad²] (default 1).
     */
    double weight_rot;
    /*
     Parameters to identify: `requested[i]` non-zero for flat index i (first
     `kincal_num_params(N)` used); only their identifiable subset is fitted.
     */
    uint8_t requested[KINCAL_MAX_PARAMS];
    /*
     OPT1 prior intervals, absolute values per flat index (±infinity allowed, NaN not).
     */
    double lower[KINCAL_MAX_PARAMS];
    /*
     Upper ends of the OPT1 intervals.
     */
    double upper[KINCAL_MAX_PARAMS];
    /*
     Gaussian prior for weak directions, for every algorithm: per flat index, the σ of a
     prior centred on the robot's own value (the model the fit starts from), in the
     parameter's unit; `INFINITY` = no prior (the default everywhere). Each prior adds
     one row weighted 1/σ² on the scale of `weight_pos`/`weight_rot`, so it means what
     it says when those whiten the data (1/σ_instrument²). Counted in the standard
     errors (posterior). `kincal_identify_options_set_prior` fills the link entries.
     */
    double prior_sigma[KINCAL_MAX_PARAMS];
} kincal_identify_options;

/*
 Auxiliary inputs of a joint state that some effects need. Pass NULL where a function takes
 `const kincal_joint_aux *aux` when the model has neither backlash nor thermal expansion.
 */
typedef struct kincal_joint_aux {
    /*
     Non-zero: `approach` holds the approach directions (needed with backlash).
     */
    uint32_t has_approach;
    /*
     Non-zero: `temp_c` holds the arm temperature (needed with thermal expansion).
     */
    uint32_t has_temp;
    /*
     Direction from which each joint approached the pose: −1, 0 or +1 (first N used).
     */
    double approach[KINCAL_MAX_JOINTS];
    /*
     Arm temperature [°C].
     */
    double temp_c;
} kincal_joint_aux;

/*
 A set of measurements: caller-owned arrays, viewed (not copied into the library) for the
 duration of one call. L = `n_poses`, N = the robot's joint count.
 */
typedef struct kincal_measurements {
    /*
     Number of poses L (≥ 1).
     */
    size_t n_poses;
    /*
     Joint readings [rad], L × N row-major (pose l at `q[l*N]`); `q_len` = L·N.
     */
    const double *q;
    /*
     Length of `q`.
     */
    size_t q_len;
    /*
     Measured tool poses `T_e^b` in the base frame: L 4×4 column-major rigid transforms;
     `poses_len` = 16·L.
     */
    const double *poses;
    /*
     Length of `poses`.
     */
    size_t poses_len;
    /*
     Measured components per pose (bit k = component k of `[x, y, z, φx, φy, φz]`: 0x3f a
     full pose, 0x07 position only), or NULL for full poses; `masks_len` = L.
     */
    const uint8_t *masks;
    /*
     Length of `masks` (ignored when NULL).
     */
    size_t masks_len;
    /*
     Approach directions / temperature per pose, or NULL; `aux_len` = L.
     */
    const struct kincal_joint_aux *aux;
    /*
     Length of `aux` (ignored when NULL).
     */
    size_t aux_len;
    /*
     Weight of each pose in the fit (finite, ≥ 0; it multiplies the row weights): 1
     normally, 0 to hold a pose out (cross-validation), other values for robust
     reweighting; or NULL for all 1. `weights_len` = L. Validation ignores the weights.
     */
    const double *weights;
    /*
     Length of `weights` (ignored when NULL).
     */
    size_t weights_len;
} kincal_measurements;

/*
 What the data can determine. Masks are indexed by flat parameter index (1 = member).
 */
typedef struct kincal_identifiability {
    /*
     Number of identifiable parameters.
     */
    size_t rank;
    /*
     σ_max/σ_min of the unit-column-scaled Jacobian of the identifiable parameters
     (infinity when singular).
     */
    double condition_number;
    /*
     What was asked for.
     */
    uint8_t requested[KINCAL_MAX_PARAMS];
    /*
     What the data determine (and is fitted).
     */
    uint8_t identifiable[KINCAL_MAX_PARAMS];
    /*
     Redundant in the model for the measured components, whatever the poses.
     */
    uint8_t structural[KINCAL_MAX_PARAMS];
    /*
     Identifiable in general but not from these poses.
     */
    uint8_t data_deficient[KINCAL_MAX_PARAMS];
    /*
     For each parameter not kept: the kept parameter its column aligns with most
     (`KINCAL_NO_INDEX` if none).
     */
    size_t partner[KINCAL_MAX_PARAMS];
    /*
     |cos| of the angle between the two columns (NaN if no partner).
     */
    double partner_cosine[KINCAL_MAX_PARAMS];
    /*
     Number of valid entries of `singular_values` (= `rank`).
     */
    size_t n_singular_values;
    /*
     Singular values (descending) of the unit-column-scaled Jacobian of the identifiable
     parameters.
     */
    double singular_values[KINCAL_MAX_PARAMS];
} kincal_identifiability;

/*
 Residual statistics of a model on a set of measurements.
 */
typedef struct kincal_residual_stats {
    /*
     Number of poses.
     */
    size_t poses;
    /*
     Number of measured rows (components).
     */
    size_t rows;
    /*
     Weighted sum of squares (the identification cost).
     */
    double cost;
    /*
     RMS of |e_p| over poses with a measured position [m].
     */
    double rms_pos_m;
    /*
     Largest |e_p| [m].
     */
    double max_pos_m;
    /*
     RMS of the rotation angle over poses with a measured orientation [rad].
     */
    double rms_rot_rad;
    /*
     Largest rotation angle [rad].
     */
    double max_rot_rad;
} kincal_residual_stats;

/*
 A pair of strongly correlated parameter estimates.
 */
typedef struct kincal_correlation {
    /*
     First parameter (flat index).
     */
    size_t a;
    /*
     Second parameter (flat index).
     */
    size_t b;
    /*
     Correlation coefficient.
     */
    double rho;
} kincal_correlation;

/*
 Everything `kincal_identify` reports besides the identified model.
 */
typedef struct kincal_identify_report {
    /*
     The `kincal_algorithm` used.
     */
    uint32_t algorithm;
    /*
     Iterations used.
     */
    uint32_t iterations;
    /*
     The identifiability analysis.
     */
    struct kincal_identifiability analysis;
    /*
     Residuals of the initial model.
     */
    struct kincal_residual_stats initial;
    /*
     Residuals of the identified model.
     */
    struct kincal_residual_stats fitted;
    /*
     Residual variance σ² = cost/(rows − fitted parameters) (0 without redundancy).
     */
    double sigma2;
    /*
     Standard error of each fitted parameter (flat index; 0 for parameters not fitted).
     */
    double std_errors[KINCAL_MAX_PARAMS];
    /*
     OPT1: fitted parameters that ended on a bound (mask by flat index).
     */
    uint8_t at_bound[KINCAL_MAX_PARAMS];
    /*
     Number of pairs with |ρ| above 0.95 (only the first `KINCAL_MAX_CORRELATED_PAIRS`
     are listed).
     */
    size_t n_correlated;
    /*
     The listed pairs.
     */
    struct kincal_correlation correlated[KINCAL_MAX_CORRELATED_PAIRS];
    /*
     With a prior: Σ((x − centre)/σ)² over the fitted parameters that carry one; else 0.
     */
    double prior_chi2;
    /*
     With a prior: its rows (fitted parameters with a finite σ); else 0.
     */
    size_t prior_rows;
} kincal_identify_report;

/*
 Options of `kincal_ik` and `kincal_prepared_ik`; start from one of three presets:
 `kincal_ik_options_control_loop` (seed near the answer: microseconds),
 `kincal_ik_options_global_search` (any seed, first solution: tens of microseconds) or
 `kincal_ik_options_default` (every seed, the solution nearest the seed: milliseconds).
 Every field is checked against its bounds before any work (INVALID_ARGUMENT naming the
 field, e.g. `opts->extra_seeds`, and its value), and so is
 the budget (1 + extra_seeds)·max_iterations <= `KINCAL_IK_MAX_TOTAL_ITERATIONS` (20000,
 about 6x the defaults' 3400), so every call ends in bounded time.
 */
typedef struct kincal_ik_options {
    /*
     Iterations per seed, 1..=`KINCAL_IK_MAX_ITERATIONS` (1000; default 200).
     */
    uint32_t max_iterations;
    /*
     1: stop at the first seed that converges (faster; the answer is then the solution
     reached from the earliest converging seed rather than the nearest to the caller's
     seed); 0: try every seed (default). Other values are INVALID_ARGUMENT.
     */
    uint32_t first_solution;
    /*
     Seeds tried after the caller's: a deterministic Halton sequence over the limits clipped
     to ±π, 0..=`KINCAL_IK_MAX_EXTRA_SEEDS` (256; default 16), within the budget above
     (INVALID_ARGUMENT names `opts->extra_seeds` when the budget is exceeded).
     */
    size_t extra_seeds;
    /*
     Convergence: position residual below this [m], in (0, 1] (default 1e-11).
     */
    double tol_pos_m;
    /*
     Convergence: orientation residual below this [rad], in (0, π] (default 1e-11).
     */
    double tol_rot_rad;
} kincal_ik_options;

/*
 What `kincal_ik` found besides the readings.
 */
typedef struct kincal_ik_info {
    /*
     Position residual of the solution [m].
     */
    double residual_pos_m;
    /*
     Orientation residual of the solution [rad].
     */
    double residual_rot_rad;
    /*
     Iterations used from the chosen seed.
     */
    uint32_t iterations;
    /*
     Which seed converged to the solution (0 = the caller's).
     */
    size_t seed_index;
} kincal_ik_info;

#if defined(KINCAL_STD)
/*
 Why a file was refused, where in it, in words: a caller-owned plain struct (pass NULL when
 not wanted). Every call that takes one overwrites all of it: on success `line` and
 `column` 0 and `message` empty; on `KINCAL_STATUS_BAD_FILE` the reader's message (the
 CLI's, e.g. `"model.json:12:5: not valid JSON: …"`) and its position; on any other status
 that status's text.
 */
typedef struct kincal_read_error {
    /*
     1-based line of the fault, 0 when the message names no line.
     */
    size_t line;
    /*
     1-based column of the fault, 0 when the message names none: bytes in a model file,
     the cell (field) number in a measurement CSV.
     */
    size_t column;
    /*
     NUL-terminated UTF-8 message, cut at a character boundary if longer than the buffer.
     */
    char message[KINCAL_READ_MESSAGE_LEN];
} kincal_read_error;
#endif

/*
 Column scaling of the observability exports. Plain data.
 */
typedef struct kincal_scaling {
    /*
     A `kincal_scaling_kind`.
     */
    uint32_t kind;
    /*
     Tolerance of lengths [m] (finite, > 0; used by `KINCAL_SCALING_KIND_TOLERANCE` only).
     */
    double length_m;
    /*
     Tolerance of angles [rad] (finite, > 0; used by `KINCAL_SCALING_KIND_TOLERANCE` only).
     */
    double angle_rad;
} kincal_scaling;

/*
 The observability indices of a pose set (singular values σ of the stacked, scaled
 identification Jacobian: rows `[Δp (m); Δφ (rad)]` per pose, one column per parameter).
 */
typedef struct kincal_observability_indices {
    /*
     Eq. (17), σ_min/σ_max.
     */
    double o;
    /*
     Borm–Menq, (σ_1···σ_p)^(1/p)/√m.
     */
    double o1;
    /*
     Inverse condition number.
     */
    double o2;
    /*
     σ_min.
     */
    double o3;
    /*
     σ_min²/σ_max.
     */
    double o4;
    /*
     1/σ_max.
     */
    double o5;
    /*
     A-optimality, 1/Σ σ⁻¹.
     */
    double a_optimality;
    /*
     D-optimality, ln det(JᵀJ) (−infinity when singular).
     */
    double d_optimality;
    /*
     Smallest singular value.
     */
    double sigma_min;
    /*
     Largest singular value.
     */
    double sigma_max;
    /*
     Number of poses m.
     */
    size_t poses;
    /*
     Number of parameters p (columns).
     */
    size_t params;
} kincal_observability_indices;

/*
 An axis-aligned box in the base frame [m].
 */
typedef struct kincal_region {
    /*
     Lower corner `[x, y, z]` [m].
     */
    double min_m[3];
    /*
     Upper corner `[x, y, z]` [m] (each ≥ the lower one).
     */
    double max_m[3];
} kincal_region;

/*
 The outcome of `kincal_select_poses`.
 */
typedef struct kincal_selection {
    /*
     Objective (the chosen index, from the Gram matrix) of the selected set.
     */
    double value;
    /*
     Objective after the greedy initial set.
     */
    double initial_value;
    /*
     Objective after the exchange, before the joint-space refinement.
     */
    double exchange_value;
    /*
     Objective evaluations.
     */
    uint64_t evaluations;
    /*
     Accepted exchanges.
     */
    size_t exchanges;
    /*
     Accepted refinement moves.
     */
    size_t refinements;
    /*
     The start that gave the result.
     */
    size_t start;
    /*
     The indices of the selected set (SVD route, as `kincal_observability`).
     */
    struct kincal_observability_indices indices;
} kincal_selection;

/*
 The outcome of `kincal_cluster_select`.
 */
typedef struct kincal_cluster_selection {
    /*
     Spread of the per-pose indices of the chosen poses: `max_k |ln σ_k(q) − ln σ_k(q*)|`
     over the chosen `q` and the target `q*` (0.1 ≈ 10 %).
     */
    double spread;
    /*
     Objective (the chosen index) of the chosen set.
     */
    double value;
    /*
     Zero-based pool index of the target pose whose per-pose index the others match.
     */
    size_t target;
    /*
     Non-zero when the spread is within the tolerance (else the smallest spread found).
     */
    uint32_t within_tolerance;
    /*
     Cubes of the region that hold at least one pool member.
     */
    size_t occupied_cubes;
} kincal_cluster_selection;

/*
 A prepared robot model: the core model built and validated once by `kincal_prepare`, for
 fast repeated FK and IK (`kincal_prepared_*`). Caller-owned storage of
 `KINCAL_PREPARED_SIZE` bytes aligned to `KINCAL_PREPARED_ALIGN`, wherever the caller puts it
 (static, stack): the library allocates nothing and keeps no pointer to it.

 The content is opaque and private to the library build that wrote it: do not edit it, do
 not persist it across library builds or versions (prepare again at start-up). A handle may
 be copied with `memcpy`. Storage that `kincal_prepare` did not fill (uninitialised,
 zeroed, overwritten, or from another build) makes every `kincal_prepared_*` call return
 `KINCAL_STATUS_BAD_HANDLE` (cheap header and guard words, checked on every call); a
 checksum over the whole stored model, checked by `kincal_prepared_validate` only, detects
 corruption of the stored numbers themselves.
 */
typedef struct kincal_prepared {
    /*
     Opaque; written only by `kincal_prepare`.
     */
    uint64_t opaque[KINCAL_PREPARED_WORDS];
} kincal_prepared;

/*
 Options of `kincal_register`; `kincal_registration_options_default` fills them.
 */
typedef struct kincal_registration_options {
    /*
     Stated measurement noise, 1σ per axis at weight 1 [m] (finite, > 0).
     */
    double sigma_m;
    /*
     Outlier threshold in units of σ_j on the 3-D residual distance (default 4).
     */
    double k_sigma;
    /*
     Most markers to exclude as outliers (≤ `KINCAL_MAX_OUTLIERS`; 0 disables the search;
     default 2).
     */
    size_t max_outliers;
} kincal_registration_options;

/*
 The fit of one marker.
 */
typedef struct kincal_marker_fit {
    /*
     Predicted position `t_mocap_body · design` in the motion-capture frame [m].
     */
    double predicted_m[3];
    /*
     Residual measured − predicted [m] (zero if missing).
     */
    double residual_m[3];
    /*
     Length of the residual [m] (zero if missing).
     */
    double distance_m;
    /*
     Outlier threshold k·σ/√w of this marker [m].
     */
    double threshold_m;
    /*
     A `kincal_marker_status`.
     */
    uint32_t status;
    /*
     For `KINCAL_MARKER_STATUS_SWAPPED`: the other marker (zero-based); else
     `KINCAL_NO_INDEX`.
     */
    size_t swapped_with;
} kincal_marker_fit;

/*
 The result of `kincal_register`.
 */
typedef struct kincal_registration {
    /*
     The body frame in the motion-capture frame, 4×4 column-major:
     measured ≈ t_mocap_body · design.
     */
    double t_mocap_body[16];
    /*
     Markers used in the fit.
     */
    size_t n_used;
    /*
     Weighted RMS residual distance of the used markers [m].
     */
    double rms_m;
    /*
     1 when every used marker is within its threshold.
     */
    uint32_t consistent;
    /*
     Number of markers (entries of `markers` that are valid).
     */
    size_t n_markers;
    /*
     Per-marker fits, in input order.
     */
    struct kincal_marker_fit markers[KINCAL_MAX_MARKERS];
    /*
     1 when another exclusion fits as well with a different pose (a ghost or knocked
     marker on a body with too few markers to pin it, typical of symmetric designs): the
     pose is not determined and must not be used. 0 otherwise.
     */
    uint32_t ambiguous;
    /*
     When `ambiguous`: the markers (bit j for marker j) the competing fit excludes.
     */
    uint32_t alternative_excluded;
    /*
     When `ambiguous`: the rotation between the two poses [rad]; else 0.
     */
    double ambiguity_rotation_rad;
} kincal_registration;

/*
 Summary of a validation: RMS (sqrt(mean |e|²)) and maximum of the error norms, and whether
 the worst pose meets the targets.
 */
typedef struct kincal_validation_summary {
    /*
     Number of poses.
     */
    size_t count;
    /*
     RMS of |e_p| [m].
     */
    double rms_pos_m;
    /*
     Largest |e_p| [m].
     */
    double max_pos_m;
    /*
     RMS of |e_φ| [rad].
     */
    double rms_rot_rad;
    /*
     Largest |e_φ| [rad].
     */
    double max_rot_rad;
    /*
     1 when every |e_p| is below the position target.
     */
    uint32_t pos_ok;
    /*
     1 when every |e_φ| is below the orientation target.
     */
    uint32_t rot_ok;
} kincal_validation_summary;

/*
 The result of `kincal_view_point`: where the viewing axes of a set of poses converge (the
 `_result` suffix: in C a type cannot share the function's name).
 */
typedef struct kincal_view_point_result {
    /*
     The point nearest (least squares) to every viewing axis, in the frame the poses are
     given in [m].
     */
    double point_m[3];
    /*
     Mean distance from the frame origins to the point, measured along each axis [m]: the
     re-expression distance `s` (the point `s·e_axis` of every frame).
     */
    double mean_distance_m;
    /*
     Smallest distance along an axis [m] (negative: the point lies behind that frame).
     */
    double min_distance_m;
    /*
     Largest distance along an axis [m].
     */
    double max_distance_m;
    /*
     RMS over the poses of the point's distance from each viewing axis [m].
     */
    double miss_rms_m;
    /*
     Largest distance of the point from a viewing axis [m].
     */
    double miss_max_m;
    /*
     Index (zero-based) of the pose whose axis passes farthest from the point.
     */
    size_t miss_max_pose;
} kincal_view_point_result;

/*
 A target of `kincal_constraint_data`: unknown (3 nuisance coordinates, eliminated) or
 known in the base frame.
 */
typedef struct kincal_target {
    /*
     Non-zero: the target's position is known (`xyz_m`, an external reference).
     */
    uint32_t known;
    /*
     Known position in the base frame [m] (ignored when not known).
     */
    double xyz_m[3];
} kincal_target;

/*
 A plane of `kincal_constraint_data`: unknown or known as `normal·p = offset_m`.
 */
typedef struct kincal_plane {
    /*
     Non-zero: the plane is known (`normal`, `offset_m`).
     */
    uint32_t known;
    /*
     Normal in the base frame (any non-zero length).
     */
    double normal[3];
    /*
     `normal·p` on the plane with the normal normalised [m].
     */
    double offset_m;
} kincal_plane;

/*
 A known distance between two targets.
 */
typedef struct kincal_distance {
    /*
     First target (index into the targets).
     */
    uint32_t a;
    /*
     Second target (≠ `a`).
     */
    uint32_t b;
    /*
     The distance [m] (> 0).
     */
    double m;
    /*
     Weight relative to one position coordinate (≥ 0): 1 normally,
     `(σ_data/σ_distance)²` when the distance's uncertainty is known.
     */
    double weight;
} kincal_distance;

/*
 Instrument-free (or mixed) data: caller-owned arrays viewed for one call. L = `n_rows`,
 N = the robot's joint count. Every row is exactly one of: a contact of target `target[l]`,
 a contact of plane `plane[l]`, or an instrument row with the coordinates `coord_mask[l]`
 of `coords`. Rows need not be sorted.
 */
typedef struct kincal_constraint_data {
    /*
     Number of rows L (≥ 1).
     */
    size_t n_rows;
    /*
     Joint readings [rad], L × N row-major; `q_len` = L·N.
     */
    const double *q;
    /*
     Length of `q`.
     */
    size_t q_len;
    /*
     Target of each row (< `n_targets`) or `KINCAL_NO_GROUP`; NULL: no target rows.
     */
    const uint32_t *target;
    /*
     Length of `target` (L; ignored when NULL).
     */
    size_t target_len;
    /*
     Plane of each row (< `n_planes`) or `KINCAL_NO_GROUP`; NULL: no plane rows.
     */
    const uint32_t *plane;
    /*
     Length of `plane` (L; ignored when NULL).
     */
    size_t plane_len;
    /*
     Session of each row (< `n_sessions`); NULL: one session.
     */
    const uint32_t *session;
    /*
     Length of `session` (L; ignored when NULL).
     */
    size_t session_len;
    /*
     Number of sessions (ignored when `session` is NULL).
     */
    size_t n_sessions;
    /*
     Tool point of each row in the tool frame [m], L × 3 (the ball centre, the probe tip);
     NULL: the tool-frame origin.
     */
    const double *point;
    /*
     Length of `point` (3·L; ignored when NULL).
     */
    size_t point_len;
    /*
     Measured coordinates of the tool point in the base frame [m], L × 3 (only the
     components in `coord_mask` are read); NULL: no instrument rows.
     */
    const double *coords;
    /*
     Length of `coords` (3·L; ignored when NULL).
     */
    size_t coords_len;
    /*
     Measured components per row: bit k = coordinate k of `[x, y, z]` (0x7 a full point,
     0x4 z only); 0 on contact rows. NULL: no instrument rows.
     */
    const uint8_t *coord_mask;
    /*
     Length of `coord_mask` (L; ignored when NULL).
     */
    size_t coord_mask_len;
    /*
     Approach directions / temperature per row, or NULL; `aux_len` = L.
     */
    const struct kincal_joint_aux *aux;
    /*
     Length of `aux` (ignored when NULL).
     */
    size_t aux_len;
    /*
     Number of targets T; each needs rows: 2 when unknown, 1 when known.
     */
    size_t n_targets;
    /*
     The targets (T entries), or NULL: all unknown.
     */
    const struct kincal_target *targets;
    /*
     Length of `targets` (T; ignored when NULL).
     */
    size_t targets_len;
    /*
     Number of planes; each needs rows: 3 not collinear when unknown, 1 when known.
     */
    size_t n_planes;
    /*
     The planes, or NULL: all unknown.
     */
    const struct kincal_plane *planes;
    /*
     Length of `planes` (`n_planes`; ignored when NULL).
     */
    size_t planes_len;
    /*
     Number of known distances.
     */
    size_t n_distances;
    /*
     The distances (NULL when `n_distances` is 0).
     */
    const struct kincal_distance *distances;
    /*
     Length of `distances` (`n_distances`).
     */
    size_t distances_len;
} kincal_constraint_data;

/*
 Everything `kincal_identify_constraints` reports besides the model.
 */
typedef struct kincal_constraints_report {
    /*
     The identification report (identifiability, residuals before/after over all rows,
     standard errors, correlations). Its residual statistics count contacts as poses:
     `rms_pos_m` is over targets' 3-D and planes' 1-D residuals and instrument positions.
     */
    struct kincal_identify_report identify;
    /*
     The gauge (mask by flat index): requested parameters no row can see, named rather
     than fixed silently: the base frame without an external reference (no instrument
     row, known target or plane), one length without a length reference (no distance
     either).
     */
    uint8_t gauge[KINCAL_MAX_PARAMS];
    /*
     Non-zero: some row refers to the base frame (instrument row, known target or plane).
     */
    uint32_t external_reference;
    /*
     Non-zero: some row fixes the scale (a distance or an external reference).
     */
    uint32_t length_reference;
    /*
     Instrument rows.
     */
    size_t n_instrument_rows;
    /*
     Contact rows (target and plane rows).
     */
    size_t n_contacts;
} kincal_constraints_report;

/*
 What a target's or plane's contacts say at the identified model.
 */
typedef struct kincal_group_estimate {
    /*
     Contacts with a positive weight.
     */
    size_t contacts;
    /*
     Mean predicted tool point: the estimated target [m] (for planes a point on it).
     */
    double point[3];
    /*
     Unit plane normal (zero for targets).
     */
    double normal[3];
    /*
     Plane offset `normal·p` [m] (0 for targets).
     */
    double offset_m;
    /*
     RMS residual distance of the contacts (3-D for targets, to the plane for planes) [m].
     */
    double rms_m;
    /*
     Largest residual distance [m].
     */
    double max_m;
    /*
     Mean residual distance [m] (MUKCa's "mean absolute consistency error").
     */
    double mean_m;
    /*
     Planes: spread across the best-fit line over extent along it (0 for targets).
     */
    double aspect;
} kincal_group_estimate;

/*
 Options of `kincal_diagnose`; fill with `kincal_diagnose_options_default`, then edit.
 */
typedef struct kincal_diagnose_options {
    /*
     Stated position noise, 1σ per axis [m]; NaN: estimate from repeats.
     */
    double sigma_pos_m;
    /*
     Stated rotation noise, 1σ per axis [rad]; NaN: estimate from repeats.
     */
    double sigma_rot_rad;
    /*
     Cross-validation folds (≥ 2; default 5).
     */
    uint32_t folds;
    /*
     Non-zero: also evaluate every pair of candidate effects (default 1).
     */
    uint32_t pairs;
    /*
     Seed of the fold assignment.
     */
    uint64_t fold_seed;
    /*
     Candidate effects (mask of `kincal_effect` bits); 0: every effect whose inputs all
     rows carry (default).
     */
    uint32_t candidates;
    /*
     Cross-validation needs this many pose groups per fold (default 5), else the
     in-sample nested test.
     */
    uint32_t min_groups_per_fold;
    /*
     Non-zero: screen gross outliers first (default 1).
     */
    uint32_t screen_outliers;
    /*
     Reserved, 0.
     */
    uint32_t reserved;
    /*
     Threshold of the gap test (one-sided z, default 3).
     */
    double z_gap;
    /*
     Threshold of a candidate's improvement (default 3).
     */
    double z_significance;
    /*
     "Not significantly worse" below this paired z (default 3).
     */
    double z_equivalence;
    /*
     Share of the gap closed for `explained` (default 0.8).
     */
    double explained_fraction;
    /*
     Share for `partially_explained` (default 0.25).
     */
    double partial_fraction;
    /*
     Repeats within this temperature difference [°C] are the same conditions (0.5).
     */
    double repeat_temp_tol_c;
    /*
     Rank tolerance of the identifiability tests (default 1e-6).
     */
    double rank_tol;
} kincal_diagnose_options;

/*
 The gap test of a model's held-out errors against the noise floor.
 */
typedef struct kincal_gap_test {
    /*
     Observed over expected whitened held-out total, Q/E.
     */
    double ratio;
    /*
     z of ln(Q/E).
     */
    double z;
    /*
     Held-out RMS position error expected at the noise floor [m].
     */
    double expected_rms_pos_m;
    /*
     Held-out RMS rotation angle expected at the noise floor [rad].
     */
    double expected_rms_rot_rad;
    /*
     The test on the position rows alone (0 without).
     */
    double z_pos;
    /*
     The test on the rotation rows alone (0 without).
     */
    double z_rot;
} kincal_gap_test;

/*
 The library-free smooth check (REPORT.json `explainable`, `remaining_structure`).
 */
typedef struct kincal_smooth_check {
    /*
     Non-zero: the check ran.
     */
    uint32_t evaluated;
    /*
     Non-zero: `z` exceeds the significance threshold.
     */
    uint32_t significant;
    /*
     Share of the held-out gap a smooth function of q removes (whitened), in [0, 1].
     */
    double share_of_gap;
    /*
     The same on the position RMS.
     */
    double share_pos;
    /*
     The same on the rotation RMS.
     */
    double share_rot;
    /*
     Held-out RMS position error after the smooth correction [m].
     */
    double heldout_rms_pos_m;
    /*
     Held-out RMS rotation angle after it [rad].
     */
    double heldout_rms_rot_rad;
    /*
     Paired z against the geometric model (positive: better).
     */
    double z;
} kincal_smooth_check;

/*
 The noise floor used (REPORT.json `noise_floor`). A component type no row measures and
 whose σ was not stated (position-only data: the orientation) has no noise floor:
 `measured_*` and `stated_*` are both 0 and its σ and degrees of freedom are 0 (REPORT.json
 `"not_measured"`, null), never a placeholder.
 */
typedef struct kincal_noise_floor {
    /*
     Position noise, 1σ per axis [m]; 0 when not measured (see `measured_pos`).
     */
    double sigma_pos_m;
    /*
     Rotation noise, 1σ per axis [rad]; 0 when not measured (see `measured_rot`).
     */
    double sigma_rot_rad;
    /*
     Degrees of freedom of the position estimate (infinity when stated, 0 when not
     measured).
     */
    double dof_pos;
    /*
     Degrees of freedom of the rotation estimate (infinity when stated, 0 when not
     measured).
     */
    double dof_rot;
    /*
     Repeat subgroups in the data.
     */
    size_t repeat_subgroups;
    /*
     Non-zero: σ_pos was stated (else from repeats).
     */
    uint32_t stated_pos;
    /*
     Non-zero: σ_rot was stated.
     */
    uint32_t stated_rot;
    /*
     Non-zero: some row measures a position component. 0 with `stated_pos` 0: position
     not measured, no position noise floor.
     */
    uint32_t measured_pos;
    /*
     Non-zero: some row measures an orientation component. 0 with `stated_rot` 0:
     orientation not measured (position-only data), no orientation noise floor; the
     report's rotation RMS values are then 0.
     */
    uint32_t measured_rot;
    /*
     σ per axis the repeats alone give [m] (NaN without repeats).
     */
    double repeats_pos_m;
    /*
     Its degrees of freedom (0 without).
     */
    double repeats_pos_dof;
    /*
     σ per axis of the rotation repeats [rad] (NaN without).
     */
    double repeats_rot_rad;
    /*
     Its degrees of freedom.
     */
    double repeats_rot_dof;
    /*
     Non-zero: the stated σ_pos was overruled by noisier repeats (the floor uses them).
     */
    uint32_t overruled_pos;
    /*
     Non-zero: the stated σ_rot was overruled.
     */
    uint32_t overruled_rot;
    /*
     The overruled stated σ_pos [m] (NaN when not overruled).
     */
    double overruled_pos_m;
    /*
     The overruled stated σ_rot [rad] (NaN when not overruled).
     */
    double overruled_rot_rad;
} kincal_noise_floor;

/*
 One model's score (REPORT.json `candidates[]`, `baseline`).
 */
typedef struct kincal_model_score {
    /*
     Effects of the model (mask of `kincal_effect` bits; 0 for the baseline).
     */
    uint32_t effects;
    /*
     Non-zero: evaluated (0: no effect parameter separable from the geometry,
     `confounded_with_geometry`).
     */
    uint32_t evaluated;
    /*
     Non-zero: significantly better than the geometric model.
     */
    uint32_t significant;
    /*
     Reserved, 0.
     */
    uint32_t reserved;
    /*
     Parameters fitted.
     */
    size_t fitted_params;
    /*
     Held-out RMS position error [m].
     */
    double heldout_rms_pos_m;
    /*
     Held-out RMS rotation angle [rad].
     */
    double heldout_rms_rot_rad;
    /*
     Whitened held-out total.
     */
    double heldout_chi2;
    /*
     Paired z of the improvement over the baseline.
     */
    double improvement_z;
    /*
     Paired z against the best candidate (positive: worse).
     */
    double z_vs_best;
    /*
     Paired z against the winner.
     */
    double z_vs_winner;
    /*
     Paired z of the improvement in position alone (negative: worse).
     */
    double z_pos;
    /*
     The same in rotation alone.
     */
    double z_rot;
    /*
     Share of the position gap closed.
     */
    double gap_closed_fraction;
    /*
     Share of the rotation gap closed.
     */
    double gap_closed_rot_fraction;
    /*
     Whitened share (position and rotation): what the status is decided on.
     */
    double gap_closed_total_fraction;
    /*
     How distinct the effect's columns are from the geometry (smallest sine).
     */
    double distinctness;
} kincal_model_score;

/*
 A warning (REPORT.json `warnings[]`); the fields its code documents are set, the others 0.
 */
typedef struct kincal_diagnosis_warning {
    /*
     A `kincal_diagnosis_warning_code`.
     */
    uint32_t code;
    /*
     A `kincal_diagnosis_part`.
     */
    uint32_t part;
    /*
     Ratio (noise warnings).
     */
    double ratio;
    /*
     z (noise warnings).
     */
    double z;
    /*
     The baseline's gap-test z (`gap_despite_gap_test`).
     */
    double z_gap;
    /*
     The best candidate's improvement z (`gap_despite_gap_test`).
     */
    double z_candidate;
    /*
     Rows that failed the outlier test (`too_many_suspects`).
     */
    size_t count;
} kincal_diagnosis_warning;

/*
 Everything `kincal_diagnose` found: the fields of REPORT.json (`where`, per-pose rows,
 files and settings aside), in SI units.
 */
typedef struct kincal_diagnosis_report {
    /*
     A `kincal_diagnosis_status`.
     */
    uint32_t status;
    /*
     A `kincal_diagnosis_method` (`in_sample_nested` with too few pose groups).
     */
    uint32_t method;
    /*
     A `kincal_diagnosis_reason`.
     */
    uint32_t reason;
    /*
     Where the remaining gap lies or what gets worse (a `kincal_diagnosis_part`).
     */
    uint32_t reason_part;
    /*
     The z of the reason (remaining gap, remaining structure, worsening, extrapolation,
     form check); NaN otherwise.
     */
    double reason_z;
    /*
     For `does_not_extrapolate`: the joint (zero-based) whose half range was held out;
     `KINCAL_NO_INDEX` otherwise.
     */
    size_t reason_joint;
    /*
     For `form_not_determined`: the effect whose form the data do not determine
     (`joint_cyclic` or `thermal`, as a mask of `kincal_effect` bits); 0 otherwise.
     */
    uint32_t reason_effects;
    /*
     The verdict's effects (the winner; mask of `kincal_effect` bits; 0 for none).
     */
    uint32_t effects;
    /*
     Union of the effects of every confounded candidate (REPORT.json `confounded_with`).
     */
    uint32_t confounded_effects;
    /*
     The winner's index in `candidates`, or `KINCAL_NO_INDEX`.
     */
    size_t winner;
    /*
     Candidates that explain the data as well as the winner (first `n_confounded` of
     `confounded_with`, each an effect mask).
     */
    size_t n_confounded;
    /*
     The confounded candidates.
     */
    uint32_t confounded_with[KINCAL_DIAG_MAX_CANDIDATES];
    /*
     Share of the position gap closed.
     */
    double gap_closed_fraction;
    /*
     Share of the rotation gap closed.
     */
    double gap_closed_rot_fraction;
    /*
     Whitened share (position and rotation): the status's share.
     */
    double gap_closed_total_fraction;
    /*
     Held-out RMS position error of the verdict's model [m].
     */
    double heldout_rms_pos_m;
    /*
     Held-out RMS rotation angle of the verdict's model [rad]; 0 (like every rotation
     RMS of the report) when no row measures the orientation (`noise.measured_rot` 0).
     */
    double heldout_rms_rot_rad;
    /*
     The gap test of what remains (z, z_pos, z_rot).
     */
    struct kincal_gap_test remaining;
    /*
     Non-zero: the remaining gap test exceeds `z_gap`.
     */
    uint32_t remaining_gap_significant;
    /*
     A `kincal_beyond_library`.
     */
    uint32_t beyond_library;
    /*
     Share a smooth function of q closes when `beyond_library` is `smooth_effect`, else
     NaN.
     */
    double beyond_library_share;
    /*
     Held-out RMS of what remains per axis (x, y, z [m], rx, ry, rz [rad]).
     */
    double remaining_rms_axis[6];
    /*
     "Explainable at all?": the smooth check on the baseline's held-out residuals.
     */
    struct kincal_smooth_check explainable;
    /*
     The same check on the verdict's held-out residuals (run when it would be explained).
     */
    struct kincal_smooth_check remaining_structure;
    /*
     The noise floor used.
     */
    struct kincal_noise_floor noise;
    /*
     The geometric model's score.
     */
    struct kincal_model_score baseline;
    /*
     The geometric model's gap test.
     */
    struct kincal_gap_test gap;
    /*
     In-sample RMS position error of the geometric calibration [m].
     */
    double insample_rms_pos_m;
    /*
     In-sample RMS rotation angle of the geometric calibration [rad].
     */
    double insample_rms_rot_rad;
    /*
     Number of candidates (singles in `kincal_effect` order, then pairs).
     */
    size_t n_candidates;
    /*
     The candidates.
     */
    struct kincal_model_score candidates[KINCAL_DIAG_MAX_CANDIDATES];
    /*
     Number of suspect rows (gross outliers excluded from every fit and test).
     */
    size_t n_suspects;
    /*
     Suspect rows (zero-based indices into the data, ascending).
     */
    size_t suspects[KINCAL_DIAG_MAX_SUSPECTS];
    /*
     Number of warnings.
     */
    size_t n_warnings;
    /*
     The warnings.
     */
    struct kincal_diagnosis_warning warnings[KINCAL_DIAG_MAX_WARNINGS];
    /*
     Distinct pose groups.
     */
    size_t groups;
    /*
     Folds used.
     */
    size_t folds;
} kincal_diagnosis_report;

/*
 Per-pose outputs of `kincal_diagnose` (REPORT.json `where.per_pose`).
 */
typedef struct kincal_pose_diagnosis {
    /*
     The pose's group id.
     */
    uint32_t group;
    /*
     Its cross-validation fold.
     */
    uint32_t fold;
    /*
     Non-zero: a suspect row (excluded).
     */
    uint32_t suspect;
    /*
     Reserved, 0.
     */
    uint32_t reserved;
    /*
     Residual of the geometric calibration on all rows `[Δp (m); Δφ (rad)]`; 0 in the
     components the pose does not measure (its `masks` bits).
     */
    double residual[6];
    /*
     Held-out residual of the geometric model.
     */
    double heldout_baseline[6];
    /*
     Held-out residual of the verdict's model.
     */
    double heldout_final[6];
} kincal_pose_diagnosis;

#if defined(KINCAL_STD)
/*
 What a measurement file holds: the sizes of the buffers `kincal_measurements_read` fills,
 and which optional columns the file has. Plain data, written by
 `kincal_measurements_read_sizes`.
 */
typedef struct kincal_measurement_sizes {
    /*
     Data rows L (≥ 1).
     */
    size_t n_rows;
    /*
     Joints N: the robot's, or without a robot the highest `qK` of the header.
     */
    size_t n_joints;
    /*
     Header columns (names in `text`).
     */
    size_t n_columns;
    /*
     Comment lines before the header (in `text`).
     */
    size_t n_comments;
    /*
     `extra_*` columns (values per row in `text`).
     */
    size_t n_extra;
    /*
     Bytes of `text`, every string's NUL included.
     Length of `text` (ignored when NULL).
     */
    size_t text_len;
    /*
     1-based line of the header row.
     */
    size_t header_line;
    /*
     Orientation columns: 0 none, 1 roll/pitch/yaw, 2 qw/qx/qy/qz.
     */
    uint32_t orientation;
    /*
     Non-zero: the file has x, y, z.
     */
    uint32_t has_position;
    /*
     Non-zero: the file has `pose_id` (one label per row in `text`).
     */
    uint32_t has_pose_id;
    /*
     Non-zero: the file has the approach directions s1..sN.
     */
    uint32_t has_approach;
    /*
     Non-zero: the file has `temp_c`.
     */
    uint32_t has_temperature;
    /*
     Non-zero: the file has contact columns (`point_x/y/z`, `target`, `plane`, `session`),
     which these outputs do not carry: read such files with the CLI (`kincal calibrate`).
     Target and plane rows come out with mask 0.
     */
    uint32_t has_contacts;
} kincal_measurement_sizes;
#endif

#if defined(KINCAL_STD)
/*
 Where `kincal_measurements_read` writes: caller-owned buffers, each NULL when not wanted
 or exactly the length `kincal_measurement_sizes` gives (L rows, N joints).
 */
typedef struct kincal_measurement_buffers {
    /*
     Joint readings [rad, or m for a prismatic joint], L × N row-major; `q_len` = L·N.
     */
    double *q;
    /*
     Length of `q` (ignored when NULL).
     */
    size_t q_len;
    /*
     Measured poses, L 4×4 column-major transforms [m]; `poses_len` = 16·L. Rows without
     an orientation have the identity rotation, rows without a position the identity pose.
     */
    double *poses;
    /*
     Length of `poses` (ignored when NULL).
     */
    size_t poses_len;
    /*
     Measured components per row, as `kincal_measurements.masks`: 0x3f a full pose, 0x07
     a position, the bits of the coordinates given for a partial position, 0 none;
     `masks_len` = L.
     */
    uint8_t *masks;
    /*
     Length of `masks` (ignored when NULL).
     */
    size_t masks_len;
    /*
     Approach directions and temperature per row (flags set when the file has them);
     `aux_len` = L.
     */
    struct kincal_joint_aux *aux;
    /*
     Length of `aux` (ignored when NULL).
     */
    size_t aux_len;
    /*
     1-based file line of each row; `lines_len` = L.
     */
    size_t *lines;
    /*
     Length of `lines` (ignored when NULL).
     */
    size_t lines_len;
    /*
     The file's text, NUL-terminated UTF-8 strings one after another: the comments
     (without the `#`, as written), the column names, then per row its `pose_id` (when
     the file has one) and its `n_extra` extra cells; `text_len` = the sizes' `text_len`.
     */
    char *text;
    /*
     Length of `text` (ignored when NULL).
     */
    size_t text_len;
} kincal_measurement_buffers;
#endif

#ifdef __cplusplus
extern "C" {
#endif // __cplusplus

#if defined(KINCAL_TEST_PANIC)
/*
 Panics on purpose inside the panic boundary; returns `KINCAL_STATUS_PANIC` (and fills `err`)
 in `std` builds. Exists only with the cargo feature `test-panic`, to prove from C that no
 panic crosses the ABI; in the `panic-never` build it is the canary whose reference must
 make the link fail.

 # Safety
 `err` must be NULL or point to a writable `kincal_error`.
 */
kincal_status kincal_test_panic(struct kincal_error *err);
#endif

/*
 Writes a built-in ARIA model (`model` is a `kincal_aria_model`) into `robot_out` (need not be
 initialised; written on success only). Identity base and tool, no effects. Returns OK,
 NULL_POINTER, MISALIGNED_POINTER or INVALID_ARGUMENT (`model`).

 # Safety
 `robot_out` must be NULL or writable; `err` NULL or writable.
 */
kincal_status kincal_robot_aria(struct kincal_robot *robot_out,
                                uint32_t model,
                                struct kincal_error *err);

/*
 Table 2 calibration-tool pose `index` (zero-based, < `KINCAL_ARIA_NUM_TOOL_POSES`) as a 4×4
 column-major pose in `t_out` (16 doubles). Returns OK, NULL_POINTER, MISALIGNED_POINTER,
 BAD_LENGTH or INDEX_OUT_OF_RANGE.

 # Safety
 `t_out` must be NULL or writable for `t_len` doubles; `err` NULL or writable.
 */
kincal_status kincal_aria_tool_pose(size_t index,
                                    double *t_out,
                                    size_t t_len,
                                    struct kincal_error *err);

/*
 A configuration near the Table 2 tool poses [rad] (6 doubles in `q_out`), the IK seed that
 solves every tool pose on the same branch. Returns OK, NULL_POINTER, MISALIGNED_POINTER or
 BAD_LENGTH.

 # Safety
 `q_out` must be NULL or writable for `q_len` doubles; `err` NULL or writable.
 */
kincal_status kincal_aria_tool_seed(double *q_out,
                                    size_t q_len,
                                    struct kincal_error *err);

/*
 Builds a robot from its N revolute joint axes at q = 0, all given in one reference frame:
 the mDH links, d/β choices (β for parallel consecutive axes), base and tool frames are
 computed so that the model's FK equals the chain's product of exponentials
 `T_base_tool(q) = T_ref_base⁻¹ · Rot(p_1, u_1, q_1) ··· Rot(p_N, u_N, q_N) · T_ref_tool`
 to rounding. No masses, no effects; this geometry is also the nominal one.

 - `robot_out`: written on success only; need not be initialised.
 - `n_joints`: 1..=`KINCAL_MAX_JOINTS`.
 - `points`, `points_len`: a point on each axis [m], N × 3 doubles.
 - `directions`, `directions_len`: each axis direction, N × 3 doubles (positive rotation is
   right-handed about it; normalised, must not be zero).
 - `t_ref_base`, `t_ref_base_len`: the robot's base frame in the reference frame (16 doubles,
   4×4 column-major), or NULL for identity.
 - `t_ref_tool`, `t_ref_tool_len`: the tool (flange) frame in the reference frame at q = 0,
   or NULL for identity.
 - `limits`, `limits_len`: `[lower, upper]` per joint [rad], 2N doubles.

 Returns OK, NULL_POINTER, MISALIGNED_POINTER, BAD_JOINT_COUNT, BAD_LENGTH, NON_FINITE,
 INVALID_TRANSFORM, DEGENERATE_AXIS (`joint`) or INVALID_LIMITS.

 # Safety
 Non-NULL pointers must be valid for their stated lengths; `err` NULL or writable.
 */
kincal_status kincal_robot_from_axes(struct kincal_robot *robot_out,
                                     size_t n_joints,
                                     const double *points,
                                     size_t points_len,
                                     const double *directions,
                                     size_t directions_len,
                                     const double *t_ref_base,
                                     size_t t_ref_base_len,
                                     const double *t_ref_tool,
                                     size_t t_ref_tool_len,
                                     const double *limits,
                                     size_t limits_len,
                                     struct kincal_error *err);

/*
 The public name of effect `effect` (`"base_frame"`, `"joint_compliance"`, …): a static
 NUL-terminated string (never free it), or NULL when `effect` is not a `kincal_effect`.
 */
const char *kincal_effect_name(uint32_t effect);

/*
 The `kincal_effect` named `name` (NUL-terminated, e.g. `"joint_compliance"`), written to
 `effect_out`. Returns OK, NULL_POINTER, MISALIGNED_POINTER or UNKNOWN_LABEL.

 # Safety
 `name` must be NULL or a NUL-terminated string; `effect_out` NULL or writable; `err` NULL or
 writable.
 */
kincal_status kincal_effect_from_name(const char *name,
                                      uint32_t *effect_out,
                                      struct kincal_error *err);

/*
 The mask of the joint effects with a non-zero parameter in the model (compliance, scale,
 cyclic, backlash, thermal; base and tool frames are geometry and never reported), written
 to `effects_out`. Returns OK, NULL_POINTER, MISALIGNED_POINTER or any status of
 `kincal_robot_validate`.

 # Safety
 `robot` must be NULL or point to a readable `kincal_robot`; `effects_out` NULL or writable;
 `err` NULL or writable.
 */
kincal_status kincal_robot_active_effects(const struct kincal_robot *robot,
                                          uint32_t *effects_out,
                                          struct kincal_error *err);

/*
 Sets every parameter of the effects in the mask `effects` to zero (for `base_frame` and
 `tool_frame`: the current base/tool frame becomes identity). On failure `*robot` is
 unchanged. Returns OK, NULL_POINTER, MISALIGNED_POINTER, INVALID_ARGUMENT (unknown bits) or
 any status of `kincal_robot_validate`.

 # Safety
 `robot` must be NULL or point to a readable and writable `kincal_robot`; `err` NULL or
 writable.
 */
kincal_status kincal_robot_clear_effects(struct kincal_robot *robot,
                                         uint32_t effects,
                                         struct kincal_error *err);

/*
 Bytes of caller memory `kincal_identify` and `kincal_analyze_identifiability` need for
 `n_poses` measurements of an `n_joints` robot when `n_requested` parameters are
 requested (the count of non-zero `requested` entries; the size is that of the smallest
 capacity, 32 or `KINCAL_MAX_PARAMS`, that holds them: about 92 KB or 1.45 MB,
 plus about 0.26 KB per pose). Returns 0 for an invalid joint count, more than
 `KINCAL_MAX_PARAMS` parameters, or an overflowing size.
 */
size_t kincal_identify_workspace_size(size_t n_joints,
                                      size_t n_poses,
                                      size_t n_requested);

/*
 Default identification options for `robot`: `algorithm` (a `kincal_algorithm`), the
 geometric parameters θ0, a, α and d-or-β of every link plus every parameter of the effects in
 the mask `effects` requested, OPT1 intervals of the paper (±5 mm on lengths, ±5° on angles
 around the current parameters; compliance in [0, 1e-2] rad/(N·m)), and the tolerances listed
 in `kincal_identify_options`. Returns OK, NULL_POINTER, MISALIGNED_POINTER,
 INVALID_ARGUMENT (`algorithm`, `effects`) or any status of `kincal_robot_validate`.

 # Safety
 `robot` must be NULL or point to a readable `kincal_robot`; `opts_out` NULL or writable;
 `err` NULL or writable.
 */
kincal_status kincal_identify_options_default(const struct kincal_robot *robot,
                                              uint32_t algorithm,
                                              uint32_t effects,
                                              struct kincal_identify_options *opts_out,
                                              struct kincal_error *err);

/*
 Sets `opts->prior_sigma` for `robot`'s link parameters: `length_m` on every link length
 (d, a) and `angle_rad` on every link angle (θ0, α, β); frames and effects get no prior
 (`INFINITY`). The CLI's defaults are 5 mm and 1° (`kincal calibrate --prior`). Either
 size may be `INFINITY` (no prior on that kind). Returns OK, NULL_POINTER,
 MISALIGNED_POINTER, INVALID_ARGUMENT (a size NaN, zero or negative; a bad robot).

 # Safety
 `robot` points to a readable `kincal_robot`; `opts` to a writable
 `kincal_identify_options` (typically filled by `kincal_identify_options_default`); `err`
 is NULL or writable.
 */
kincal_status kincal_identify_options_set_prior(const struct kincal_robot *robot,
                                                double length_m,
                                                double angle_rad,
                                                struct kincal_identify_options *opts,
                                                struct kincal_error *err);

/*
 Identification: fits the identifiable subset of `opts->requested` to the measurements,
 starting from `robot`, with `opts->algorithm` (OLS, OPT1 or OPT2), and writes the identified
 model to `robot_out` and the report (identifiability analysis, residuals before and after,
 standard errors, correlations, parameters on a bound) to `report_out` (NULL if not wanted).
 OLS and OPT2 give each fitted link angle (θ0, α, β) within half a turn of its initial value.

 - `robot`: initial model (read only). `robot_out` may point to the same struct.
 - `data`: the measurements (see `kincal_measurements`); their poses in metres.
 - `opts`: from `kincal_identify_options_default`, possibly edited.
 - `workspace`, `workspace_len`: caller memory of at least `kincal_identify_workspace_size(N,
   L, requested count)` bytes, aligned to `KINCAL_WORKSPACE_ALIGN`; its contents are scratch.

 Returns OK; argument errors (NULL_POINTER, MISALIGNED_POINTER, BAD_LENGTH with `expected` =
 the bytes needed for a short workspace, NON_FINITE, INVALID_TRANSFORM or INVALID_ARGUMENT
 with `pose` set for a bad measurement, INVALID_ARGUMENT for an option, MISSING_INPUT when a
 requested effect's input is missing, TOO_FEW_DATA, CAPACITY_EXCEEDED, any status of
 `kincal_robot_validate`); RANK_DEFICIENT (the data leave requested parameters undetermined;
 see `kincal_analyze_identifiability`, or set `allow_data_deficiency`: a parameter found
 undetermined only at the fitted model is then held and listed in the result's analysis),
 NOT_CONVERGED (`iterations`),
 INVALID_PARAMETER (OPT1 with an initial value outside its interval). Outputs are written on
 success only.

 # Safety
 Non-NULL pointers must be valid for their stated lengths (`workspace` writable for
 `workspace_len` bytes and not overlapping the other arguments); `err` NULL or writable.
 */
kincal_status kincal_identify(const struct kincal_robot *robot,
                              const struct kincal_measurements *data,
                              const struct kincal_identify_options *opts,
                              void *workspace,
                              size_t workspace_len,
                              struct kincal_robot *robot_out,
                              struct kincal_identify_report *report_out,
                              struct kincal_error *err);

/*
 The identifiability analysis alone: which of `opts->requested` the measurements determine
 (rank, structural and data-deficient parameters with their aligned partners, condition
 number and singular values of the unit-scaled Jacobian), written to `analysis_out`.
 Arguments, memory and statuses as `kincal_identify` (no iterations, so never
 NOT_CONVERGED or RANK_DEFICIENT: a deficiency is reported in `analysis_out`).

 # Safety
 As `kincal_identify`.
 */
kincal_status kincal_analyze_identifiability(const struct kincal_robot *robot,
                                             const struct kincal_measurements *data,
                                             const struct kincal_identify_options *opts,
                                             void *workspace,
                                             size_t workspace_len,
                                             struct kincal_identifiability *analysis_out,
                                             struct kincal_error *err);

/*
 Writes the default IK options into `opts_out`. Returns OK, NULL_POINTER or
 MISALIGNED_POINTER.

 # Safety
 `opts_out` must be NULL or writable; `err` NULL or writable.
 */
kincal_status kincal_ik_options_default(struct kincal_ik_options *opts_out,
                                        struct kincal_error *err);

/*
 Writes the control-loop IK options into `opts_out`: one descent of at most 50 iterations
 from the caller's seed (the last cycle's answer), no further seeds; a few microseconds
 from a seed within a few degrees of the answer, never a jump to another branch. On
 UNREACHABLE (rare: an answer against a joint limit or at a singularity) fall back to
 `kincal_ik_options_global_search`. Returns OK, NULL_POINTER or MISALIGNED_POINTER.

 # Safety
 `opts_out` must be NULL or writable; `err` NULL or writable.
 */
kincal_status kincal_ik_options_control_loop(struct kincal_ik_options *opts_out,
                                             struct kincal_error *err);

/*
 Writes the global-search IK options into `opts_out`, for a target whose branch is unknown:
 the caller's seed, then up to 128 Halton seeds over the joint ranges, each descent cut
 off after 20 iterations, stopping at the first solution (not the one nearest the seed).
 Tens of microseconds where the default (every seed to the end) takes milliseconds.
 Returns OK, NULL_POINTER or MISALIGNED_POINTER.

 # Safety
 `opts_out` must be NULL or writable; `err` NULL or writable.
 */
kincal_status kincal_ik_options_global_search(struct kincal_ik_options *opts_out,
                                              struct kincal_error *err);

/*
 Inverse kinematics: readings `q_out` (N doubles [rad], within the joint limits) whose
 effect-compensated FK reaches `target` (4×4 column-major rigid transform, 16 doubles: the
 tool pose in the base frame). Damped least squares from `q_seed` and `opts->extra_seeds`
 further seeds; the converged solution nearest to `q_seed` is returned (joints whose range
 spans more than 2π are shifted by ±2π towards the seed where the limits allow).

 - `q_seed`, `q_seed_len`: start configuration [rad], N doubles (clamped into the limits).
 - `aux`: approach directions / temperature the model needs, or NULL.
 - `opts`: NULL for the defaults (`kincal_ik_options_default`); a control loop passes
   `kincal_ik_options_control_loop`'s options, a search without a good seed
   `kincal_ik_options_global_search`'s.
 - `q_out`, `q_out_len`: N doubles, written on success only; may overlap `q_seed`.
 - `info_out`: residuals, iterations and seed of the solution, or NULL.

 Returns OK, UNREACHABLE (no seed converged; `residual_pos_m`/`residual_rot_rad` give the
 best residual found), NULL_POINTER, MISALIGNED_POINTER, BAD_LENGTH, NON_FINITE,
 INVALID_TRANSFORM, INVALID_ARGUMENT (an approach direction, or an option outside the
 bounds documented in `kincal_ik_options`), MISSING_INPUT or any status of
 `kincal_robot_validate`. With `std` the call runs in a catch_unwind
 boundary; the no_std build is proved panic-free at link time.

 # Safety
 Non-NULL pointers must be valid for their stated lengths; `err` NULL or writable.
 */
kincal_status kincal_ik(const struct kincal_robot *robot,
                        const double *target,
                        size_t target_len,
                        const double *q_seed,
                        size_t q_seed_len,
                        const struct kincal_joint_aux *aux,
                        const struct kincal_ik_options *opts,
                        double *q_out,
                        size_t q_out_len,
                        struct kincal_ik_info *info_out,
                        struct kincal_error *err);

/*
 Forward kinematics: the tool pose `T_e^b` (end effector in the base frame, effects
 compensated) as a 4×4 column-major matrix.

 - `robot`: the model (read only; the library keeps no pointer to it).
 - `q`, `q_len`: joint readings [rad], `q_len` = `robot->n_joints` (else BAD_LENGTH).
 - `aux`: approach directions / temperature, or NULL (then a model with backlash or thermal
   expansion returns MISSING_INPUT).
 - `t_base_tool_out`, `t_base_tool_len`: 16 doubles, written on success only.
 - `err`: detail on failure, or NULL.

 Joint limits are not checked (see `kincal_robot_check_limits`). Returns OK, NULL_POINTER,
 MISALIGNED_POINTER, BAD_LENGTH, NON_FINITE, INVALID_ARGUMENT (an approach direction not
 −1/0/+1), MISSING_INPUT or any status of `kincal_robot_validate`.

 # Safety
 Non-NULL pointers must be valid for their stated lengths; `err` NULL or writable.
 */
kincal_status kincal_fk(const struct kincal_robot *robot,
                        const double *q,
                        size_t q_len,
                        const struct kincal_joint_aux *aux,
                        double *t_base_tool_out,
                        size_t t_base_tool_len,
                        struct kincal_error *err);

/*
 As `kincal_fk`, with the pose as position + quaternion `[px, py, pz, qw, qx, qy, qz]`
 (metres; unit quaternion, qw ≥ 0) in `pq_out` (7 doubles).

 # Safety
 Non-NULL pointers must be valid for their stated lengths; `err` NULL or writable.
 */
kincal_status kincal_fk_pq(const struct kincal_robot *robot,
                           const double *q,
                           size_t q_len,
                           const struct kincal_joint_aux *aux,
                           double *pq_out,
                           size_t pq_len,
                           struct kincal_error *err);

/*
 Every frame of one FK evaluation, in the base frame, as N + 2 consecutive 4×4 column-major
 matrices in `frames_out` (`frames_len` = 16·(N + 2) doubles): `T_0^b` (frame 0, before joint
 1), then frames 1..N (`T_0^b·A_1···A_i`), then the tool `T_e^b`. Arguments and statuses as
 `kincal_fk`.

 # Safety
 Non-NULL pointers must be valid for their stated lengths; `err` NULL or writable.
 */
kincal_status kincal_fk_frames(const struct kincal_robot *robot,
                               const double *q,
                               size_t q_len,
                               const struct kincal_joint_aux *aux,
                               double *frames_out,
                               size_t frames_len,
                               struct kincal_error *err);

/*
 The identification Jacobian at `q`: a 6 × P column-major matrix in `jac_out`, column `i` =
 ∂[p; φ]/∂param_i, rows `[Δp (m); Δφ (rad)]` in the base frame (the row order of
 `kincal_pose_error`). P is chosen by `jac_len`:
 `6 * kincal_num_geometric_params(N)` (links, base, tool: the first 5N + 12 parameters) or
 `6 * kincal_num_params(N)` (also every effect column); anything else is BAD_LENGTH with
 `expected` = the full size. Link columns follow eq. (13a–e) of the ARIA paper.

 - `t_base_tool_out`, `t_base_tool_len`: the pose at `q` (16 doubles, column-major), or NULL.

 Every column is written (the caller need not zero the buffer). On failure the contents of
 `jac_out` are unspecified; NON_FINITE_RESULT when a column overflowed (finite parameters
 too large for double precision). Other arguments and statuses as `kincal_fk`.

 # Safety
 Non-NULL pointers must be valid for their stated lengths; `jac_out` must not overlap the
 other arguments; `err` NULL or writable.
 */
kincal_status kincal_jacobian(const struct kincal_robot *robot,
                              const double *q,
                              size_t q_len,
                              const struct kincal_joint_aux *aux,
                              double *jac_out,
                              size_t jac_len,
                              double *t_base_tool_out,
                              size_t t_base_tool_len,
                              struct kincal_error *err);

/*
 Gravity torque about each joint axis [N·m] at readings `q` (`tau_out`, N doubles), from the
 mass model and the nominal geometry: τ_j = z_{j−1}·Σ_{k≥j}(c_k − p_{j−1}) × (m_k·g); a
 positive compliance moves a joint the way gravity pulls. Returns OK, NULL_POINTER,
 MISALIGNED_POINTER, BAD_LENGTH, NON_FINITE or any status of `kincal_robot_validate`.

 # Safety
 Non-NULL pointers must be valid for their stated lengths; `err` NULL or writable.
 */
kincal_status kincal_gravity_torques(const struct kincal_robot *robot,
                                     const double *q,
                                     size_t q_len,
                                     double *tau_out,
                                     size_t tau_len,
                                     struct kincal_error *err);

/*
 The joint angles the geometry sees after the joint effects (compliance, scale, cyclic,
 backlash), `q_j + Δθ_j` without θ0, in `angles_out` (N doubles) [rad]: what a controller
 compensating the calibrated model works with. Arguments and statuses as `kincal_fk`.

 # Safety
 Non-NULL pointers must be valid for their stated lengths; `err` NULL or writable.
 */
kincal_status kincal_joint_angles(const struct kincal_robot *robot,
                                  const double *q,
                                  size_t q_len,
                                  const struct kincal_joint_aux *aux,
                                  double *angles_out,
                                  size_t angles_len,
                                  struct kincal_error *err);

/*
 Checks that every reading of `q` (N doubles [rad]) lies within the joint limits
 (inclusive). Returns OK, OUT_OF_LIMITS (`joint`, `value`, `lower`, `upper`), NULL_POINTER,
 MISALIGNED_POINTER, BAD_LENGTH, NON_FINITE or any status of `kincal_robot_validate`.

 # Safety
 Non-NULL pointers must be valid for their stated lengths; `err` NULL or writable.
 */
kincal_status kincal_robot_check_limits(const struct kincal_robot *robot,
                                        const double *q,
                                        size_t q_len,
                                        struct kincal_error *err);

#if defined(KINCAL_STD)
/*
 Reads the model file at `path` (written by `kincal calibrate`, `diagnose`, …) into
 `robot_out`, with the CLI's validation: schema version, every parameter present once by
 its label, joint count, length parameters, effects, finite plausible numbers.

 - `path`: NUL-terminated file name (any bytes on Unix).
 - `variant`: NULL or `""` for the model the file stores; `"NOM"` for every parameter at
   its nominal value (the model the calibration started from); `"OLS"`, `"OPT1"`, `"OPT2"`
   for the stored model with that algorithm's identified parameters (case-insensitive).
 - `robot_out`: written on success only; need not be initialised.
 - `read_err`: why the file was refused and where (line, column, message), or NULL.
 - `err`: detail on failure, or NULL.

 Returns OK, NULL_POINTER, MISALIGNED_POINTER, BAD_FILE (unreadable or refused: see
 `read_err`) or INVALID_ARGUMENT (a variant the file does not hold, or not UTF-8).
 Available in std builds only (not in the firmware library).

 # Safety
 `path` and non-NULL `variant` are NUL-terminated strings; `robot_out`, `read_err` and
 `err` are NULL or writable.
 */
kincal_status kincal_model_read(const char *path,
                                const char *variant,
                                struct kincal_robot *robot_out,
                                struct kincal_read_error *read_err,
                                struct kincal_error *err);
#endif

#if defined(KINCAL_STD)
/*
 As `kincal_model_read`, from the file's bytes in memory (`bytes`, `bytes_len` bytes of
 UTF-8; no NUL needed). Messages name the source `"buffer"` (e.g. `"buffer:3:7: …"`).

 # Safety
 `bytes` readable for `bytes_len` bytes; the other pointers as in `kincal_model_read`.
 */
kincal_status kincal_model_read_buffer(const char *bytes,
                                       size_t bytes_len,
                                       const char *variant,
                                       struct kincal_robot *robot_out,
                                       struct kincal_read_error *read_err,
                                       struct kincal_error *err);
#endif

/*
 Bytes of caller memory `kincal_observability` and `kincal_pose_singular_values` need for
 `n_params` parameters (the mask's count, or `kincal_num_geometric_params`-sized default
 set's count; the size is that of the smallest capacity, 32 or `KINCAL_MAX_PARAMS`, that
 holds them). Returns 0 for 0 or more than `KINCAL_MAX_PARAMS` parameters.
 */
size_t kincal_observability_workspace_size(size_t n_params);

/*
 Bytes of caller memory `kincal_select_poses` needs for `n_params` parameters and a pool
 of `pool_len` configurations (the core workspace and selection scratch, then one Jacobian
 block and position per candidate: about 1.5 KB per candidate at capacity 32). Returns 0
 for 0 or more than `KINCAL_MAX_PARAMS` parameters or an overflowing size.
 */
size_t kincal_select_workspace_size(size_t n_params,
                                    size_t pool_len);

/*
 Observability indices of `n_poses` configurations of `robot` (normally the nominal
 model): the singular values σ_1 ≥ … ≥ σ_p of the stacked identification Jacobian
 (6 rows `[Δp (m); Δφ (rad)]` per pose, one column per parameter, scaled as `scaling`
 says) and the indices O (eq. 17), O1–O5, A- and D-optimality.

 - `qs`, `qs_len`: joint values [rad], `n_poses` × N row-major (pose l at `qs[l*N]`);
   `qs_len` = `n_poses`·N, `n_poses` ≥ 1.
 - `params`, `params_len`: parameter mask by flat index (`params_len` =
   `kincal_num_params(N)`, non-zero = a column), or NULL for the robot's geometric set
   (θ0, a, α and d-or-β of every link; `params_len` ignored).
 - `scaling`: column scaling, or NULL for unit columns.
 - `workspace`, `workspace_len`: caller memory of at least
   `kincal_observability_workspace_size(p)` bytes aligned to `KINCAL_WORKSPACE_ALIGN`;
   scratch.
 - `indices_out`: the indices. `sv_out`, `sv_len`: the p singular values (descending), or
   NULL if not wanted; `sv_len` = p.

 Returns OK, NULL_POINTER, MISALIGNED_POINTER, BAD_LENGTH (`workspace`: `expected` = bytes
 needed), NON_FINITE, INVALID_ARGUMENT (`scaling`), TOO_FEW_DATA (no pose, empty mask),
 CAPACITY_EXCEEDED, NOT_CONVERGED (SVD), any status of `kincal_robot_validate`. Outputs are
 written on success only.

 # Safety
 Non-NULL pointers must be valid for their stated lengths (`workspace` writable for
 `workspace_len` bytes and not overlapping the other arguments); `err` NULL or writable.
 */
kincal_status kincal_observability(const struct kincal_robot *robot,
                                   const double *qs,
                                   size_t n_poses,
                                   size_t qs_len,
                                   const uint8_t *params,
                                   size_t params_len,
                                   const struct kincal_scaling *scaling,
                                   void *workspace,
                                   size_t workspace_len,
                                   struct kincal_observability_indices *indices_out,
                                   double *sv_out,
                                   size_t sv_len,
                                   struct kincal_error *err);

/*
 The per-pose index: the six singular values (descending) of configuration `q`'s 6 × p
 block of the identification Jacobian, columns scaled as `scaling` says (unit columns use
 this pose's own column norms); what the workspace-clustering design compares.

 - `q`, `q_len`: joint values [rad], `q_len` = N.
 - `params`, `params_len`, `scaling`, `workspace`, `workspace_len`: as
   `kincal_observability`.
 - `sv_out`, `sv_len`: the six singular values; `sv_len` = 6.

 Returns the statuses of `kincal_observability`.

 # Safety
 As `kincal_observability`.
 */
kincal_status kincal_pose_singular_values(const struct kincal_robot *robot,
                                          const double *q,
                                          size_t q_len,
                                          const uint8_t *params,
                                          size_t params_len,
                                          const struct kincal_scaling *scaling,
                                          void *workspace,
                                          size_t workspace_len,
                                          double *sv_out,
                                          size_t sv_len,
                                          struct kincal_error *err);

/*
 Pose selection (eq. 18): the `m` configurations that maximise the index `objective`, from
 the caller's candidate pool (greedy start, DETMAX exchange, then joint-space refinement
 within the joint limits minus `joint_margin_rad` and inside `region`; refined poses need
 not be pool members). Deterministic for a given `seed` (the core's default of 4 starts).

 - `pool_q`, `pool_q_len`: candidate joint values [rad], `pool_len` × N row-major;
   `pool_q_len` = `pool_len`·N; `m` ≤ `pool_len`.
 - `m`: poses to select, 1 ≤ `m` ≤ `KINCAL_MAX_SELECT`.
 - `params`, `params_len`, `scaling`: as `kincal_observability`.
 - `objective`: a `kincal_obs_index`. `seed`: random seed.
 - `region`: the end effector's box [m], or NULL for none. `joint_margin_rad`: distance
   kept from every joint limit [rad] (finite, ≥ 0).
 - `workspace`, `workspace_len`: caller memory of at least
   `kincal_select_workspace_size(p, pool_len)` bytes aligned to `KINCAL_WORKSPACE_ALIGN`;
   scratch.
 - `q_out`, `q_out_len`: the selected configurations, `m` × N row-major; `q_out_len` = m·N.
 - `selection_out`: objective values, counts and the indices of the selected set (NULL if
   not wanted).

 Returns OK, NULL_POINTER, MISALIGNED_POINTER, BAD_LENGTH, NON_FINITE, INVALID_ARGUMENT
 (`objective`, `scaling`, `region`, `joint_margin_rad`), TOO_FEW_DATA (`m` = 0 or above the
 pool), CAPACITY_EXCEEDED (`m` > `KINCAL_MAX_SELECT`), NOT_CONVERGED, any status of
 `kincal_robot_validate`. Outputs are written on success only.

 # Safety
 As `kincal_observability`; `q_out` writable for `q_out_len` doubles.
 */
kincal_status kincal_select_poses(const struct kincal_robot *robot,
                                  const double *pool_q,
                                  size_t pool_len,
                                  size_t pool_q_len,
                                  size_t m,
                                  const uint8_t *params,
                                  size_t params_len,
                                  const struct kincal_scaling *scaling,
                                  uint32_t objective,
                                  uint64_t seed,
                                  const struct kincal_region *region,
                                  double joint_margin_rad,
                                  void *workspace,
                                  size_t workspace_len,
                                  double *q_out,
                                  size_t q_out_len,
                                  struct kincal_selection *selection_out,
                                  struct kincal_error *err);

/*
 Bytes of caller memory `kincal_cluster_select` needs for `n_params` parameters, a pool of
 `pool_len` configurations and the cubes of side `cube_m` [m] of `region` (the selection
 workspace of `kincal_select_workspace_size`, then six values per candidate and 16 bytes
 per cube). Returns 0 for 0 or more than `KINCAL_MAX_PARAMS` parameters, a NULL or invalid
 region, a cube side that is not finite and positive, or an overflowing size.

 # Safety
 `region` NULL or readable.
 */
size_t kincal_cluster_workspace_size(size_t n_params,
                                     size_t pool_len,
                                     const struct kincal_region *region,
                                     double cube_m);

/*
 The workspace-clustering design of the paper (Section 4.2, what `kincal select-poses
 --design clustering` and `design-tool` use): `m` members of the caller's pool whose
 end-effector positions lie in mutually different cubes of side `cube_m` of `region`, and
 whose per-pose indices (`kincal_pose_singular_values`) match a target pose's within
 `tolerance` (`max_k |ln σ_k − ln σ_k*|`); among targets whose design is within the
 tolerance the index `objective` decides, otherwise the smallest spread. Deterministic.

 - `pool_q`, `pool_q_len`: candidate joint values [rad], `pool_len` × N row-major;
   `pool_q_len` = `pool_len`·N. Members outside `region` are never chosen.
 - `m`: poses to choose, 1 ≤ `m` ≤ `KINCAL_MAX_SELECT` and ≤ the occupied cubes.
 - `params`, `params_len`, `scaling`: as `kincal_observability`.
 - `objective`: a `kincal_obs_index`.
 - `region`: the box split into cubes [m] (required). `cube_m`: cube side [m] (> 0).
   `tolerance`: accepted spread (finite, ≥ 0; the CLI's default is 0.1).
 - `workspace`, `workspace_len`: caller memory of at least `kincal_cluster_workspace_size(p,
   pool_len, region, cube_m)` bytes aligned to `KINCAL_WORKSPACE_ALIGN`; scratch.
 - `chosen_out`, `chosen_len`: the zero-based pool indices of the chosen poses; `chosen_len`
   = m.
 - `selection_out`: spread, objective, target, occupied cubes (NULL if not wanted).

 Returns OK, NULL_POINTER, MISALIGNED_POINTER, BAD_LENGTH, NON_FINITE, INVALID_ARGUMENT
 (`objective`, `scaling`, `region`, `cube_m`, `tolerance`), TOO_FEW_DATA (`m` = 0, or more
 than the occupied cubes), CAPACITY_EXCEEDED (`m` > `KINCAL_MAX_SELECT`, too many cubes),
 NOT_CONVERGED, any status of `kincal_robot_validate`. Outputs are written on success only.

 # Safety
 As `kincal_select_poses`; `chosen_out` writable for `chosen_len` elements.
 */
kincal_status kincal_cluster_select(const struct kincal_robot *robot,
                                    const double *pool_q,
                                    size_t pool_len,
                                    size_t pool_q_len,
                                    size_t m,
                                    const uint8_t *params,
                                    size_t params_len,
                                    const struct kincal_scaling *scaling,
                                    uint32_t objective,
                                    const struct kincal_region *region,
                                    double cube_m,
                                    double tolerance,
                                    void *workspace,
                                    size_t workspace_len,
                                    size_t *chosen_out,
                                    size_t chosen_len,
                                    struct kincal_cluster_selection *selection_out,
                                    struct kincal_error *err);

/*
 The value of parameter `index` (flat layout, see `kincal_robot.params`).

 - `value_out`: one double, written on success only; unit by parameter (m, rad,
   rad/(N·m), 1, 1/K).

 Returns OK, NULL_POINTER, MISALIGNED_POINTER, INDEX_OUT_OF_RANGE (`index >=
 kincal_num_params(N)`) or any status of `kincal_robot_validate`.

 # Safety
 `robot` must be NULL or point to a readable `kincal_robot`; `value_out` NULL or writable;
 `err` NULL or writable.
 */
kincal_status kincal_robot_get_param(const struct kincal_robot *robot,
                                     size_t index,
                                     double *value_out,
                                     struct kincal_error *err);

/*
 Sets parameter `index` (flat layout) of the current model to `value` (finite). On failure
 `*robot` is unchanged. Returns OK, NULL_POINTER, MISALIGNED_POINTER, INDEX_OUT_OF_RANGE,
 NON_FINITE or any status of `kincal_robot_validate`.

 # Safety
 `robot` must be NULL or point to a readable and writable `kincal_robot`; `err` NULL or
 writable.
 */
kincal_status kincal_robot_set_param(struct kincal_robot *robot,
                                     size_t index,
                                     double value,
                                     struct kincal_error *err);

/*
 The flat index of the parameter labelled `label` (NUL-terminated, e.g. `"theta0_3"`,
 `"beta_2"`, `"base_px"`, `"tool_rz"`, `"compliance_2"`, `"scale_1"`, `"cyclic_sin1_4"`,
 `"backlash_6"`, `"thermal_kappa"`; link and joint numbers are 1-based).

 Returns OK, NULL_POINTER, MISALIGNED_POINTER, UNKNOWN_LABEL or any status of
 `kincal_robot_validate`.

 # Safety
 `robot` must be NULL or point to a readable `kincal_robot`; `label` NULL or a NUL-terminated
 string; `index_out` NULL or writable; `err` NULL or writable.
 */
kincal_status kincal_robot_param_index(const struct kincal_robot *robot,
                                       const char *label,
                                       size_t *index_out,
                                       struct kincal_error *err);

/*
 The value of the parameter labelled `label` (see `kincal_robot_param_index`). Returns as
 `kincal_robot_get_param`, plus UNKNOWN_LABEL.

 # Safety
 As `kincal_robot_param_index`, with `value_out` NULL or writable.
 */
kincal_status kincal_robot_get_param_by_label(const struct kincal_robot *robot,
                                              const char *label,
                                              double *value_out,
                                              struct kincal_error *err);

/*
 Sets the parameter labelled `label` (see `kincal_robot_param_index`) to `value` (finite).
 On failure `*robot` is unchanged. Returns as `kincal_robot_set_param`, plus UNKNOWN_LABEL.

 # Safety
 `robot` must be NULL or point to a readable and writable `kincal_robot`; `label` NULL or a
 NUL-terminated string; `err` NULL or writable.
 */
kincal_status kincal_robot_set_param_by_label(struct kincal_robot *robot,
                                              const char *label,
                                              double value,
                                              struct kincal_error *err);

/*
 Writes the label of parameter `index` (e.g. `"theta0_3"`) as a NUL-terminated string into
 `label_out`, which holds `label_len` bytes; `KINCAL_LABEL_CAPACITY` bytes always suffice.
 If the buffer is too small, returns BAD_LENGTH with `expected` = the bytes needed (NUL
 included) and writes nothing.

 Returns OK, NULL_POINTER, MISALIGNED_POINTER, INDEX_OUT_OF_RANGE, BAD_LENGTH or any status of
 `kincal_robot_validate`.

 # Safety
 `robot` must be NULL or point to a readable `kincal_robot`; `label_out` NULL or writable for
 `label_len` bytes; `err` NULL or writable.
 */
kincal_status kincal_robot_param_label(const struct kincal_robot *robot,
                                       size_t index,
                                       char *label_out,
                                       size_t label_len,
                                       struct kincal_error *err);

/*
 Copies every parameter (`params_len` = `kincal_num_params(N)` doubles, flat layout) into
 `params_out`. Returns OK, NULL_POINTER, MISALIGNED_POINTER, BAD_LENGTH or any status of
 `kincal_robot_validate`.

 # Safety
 `robot` must be NULL or point to a readable `kincal_robot`; `params_out` NULL or writable for
 `params_len` doubles; `err` NULL or writable.
 */
kincal_status kincal_robot_get_params(const struct kincal_robot *robot,
                                      double *params_out,
                                      size_t params_len,
                                      struct kincal_error *err);

/*
 Sets every parameter from `params` (`params_len` = `kincal_num_params(N)` finite doubles,
 flat layout). On failure `*robot` is unchanged. Returns OK, NULL_POINTER,
 MISALIGNED_POINTER, BAD_LENGTH, NON_FINITE or any status of `kincal_robot_validate`.

 # Safety
 `robot` must be NULL or point to a readable and writable `kincal_robot`; `params` NULL or
 readable for `params_len` doubles; `err` NULL or writable.
 */
kincal_status kincal_robot_set_params(struct kincal_robot *robot,
                                      const double *params,
                                      size_t params_len,
                                      struct kincal_error *err);

/*
 The parameters identified by default, as a mask: `mask_out[i]` = 1 when parameter `i` is
 identified, 0 when it is fixed (`mask_len` = `kincal_num_params(N)` bytes). By default θ0,
 a, α and (d or β, see `kincal_robot.length_param`) of every link are identified, plus every
 parameter of the effects in `effects` (a bit mask: bit k = effect k of `kincal_effect`).

 Returns OK, NULL_POINTER, MISALIGNED_POINTER, BAD_LENGTH, INVALID_ARGUMENT (unknown effect
 bits) or any status of `kincal_robot_validate`.

 # Safety
 `robot` must be NULL or point to a readable `kincal_robot`; `mask_out` NULL or writable for
 `mask_len` bytes; `err` NULL or writable.
 */
kincal_status kincal_robot_param_mask(const struct kincal_robot *robot,
                                      uint32_t effects,
                                      uint8_t *mask_out,
                                      size_t mask_len,
                                      struct kincal_error *err);

/*
 Kinematic error of `measured` relative to `model` (both 4×4 column-major rigid transforms,
 16 doubles each): `error_out` = `[Δp (m); Δφ (rad)]` (6 doubles), measured minus model, both
 in the base frame; `form` is a `kincal_orientation_error`.

 Returns OK, NULL_POINTER, MISALIGNED_POINTER, BAD_LENGTH, NON_FINITE, INVALID_TRANSFORM or
 INVALID_ARGUMENT (`form`). `error_out` is written on success only and may overlap the inputs.

 # Safety
 Non-NULL pointers must be valid for their stated lengths; `err` NULL or writable.
 */
kincal_status kincal_pose_error(const double *measured,
                                size_t measured_len,
                                const double *model,
                                size_t model_len,
                                uint32_t form,
                                double *error_out,
                                size_t error_len,
                                struct kincal_error *err);

/*
 As `kincal_pose_error` with both poses as position + quaternion `[px, py, pz, qw, qx, qy,
 qz]` (7 doubles each; quaternions normalised, a zero quaternion gives INVALID_PARAMETER).

 # Safety
 Non-NULL pointers must be valid for their stated lengths; `err` NULL or writable.
 */
kincal_status kincal_pose_error_pq(const double *measured,
                                   size_t measured_len,
                                   const double *model,
                                   size_t model_len,
                                   uint32_t form,
                                   double *error_out,
                                   size_t error_len,
                                   struct kincal_error *err);

/*
 Converts position + quaternion `pq` (7 doubles `[px, py, pz, qw, qx, qy, qz]`, quaternion
 normalised) to a 4×4 column-major pose `t_out` (16 doubles). Returns OK, NULL_POINTER,
 MISALIGNED_POINTER, BAD_LENGTH, NON_FINITE or INVALID_PARAMETER (zero quaternion).

 # Safety
 Non-NULL pointers must be valid for their stated lengths; `err` NULL or writable.
 */
kincal_status kincal_pose_from_pq(const double *pq,
                                  size_t pq_len,
                                  double *t_out,
                                  size_t t_len,
                                  struct kincal_error *err);

/*
 Converts a 4×4 column-major rigid transform `t` (16 doubles) to position + quaternion
 `pq_out` (7 doubles, qw ≥ 0). Returns OK, NULL_POINTER, MISALIGNED_POINTER, BAD_LENGTH,
 NON_FINITE or INVALID_TRANSFORM.

 # Safety
 Non-NULL pointers must be valid for their stated lengths; `err` NULL or writable.
 */
kincal_status kincal_pose_to_pq(const double *t,
                                size_t t_len,
                                double *pq_out,
                                size_t pq_len,
                                struct kincal_error *err);

/*
 Converts `xyz_rpy` (6 doubles: x, y, z [m], roll, pitch, yaw [rad] with
 R = Rz(yaw)·Ry(pitch)·Rx(roll), the measurement-file convention) to a 4×4 column-major pose
 `t_out` (16 doubles). Returns OK, NULL_POINTER, MISALIGNED_POINTER, BAD_LENGTH or NON_FINITE.

 # Safety
 Non-NULL pointers must be valid for their stated lengths; `err` NULL or writable.
 */
kincal_status kincal_pose_from_xyz_rpy(const double *xyz_rpy,
                                       size_t xyz_rpy_len,
                                       double *t_out,
                                       size_t t_len,
                                       struct kincal_error *err);

/*
 Converts a 4×4 column-major rigid transform `t` (16 doubles) to `xyz_rpy_out` (6 doubles:
 x, y, z [m], roll, pitch, yaw [rad], pitch in [−π/2, π/2]; at gimbal lock roll = 0).
 Returns OK, NULL_POINTER, MISALIGNED_POINTER, BAD_LENGTH, NON_FINITE or INVALID_TRANSFORM.

 # Safety
 Non-NULL pointers must be valid for their stated lengths; `err` NULL or writable.
 */
kincal_status kincal_pose_to_xyz_rpy(const double *t,
                                     size_t t_len,
                                     double *xyz_rpy_out,
                                     size_t xyz_rpy_len,
                                     struct kincal_error *err);

/*
 `sizeof(kincal_prepared)` as the library was built (`KINCAL_PREPARED_SIZE`): compare with
 the header's to detect a header/library mismatch.
 */
size_t kincal_prepared_size(void);

/*
 Validates `robot` once and writes the built model into the caller's handle storage
 `prepared_out` (`KINCAL_PREPARED_SIZE` bytes, aligned to `KINCAL_PREPARED_ALIGN`; need not
 be initialised). The handle then serves `kincal_prepared_fk`, `kincal_prepared_fk_pq`,
 `kincal_prepared_joint_angles` and `kincal_prepared_ik`, which give bit-identical results
 to `kincal_fk`, `kincal_fk_pq`, `kincal_joint_angles` and `kincal_ik` on `robot` without
 converting the parameter table on every call.

 The handle is a snapshot: later edits of `*robot` do not reach it (prepare again). It keeps
 no pointer to `robot` and may be copied with `memcpy`. `*prepared_out` is written on success
 only (a failed call leaves an earlier handle in it intact).

 Returns OK, NULL_POINTER, MISALIGNED_POINTER or any status of `kincal_robot_validate`.

 # Safety
 `robot` must be NULL or point to a readable `kincal_robot`; `prepared_out` NULL or writable
 for `KINCAL_PREPARED_SIZE` bytes; `err` NULL or writable.
 */
kincal_status kincal_prepare(const struct kincal_robot *robot,
                             struct kincal_prepared *prepared_out,
                             struct kincal_error *err);

/*
 Checks a prepared handle in full: OK when `kincal_prepare` filled it (with this library
 build) and every stored number is intact (a checksum over the whole model, about as costly
 as one FK), else BAD_HANDLE; NULL_POINTER or MISALIGNED_POINTER for a bad pointer. The
 other `kincal_prepared_*` calls check only the handle's header and guard words (a few
 nanoseconds), which catch storage `kincal_prepare` never filled but not a corrupted number
 inside a filled one: validate once after preparing or copying a handle, and again
 whenever its memory may have been damaged (e.g. after a memory self-test); then call the
 fast exports in the loop. `n_joints_out`: the joint count, or NULL.

 # Safety
 `prepared` must be NULL or point to `KINCAL_PREPARED_SIZE` readable bytes; `n_joints_out`
 NULL or writable; `err` NULL or writable.
 */
kincal_status kincal_prepared_validate(const struct kincal_prepared *prepared,
                                       size_t *n_joints_out,
                                       struct kincal_error *err);

/*
 `kincal_fk` on a prepared model: the tool pose `T_e^b` (effects compensated) as a 4×4
 column-major matrix in `t_base_tool_out` (16 doubles), bit-identical to `kincal_fk` on the
 prepared robot.

 - `prepared`: a handle filled by `kincal_prepare` (read only).
 - `q`, `q_len`: joint readings [rad], `q_len` = the prepared robot's joint count.
 - `aux`: approach directions / temperature, or NULL (as `kincal_fk`).

 Joint limits are not checked. Returns OK, BAD_HANDLE, NULL_POINTER, MISALIGNED_POINTER,
 BAD_LENGTH, NON_FINITE, INVALID_ARGUMENT (an approach direction not −1/0/+1) or
 MISSING_INPUT.

 # Safety
 `prepared` must be NULL or point to `KINCAL_PREPARED_SIZE` readable bytes; other non-NULL
 pointers must be valid for their stated lengths; `err` NULL or writable.
 */
kincal_status kincal_prepared_fk(const struct kincal_prepared *prepared,
                                 const double *q,
                                 size_t q_len,
                                 const struct kincal_joint_aux *aux,
                                 double *t_base_tool_out,
                                 size_t t_base_tool_len,
                                 struct kincal_error *err);

/*
 As `kincal_prepared_fk`, with the pose as position + quaternion `[px, py, pz, qw, qx, qy,
 qz]` in `pq_out` (7 doubles), bit-identical to `kincal_fk_pq`.

 # Safety
 As `kincal_prepared_fk`.
 */
kincal_status kincal_prepared_fk_pq(const struct kincal_prepared *prepared,
                                    const double *q,
                                    size_t q_len,
                                    const struct kincal_joint_aux *aux,
                                    double *pq_out,
                                    size_t pq_len,
                                    struct kincal_error *err);

/*
 `kincal_joint_angles` on a prepared model: the joint angles after the joint effects
 (compliance, scale, cyclic, backlash), `q_j + Δθ_j` without θ0, in `angles_out` (N doubles)
 [rad]. Arguments and statuses as `kincal_prepared_fk`.

 # Safety
 As `kincal_prepared_fk`.
 */
kincal_status kincal_prepared_joint_angles(const struct kincal_prepared *prepared,
                                           const double *q,
                                           size_t q_len,
                                           const struct kincal_joint_aux *aux,
                                           double *angles_out,
                                           size_t angles_len,
                                           struct kincal_error *err);

/*
 `kincal_ik` on a prepared model: readings `q_out` (N doubles, within the joint limits)
 whose effect-compensated FK reaches `target` (16 doubles, column-major rigid transform),
 bit-identical to `kincal_ik` on the prepared robot. Arguments as `kincal_ik` with
 `prepared` in place of `robot`: `q_seed` (N doubles), `aux` or NULL, `opts` or NULL for the
 defaults, `q_out` (N doubles; may overlap `q_seed`), `info_out` or NULL.

 Returns OK, UNREACHABLE, BAD_HANDLE, NULL_POINTER, MISALIGNED_POINTER, BAD_LENGTH,
 NON_FINITE, INVALID_TRANSFORM, INVALID_ARGUMENT or MISSING_INPUT.

 # Safety
 `prepared` must be NULL or point to `KINCAL_PREPARED_SIZE` readable bytes; other non-NULL
 pointers must be valid for their stated lengths; `err` NULL or writable.
 */
kincal_status kincal_prepared_ik(const struct kincal_prepared *prepared,
                                 const double *target,
                                 size_t target_len,
                                 const double *q_seed,
                                 size_t q_seed_len,
                                 const struct kincal_joint_aux *aux,
                                 const struct kincal_ik_options *opts,
                                 double *q_out,
                                 size_t q_out_len,
                                 struct kincal_ik_info *info_out,
                                 struct kincal_error *err);

/*
 The joint (geometric) Jacobian of a prepared model at `q`, for a controller's resolved-rate
 or operational-space loop: a 6 × N column-major matrix in `jac_out` (6N doubles), column
 `j` = `[v; ω]`, the tool origin's velocity \[m/s\] and the tool's angular velocity
 \[rad/s\], both in the base frame, per unit rate of reading `j` (rad/s; m/s for a prismatic
 joint). Joint effects enter through dθ_j/dq_j (scale, cyclic); compliance's dependence on
 q is neglected (as in the IK). `t_base_tool_out`: the pose at `q` (16 doubles,
 column-major, bit-identical to `kincal_prepared_fk`), or NULL. Other arguments and
 statuses as `kincal_prepared_fk`; NON_FINITE_RESULT when a column overflowed.

 # Safety
 As `kincal_prepared_fk`; `jac_out` must not overlap the other arguments.
 */
kincal_status kincal_prepared_joint_jacobian(const struct kincal_prepared *prepared,
                                             const double *q,
                                             size_t q_len,
                                             const struct kincal_joint_aux *aux,
                                             double *jac_out,
                                             size_t jac_len,
                                             double *t_base_tool_out,
                                             size_t t_base_tool_len,
                                             struct kincal_error *err);

/*
 `kincal_jacobian` on a prepared model: the identification Jacobian (6 × P column-major in
 `jac_out`, P = `kincal_num_geometric_params(N)` or `kincal_num_params(N)` chosen by
 `jac_len`) and optionally the pose, bit-identical to `kincal_jacobian` on the prepared
 robot. Arguments and statuses as `kincal_jacobian` with `prepared` in place of `robot`.

 # Safety
 As `kincal_prepared_fk`; `jac_out` must not overlap the other arguments.
 */
kincal_status kincal_prepared_jacobian(const struct kincal_prepared *prepared,
                                       const double *q,
                                       size_t q_len,
                                       const struct kincal_joint_aux *aux,
                                       double *jac_out,
                                       size_t jac_len,
                                       double *t_base_tool_out,
                                       size_t t_base_tool_len,
                                       struct kincal_error *err);

/*
 Default registration options for noise `sigma_m` [m]: k = 4, up to 2 outliers. Returns OK,
 NULL_POINTER or MISALIGNED_POINTER (`sigma_m` is checked by `kincal_register`).

 # Safety
 `opts_out` must be NULL or writable; `err` NULL or writable.
 */
kincal_status kincal_registration_options_default(double sigma_m,
                                                  struct kincal_registration_options *opts_out,
                                                  struct kincal_error *err);

/*
 Weighted rigid registration of one body's M markers (3 ≤ M ≤ `KINCAL_MAX_MARKERS`) with
 outlier identification (Horn's method; see the core's `registration` docs).

 - `design`, `design_len`: design positions in the body frame, M × 3 doubles [m].
 - `measured`, `measured_len`: measured positions in the motion-capture frame, M × 3 [m];
   entries of markers not visible are ignored (NaN allowed).
 - `visible`, `visible_len`: M bytes (non-zero = seen), or NULL for all seen.
 - `weights`, `weights_len`: M relative weights (finite, > 0), or NULL for all 1.
 - `opts`: from `kincal_registration_options_default`.
 - `registration_out`: written on success only.

 Returns OK, NULL_POINTER, MISALIGNED_POINTER, BAD_LENGTH (lengths not M × 3 / M),
 CAPACITY_EXCEEDED (M or `max_outliers` too large), NON_FINITE, INVALID_PARAMETER (σ, k or a
 weight not positive: `index`), TOO_FEW_DATA (fewer than 3 markers used) or RANK_DEFICIENT
 (collinear design or ambiguous rotation).

 # Safety
 Non-NULL pointers must be valid for their stated lengths; `err` NULL or writable.
 */
kincal_status kincal_register(const double *design,
                              size_t design_len,
                              const double *measured,
                              size_t measured_len,
                              const uint8_t *visible,
                              size_t visible_len,
                              const double *weights,
                              size_t weights_len,
                              const struct kincal_registration_options *opts,
                              struct kincal_registration *registration_out,
                              struct kincal_error *err);

/*
 The end-effector pose in the robot base frame from the two registrations' poses,
 `t_base_ee = t_mocap_base⁻¹ · t_mocap_ee` (all 4×4 column-major rigid transforms, 16
 doubles each). Returns OK, NULL_POINTER, MISALIGNED_POINTER, BAD_LENGTH, NON_FINITE or
 INVALID_TRANSFORM.

 # Safety
 Non-NULL pointers must be valid for their stated lengths; `err` NULL or writable.
 */
kincal_status kincal_t_base_ee(const double *t_mocap_base,
                               size_t t_mocap_base_len,
                               const double *t_mocap_ee,
                               size_t t_mocap_ee_len,
                               double *t_base_ee_out,
                               size_t t_base_ee_len,
                               struct kincal_error *err);

/*
 Number of parameters (`kincal_robot.params` entries used) of an `n_joints` model: 12N + 13.
 Returns 0 when `n_joints` is not in 1..=`KINCAL_MAX_JOINTS`.
 */
size_t kincal_num_params(size_t n_joints);

/*
 Number of geometric parameters (links, base, tool; `kincal_robot.nominal` entries used) of
 an `n_joints` model: 5N + 12. Returns 0 when `n_joints` is not in 1..=`KINCAL_MAX_JOINTS`.
 */
size_t kincal_num_geometric_params(size_t n_joints);

/*
 `sizeof(kincal_robot)` as the library was built: compare with the header's to detect a
 header/library mismatch.
 */
size_t kincal_robot_size(void);

/*
 Builds a robot from a parameter table: `n_joints` links with identity base and tool, no
 masses, no effects, and the d/β choice made from axis parallelism (β for links whose axis is
 parallel to the next one within 1°, d otherwise). This geometry is also the nominal one.

 - `robot_out`: written on success only; need not be initialised.
 - `n_joints`: 1..=`KINCAL_MAX_JOINTS`, else `KINCAL_STATUS_BAD_JOINT_COUNT`.
 - `links`, `links_len`: row-major table of `5 * n_joints` doubles, one row per link
   `[θ0 rad, d m, a m, α rad, β rad]`.
 - `limits`, `limits_len`: `2 * n_joints` doubles, `[lower, upper]` per joint [rad].
 - `err`: detail on failure, or NULL.

 Returns OK, NULL_POINTER, MISALIGNED_POINTER, BAD_JOINT_COUNT, BAD_LENGTH, NON_FINITE or
 INVALID_LIMITS.

 # Safety
 Non-NULL pointers must be valid for their stated lengths.
 */
kincal_status kincal_robot_init(struct kincal_robot *robot_out,
                                size_t n_joints,
                                const double *links,
                                size_t links_len,
                                const double *limits,
                                size_t limits_len,
                                struct kincal_error *err);

/*
 Checks a robot the caller filled or edited directly: returns the status any call would
 return for it (OK when every used field is valid).

 Returns OK, NULL_POINTER, MISALIGNED_POINTER, BAD_JOINT_COUNT, NON_FINITE, INVALID_LIMITS,
 INVALID_PARAMETER or INVALID_ARGUMENT (a `length_param` entry not 0/1).

 # Safety
 `robot` must be NULL or point to a readable `kincal_robot`; `err` NULL or writable.
 */
kincal_status kincal_robot_validate(const struct kincal_robot *robot,
                                    struct kincal_error *err);

/*
 Sets the base frame `T_0^b` = Trans(p)·Rot(r) as `[px, py, pz, rx, ry, rz]` (metres and a
 rotation vector in radians), both current and nominal (use `kincal_robot_set_param` with
 `base_*` labels to change only the current one). `base_len` must be 6.

 On failure `*robot` is unchanged. Returns OK, NULL_POINTER, MISALIGNED_POINTER, BAD_LENGTH,
 NON_FINITE or any status of `kincal_robot_validate`.

 # Safety
 `robot` must be NULL or point to a readable and writable `kincal_robot`; `base` NULL or
 readable for `base_len` doubles; `err` NULL or writable.
 */
kincal_status kincal_robot_set_base(struct kincal_robot *robot,
                                    const double *base,
                                    size_t base_len,
                                    struct kincal_error *err);

/*
 Sets the tool frame `T_e^N` = Trans(p)·Rot(r) relative to the last link frame as
 `[px, py, pz, rx, ry, rz]` (metres, rotation vector in radians), both current and nominal.
 `tool_len` must be 6. On failure `*robot` is unchanged; statuses as
 `kincal_robot_set_base`.

 # Safety
 As `kincal_robot_set_base`.
 */
kincal_status kincal_robot_set_tool(struct kincal_robot *robot,
                                    const double *tool,
                                    size_t tool_len,
                                    struct kincal_error *err);

/*
 Sets the joint limits: `limits_len` = 2N doubles `[lower, upper]` per joint [rad],
 inclusive. On failure `*robot` is unchanged. Returns OK, NULL_POINTER, MISALIGNED_POINTER,
 BAD_LENGTH, NON_FINITE, INVALID_LIMITS or any status of `kincal_robot_validate`.

 # Safety
 `robot` must be NULL or point to a readable and writable `kincal_robot`; `limits` NULL or
 readable for `limits_len` doubles; `err` NULL or writable.
 */
kincal_status kincal_robot_set_limits(struct kincal_robot *robot,
                                      const double *limits,
                                      size_t limits_len,
                                      struct kincal_error *err);

/*
 Sets the point-mass model: `link_masses_kg` (N values [kg], at the midpoint between the
 origins of frames k−1 and k), `tool_mass_kg` [kg] at the end-effector origin, `gravity`
 (3 values [m/s²] in the base frame, e.g. {0, 0, -9.81}). Masses must be ≥ 0. On failure
 `*robot` is unchanged. Returns OK, NULL_POINTER, MISALIGNED_POINTER, BAD_LENGTH, NON_FINITE,
 INVALID_PARAMETER (a negative mass; `index` = link, N = tool) or any status of
 `kincal_robot_validate`.

 # Safety
 `robot` must be NULL or point to a readable and writable `kincal_robot`; arrays NULL or
 readable for their lengths; `err` NULL or writable.
 */
kincal_status kincal_robot_set_mass(struct kincal_robot *robot,
                                    const double *link_masses_kg,
                                    size_t link_masses_kg_len,
                                    double tool_mass_kg,
                                    const double *gravity,
                                    size_t gravity_len,
                                    struct kincal_error *err);

/*
 Sets which of d/β link `link` (zero-based, < N) identifies: `choice` is
 `KINCAL_LENGTH_PARAM_D` or `KINCAL_LENGTH_PARAM_BETA`. On failure `*robot` is unchanged.
 Returns OK, NULL_POINTER, MISALIGNED_POINTER, INDEX_OUT_OF_RANGE (`link`), INVALID_ARGUMENT
 (`choice`) or any status of `kincal_robot_validate`.

 # Safety
 `robot` must be NULL or point to a readable and writable `kincal_robot`; `err` NULL or
 writable.
 */
kincal_status kincal_robot_set_length_param(struct kincal_robot *robot,
                                            size_t link,
                                            uint32_t choice,
                                            struct kincal_error *err);

/*
 Sets what joint `joint` (zero-based, < N) moves: `kind` is `KINCAL_JOINT_KIND_REVOLUTE`,
 `KINCAL_JOINT_KIND_PRISMATIC` (reading and limits then in metres) or
 `KINCAL_JOINT_KIND_SENSOR` (a passive revolute joint read by a tilt sensor). The same
 check as the core's: a prismatic or sensor joint's cyclic (and a sensor's backlash)
 effect parameters must be zero. On failure
 `*robot` is unchanged. Returns OK, NULL_POINTER, MISALIGNED_POINTER, INDEX_OUT_OF_RANGE
 (`joint`), INVALID_ARGUMENT (`kind`, or nonzero cyclic parameters) or any status of
 `kincal_robot_validate`.

 # Safety
 `robot` must be NULL or point to a readable and writable `kincal_robot`; `err` NULL or
 writable.
 */
kincal_status kincal_robot_set_joint_kind(struct kincal_robot *robot,
                                          size_t joint,
                                          uint32_t kind,
                                          struct kincal_error *err);

/*
 Makes the current geometry (links, base, tool of `params`) the nominal one, e.g. to use a
 calibrated model as the description of a new calibration. On failure `*robot` is unchanged;
 statuses as `kincal_robot_validate`.

 # Safety
 `robot` must be NULL or point to a readable and writable `kincal_robot`; `err` NULL or
 writable.
 */
kincal_status kincal_robot_adopt_geometry_as_nominal(struct kincal_robot *robot,
                                                     struct kincal_error *err);

/*
 Static text of a status code: `"KINCAL_STATUS_<NAME>: <explanation>"`, or
 `"unknown kincal status code"` for a number that is not a status.

 Takes a `uint32_t` rather than the enum because C may pass any integer. The returned string
 is static and NUL-terminated: never free or modify it. Never returns NULL.
 */
const char *kincal_status_str(uint32_t status);

/*
 Version of the library (`"MAJOR.MINOR.PATCH"`, from the crate version): a static
 NUL-terminated string; never free it. Compare it with the version your build expects.
 */
const char *kincal_version(void);

/*
 Formats `error` as one line of text into the caller's buffer, like `snprintf`: writes at most
 `buf_len` bytes including the terminating NUL and returns the length of the whole message
 (excluding the NUL), so a return value `>= buf_len` means the text was truncated. 512 bytes
 always suffice. The no_std (firmware) build leaves the floating-point fields out of the text.

 `error` NULL: returns 0 and writes nothing. `buf` may be NULL only when `buf_len` is 0 (to
 ask for the length). Nothing is allocated.

 # Safety
 `error` must be NULL or point to a `kincal_error` filled by this library (or reset by the
 caller with `argument` NULL); `buf` must be writable for `buf_len` bytes.
 */
size_t kincal_error_describe(const struct kincal_error *error,
                             char *buf,
                             size_t buf_len);

/*
 Validates `robot` on measurements with full poses (every mask 0x3f): the error of each
 pose, measured minus model in the base frame with the exact rotation-vector orientation
 error, and their summary judged against `target_pos_m` [m] and `target_rot_rad` [rad]
 (the paper's: `KINCAL_TARGET_POS_M`, `KINCAL_TARGET_ROT_RAD`).

 - `errors_out`, `errors_len`: `KINCAL_POSE_ERRORS_LEN`·L doubles (see there), or NULL.
 - `summary_out`: required.

 Returns OK, NULL_POINTER, MISALIGNED_POINTER, BAD_LENGTH, NON_FINITE, INVALID_TRANSFORM,
 INVALID_ARGUMENT (`pose` set for a partial mask or bad approach direction; a target not
 positive), MISSING_INPUT, TOO_FEW_DATA, NON_FINITE_RESULT (an error or the summary
 overflowed: `argument` names which, `pose` the pose) or any status of
 `kincal_robot_validate`. `summary_out` is written on success only, `errors_out` row by row
 (on failure it may hold the rows before the failing pose); it must not overlap the inputs.

 # Safety
 Non-NULL pointers must be valid for their stated lengths; `err` NULL or writable.
 */
kincal_status kincal_validate(const struct kincal_robot *robot,
                              const struct kincal_measurements *data,
                              double target_pos_m,
                              double target_rot_rad,
                              double *errors_out,
                              size_t errors_len,
                              struct kincal_validation_summary *summary_out,
                              struct kincal_error *err);

/*
 Eq. (3): the largest orientation error [rad] that keeps the needle tip inside a tumour of
 radius `r_t_m` [m] when the puncture point is off by `d_m` [m] and the insertion is at most
 `l_max_m` [m] long, `2·asin((r_t − d)/(2·√2·l_max))`, written to `rotation_out` (0.66° for
 5 mm, √3 mm, 0.2 m). Returns OK, NULL_POINTER, MISALIGNED_POINTER, NON_FINITE or
 INVALID_PARAMETER (`index` 0: r_t ≤ 0; 1: d outside [0, r_t); 2: l_max ≤ 0).

 # Safety
 `rotation_out` must be NULL or writable; `err` NULL or writable.
 */
kincal_status kincal_biopsy_allowed_rotation(double r_t_m,
                                             double d_m,
                                             double l_max_m,
                                             double *rotation_out,
                                             struct kincal_error *err);

/*
 The point where the `axis` directions of `n_poses` poses (lines through each frame
 origin) converge, least squares: `min_c Σ |(I − dᵢ·dᵢᵀ)(c − pᵢ)|²` with `pᵢ` the origin
 and `dᵢ` the unit `axis` of pose i; with the distances along the axes and how closely
 the axes pass the point (a set whose camera did not look at one place shows a large
 miss). Nothing is allocated: the poses are read twice.

 - `poses`, `poses_len`: `n_poses` 4×4 column-major rigid transforms one after the other
   (pose l at `poses[16*l]`), all in one frame; `poses_len` = 16·`n_poses`.
 - `n_poses`: at least 2.
 - `axis`: a `kincal_axis`, the viewing direction in each frame.
 - `view_point_out`: written on success only.

 Returns OK, NULL_POINTER, MISALIGNED_POINTER, BAD_LENGTH, TOO_FEW_DATA (fewer than 2
 poses), NON_FINITE or INVALID_TRANSFORM (`pose`, and `index` within `poses` for a
 non-finite value), INVALID_ARGUMENT (`axis`) or RANK_DEFICIENT (axes parallel within
 1e-9 of the eigenvalue ratio of `Σ (I − d·dᵀ)`: no point is determined; `found` = rank).

 # Safety
 Non-NULL pointers must be valid for their stated lengths; `err` NULL or writable.
 */
kincal_status kincal_view_point(const double *poses,
                                size_t poses_len,
                                size_t n_poses,
                                uint32_t axis,
                                struct kincal_view_point_result *view_point_out,
                                struct kincal_error *err);

/*
 `t·Trans(point)`: the same rigid body's frame moved (not rotated) to `point`, given in
 that frame [m]; the pose a measurement row with measured point `point` carries. With
 `point` = `(0, 0, s)` and `s` = `kincal_view_point_result.mean_distance_m`, a camera pose moved to
 the point it looks at.

 - `t`, `t_len`: a 4×4 column-major rigid transform, 16 doubles.
 - `point`, `point_len`: 3 doubles [m].
 - `t_out`, `t_out_len`: the moved pose, 16 doubles; written on success only, may overlap
   the inputs.

 Returns OK, NULL_POINTER, MISALIGNED_POINTER, BAD_LENGTH, NON_FINITE or
 INVALID_TRANSFORM.

 # Safety
 Non-NULL pointers must be valid for their stated lengths; `err` NULL or writable.
 */
kincal_status kincal_moved_to_point(const double *t,
                                    size_t t_len,
                                    const double *point,
                                    size_t point_len,
                                    double *t_out,
                                    size_t t_out_len,
                                    struct kincal_error *err);

/*
 Bytes of caller memory `kincal_identify_constraints` needs: `n_rows` rows of an
 `n_joints` robot with `n_targets + n_planes` groups, `n_distances` distances,
 `n_sessions` sessions (0 without a session array) and `n_requested` requested parameters
 (the identification workspace of capacity 32 or `KINCAL_MAX_PARAMS`, about 92 KB or
 1.45 MB, plus about 0.5 KB per row). Returns 0 for an invalid joint count, more than
 `KINCAL_MAX_PARAMS` parameters, or an overflowing size.
 */
size_t kincal_identify_constraints_workspace_size(size_t n_joints,
                                                  size_t n_rows,
                                                  size_t n_targets,
                                                  size_t n_planes,
                                                  size_t n_distances,
                                                  size_t n_sessions,
                                                  size_t n_requested);

/*
 Instrument-free calibration: identifies the identifiable subset of `opts->requested` from
 contacts held at targets or on planes, known distances, known targets and planes, and
 optional (partial) instrument coordinates, starting from `robot`; the 3 coordinates of
 every unknown target or plane are eliminated, never fitted (`docs/constraints.md`).

 - `robot`: initial model (read only). `robot_out` may point to the same struct.
 - `data`: the rows (see `kincal_constraint_data`).
 - `opts`: from `kincal_identify_options_default` (OLS, OPT1 or OPT2, the parameters to
   fit; `weight_pos` weighs contact and distance rows too).
 - `workspace`, `workspace_len`: caller memory of at least
   `kincal_identify_constraints_workspace_size(...)` bytes, aligned to
   `KINCAL_WORKSPACE_ALIGN`; scratch.
 - `report_out` (NULL if not wanted): identification report, gauge, references.
 - `targets_out` (`n_targets` entries), `planes_out` (`n_planes`), `distances_out`
   (`n_distances` predicted distances [m]): each NULL if not wanted; the estimates at the
   identified model (the consistency of the data with it). They are filled last, after
   the model and the report are known; only a failure while computing them (none is
   expected once the fit succeeded) can leave them partly written.

 Every refusal of a row sets `kincal_error.pose` to the zero-based row (`KINCAL_NO_INDEX`
 when no row names the group): INVALID_ARGUMENT (`data->coord_mask`: a row that measures
 nothing, coordinates and a target or plane on one row, bits beyond 0x7; `data->plane`: a
 target and a plane on one row; `data->session`: a target, plane or the instrument rows in
 two sessions), INDEX_OUT_OF_RANGE (a target, plane or session id beyond its count), BAD_GROUP
 (a target or plane with too few rows: `argument` `data->target` or `data->plane`, `index` =
 its id, `expected`/`found` = rows needed/given; or a zero known normal), DEGENERATE_GROUP
 (collinear plane contacts at the starting model, `value` = their aspect, below
 `KINCAL_PLANE_MIN_ASPECT`), TOO_FEW_DATA (a session with fewer than
 `KINCAL_MIN_SESSION_ROWS` rows, `index` = session), BAD_DISTANCE (`index` = the distance;
 an unknown target: `found` = its id, `expected` = `n_targets`; equal ends, a length
 ≤ 0, a bad weight), NON_FINITE (`pose` = row); plus the argument and numerical statuses of
 `kincal_identify`. Outputs are written on success only.

 # Safety
 Non-NULL pointers must be valid for their stated lengths (`workspace` writable for
 `workspace_len` bytes and not overlapping the other arguments); `err` NULL or writable.
 */
kincal_status kincal_identify_constraints(const struct kincal_robot *robot,
                                          const struct kincal_constraint_data *data,
                                          const struct kincal_identify_options *opts,
                                          void *workspace,
                                          size_t workspace_len,
                                          struct kincal_robot *robot_out,
                                          struct kincal_constraints_report *report_out,
                                          struct kincal_group_estimate *targets_out,
                                          size_t targets_out_len,
                                          struct kincal_group_estimate *planes_out,
                                          size_t planes_out_len,
                                          double *distances_out,
                                          size_t distances_out_len,
                                          struct kincal_error *err);

/*
 Default diagnosis options (those of `kincal diagnose`): noise from repeats, 5 folds, all
 candidates whose inputs the rows carry, pairs, z thresholds 3/3/3, explained at 80 %,
 partial at 25 %, outlier screening on. Returns OK or NULL_POINTER / MISALIGNED_POINTER.

 # Safety
 `opts_out` NULL or writable; `err` NULL or writable.
 */
kincal_status kincal_diagnose_options_default(struct kincal_diagnose_options *opts_out,
                                              struct kincal_error *err);

/*
 Bytes of caller memory `kincal_diagnose` needs for `n_poses` measurements of an
 `n_joints` robot (the diagnosis workspace, about 2.54 MB, plus about 2.1 KB per pose and the
 result). Returns 0 for an invalid joint count or an overflowing size.
 */
size_t kincal_diagnose_workspace_size(size_t n_joints,
                                      size_t n_poses);

/*
 The public name of code `code` of the diagnosis enum `kind` (a
 `kincal_diagnosis_name_kind`): the string REPORT.json shows, e.g. `"partially_explained"`
 for (STATUS, `KINCAL_DIAGNOSIS_STATUS_PARTIALLY_EXPLAINED`) or `"repeats_drift"` for
 (WARNING, `KINCAL_DIAGNOSIS_WARNING_CODE_REPEATS_DRIFT`); `""` for
 `KINCAL_DIAGNOSIS_PART_NONE`. The text is the Rust library's own, so C callers need no
 table of their own. A static NUL-terminated string (never free it), or NULL for an unknown
 kind or code.
 */
const char *kincal_diagnosis_name(uint32_t kind,
                                  uint32_t code);

/*
 The sim-to-real gap diagnosis (`kincal diagnose`, spec/effects.md) of instrument
 measurements against the robot description `robot` (nominal geometry, mass model,
 limits; effect parameters zero): the geometric calibration, every candidate effect and
 pair cross-validated over pose groups (or the in-sample nested test with too few
 groups), the verdict, and the library-free smooth check.

 - `data`: the measurements (`weights` NULL or all 1: the diagnosis holds out by itself).
 - `groups`, `groups_len`: group id of every pose (`pose_id`: repeats of one pose share
   it; `groups_len` = `n_poses`), or NULL: every pose its own group.
 - `opts`: from `kincal_diagnose_options_default`; NaN σ: estimate from repeats.
 - `workspace`: at least `kincal_diagnose_workspace_size(N, n_poses)` bytes aligned to
   `KINCAL_WORKSPACE_ALIGN`; scratch.
 - `model_out`: the verdict's model (geometry + effects) fitted on all rows;
   `geometric_out` (NULL if not wanted): the geometric calibration; `report_out`: the
   report; `poses_out` (NULL or `n_poses` entries): per-pose residuals.

 Returns OK; the argument statuses of `kincal_identify`; MISSING_INPUT (no stated σ and
 no repeats, or a candidate's input missing), TOO_FEW_DATA (fewer groups than folds),
 INVALID_PARAMETER with `pose` set (a weight other than 1), INVALID_ARGUMENT (an option),
 CAPACITY_EXCEEDED, and the numerical statuses of the fits. Outputs are written on
 success only.

 # Safety
 Non-NULL pointers must be valid for their stated lengths (`workspace` writable for
 `workspace_len` bytes and not overlapping the other arguments); `err` NULL or writable.
 */
kincal_status kincal_diagnose(const struct kincal_robot *robot,
                              const struct kincal_measurements *data,
                              const uint32_t *groups,
                              size_t groups_len,
                              const struct kincal_diagnose_options *opts,
                              void *workspace,
                              size_t workspace_len,
                              struct kincal_robot *model_out,
                              struct kincal_robot *geometric_out,
                              struct kincal_diagnosis_report *report_out,
                              struct kincal_pose_diagnosis *poses_out,
                              size_t poses_out_len,
                              struct kincal_error *err);

#if defined(KINCAL_STD)
/*
 Reads and checks the measurement CSV at `path` (spec/measurements.md) with the CLI's
 reader and writes its sizes to `sizes_out`, for the buffers of `kincal_measurements_read`.

 - `path`: NUL-terminated file name (any bytes on Unix).
 - `robot`: the robot the data are for (its joint count: exactly q1..qN; its limits,
   inclusive), or NULL to take the joint count from the header (the highest `qK`) and
   check no limits.
 - `flags`: `KINCAL_READ_ALLOW_OUT_OF_LIMITS`, `KINCAL_READ_REQUIRE_POSE`, or 0.
 - `sizes_out`: written on success.
 - `read_err`: why the file was refused and where (line; column = the cell number), or
   NULL.

 Returns OK, NULL_POINTER, MISALIGNED_POINTER, INVALID_ARGUMENT (`flags`), BAD_FILE
 (unreadable or refused: see `read_err`), any status of `kincal_robot_validate`.
 Available in std builds only.

 # Safety
 `path` NUL-terminated; `robot` NULL or readable; `sizes_out`, `read_err`, `err` NULL or
 writable.
 */
kincal_status kincal_measurements_read_sizes(const char *path,
                                             const struct kincal_robot *robot,
                                             uint32_t flags,
                                             struct kincal_measurement_sizes *sizes_out,
                                             struct kincal_read_error *read_err,
                                             struct kincal_error *err);
#endif

#if defined(KINCAL_STD)
/*
 Reads the measurement CSV at `path` into the caller's buffers, whose lengths
 `kincal_measurements_read_sizes` gave for the same `path`, `robot` and `flags`.

 - `buffers`: where to write (each pointer NULL or of exactly its stated length).
 - the other arguments as `kincal_measurements_read_sizes`.

 Returns the statuses of `kincal_measurements_read_sizes`, and BAD_LENGTH when a buffer's
 length does not fit the file (`argument` names it). Outputs are written on success only.

 # Safety
 As `kincal_measurements_read_sizes`; `buffers` readable, each of its non-NULL pointers
 writable for its length.
 */
kincal_status kincal_measurements_read(const char *path,
                                       const struct kincal_robot *robot,
                                       uint32_t flags,
                                       const struct kincal_measurement_buffers *buffers,
                                       struct kincal_read_error *read_err,
                                       struct kincal_error *err);
#endif

#if defined(KINCAL_STD)
/*
 As `kincal_measurements_read_sizes`, from the file's bytes in memory (`bytes`,
 `bytes_len` bytes; no NUL needed). Messages name the source `"buffer"`.

 # Safety
 `bytes` readable for `bytes_len` bytes; the other pointers as in
 `kincal_measurements_read_sizes`.
 */
kincal_status kincal_measurements_read_buffer_sizes(const char *bytes,
                                                    size_t bytes_len,
                                                    const struct kincal_robot *robot,
                                                    uint32_t flags,
                                                    struct kincal_measurement_sizes *sizes_out,
                                                    struct kincal_read_error *read_err,
                                                    struct kincal_error *err);
#endif

#if defined(KINCAL_STD)
/*
 As `kincal_measurements_read`, from the file's bytes in memory (see
 `kincal_measurements_read_buffer_sizes`).

 # Safety
 As `kincal_measurements_read_buffer_sizes` and `kincal_measurements_read`.
 */
kincal_status kincal_measurements_read_buffer(const char *bytes,
                                              size_t bytes_len,
                                              const struct kincal_robot *robot,
                                              uint32_t flags,
                                              const struct kincal_measurement_buffers *buffers,
                                              struct kincal_read_error *read_err,
                                              struct kincal_error *err);
#endif

#ifdef __cplusplus
}  // extern "C"
#endif  // __cplusplus

#endif  /* KINCAL_H */
