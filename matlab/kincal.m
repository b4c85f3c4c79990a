function kincal()
%KINCAL  kincal toolbox for Matlab and GNU Octave: kinematic calibration of robot arms.
%   The same Rust library as the kincal CLI and C ABI, through one MEX gateway
%   (private/kincal_mex.c). Build it once with MAKE_KINCAL; every function checks its
%   arguments and raises identifiers kincal:<reason> (see "Errors" below).
%
%   Models (plain structs: the whole model is the argument, nothing is kept in the MEX file)
%     kincal_robot            built-in ARIA models ('aria', 'aria_true', 'aria_real'), a
%                             robot from a parameter table or from its joint axes
%     kincal_param            read or set a parameter by label ('theta0_4', 'beta_2', ...)
%     kincal_param_mask       parameters identified by default (with effects)
%     kincal_effects          names of the non-geometric effects; active effects of a robot
%     kincal_load_model       a model file written by the CLI (kincal calibrate)
%   Kinematics
%     kincal_fk               tool poses T_e^b (4 x 4 x M) of joint readings (N x M)
%     kincal_frames           every frame of one FK evaluation
%     kincal_jacobian         identification Jacobian [dp; dphi] by the parameters
%     kincal_ik               inverse kinematics (nearest solution to a seed)
%     kincal_joint_angles     joint angles after the joint effects
%     kincal_gravity_torques  gravity torques of the point-mass model
%     kincal_check_limits     joint readings against the limits
%   Poses
%     kincal_pose_error       [dp; dphi] of measured vs model poses (exact or eq. 16)
%     kincal_pose_from_xyzrpy, kincal_pose_to_xyzrpy   R = Rz(yaw) Ry(pitch) Rx(roll)
%     kincal_pose_from_pq, kincal_pose_to_pq           position + quaternion [w x y z]
%     kincal_aria_tool        the Table 2 calibration-tool poses and an IK seed
%     kincal_view_point       where camera poses look (their viewing axes converge); the
%                             poses moved to that point (kincal observed-point)
%   Calibration
%     kincal_identify         OLS / OPT1 / OPT2 identification with report
%     kincal_identifiability  rank, conditioning, redundant and undetermined parameters
%     kincal_observability    observability indices O, O1..O5, A- and D-optimality of a
%                             set of configurations (Section 3.3)
%     kincal_select_poses     calibration poses that maximise an observability index
%                             (greedy start, DETMAX exchange, joint-space refinement)
%     kincal_cluster_select   the paper's workspace-clustering design (Section 4.2): poses
%                             in different cubes with equal per-pose observability
%     kincal_validate         per-pose errors and summary against the 1 mm / 0.66 deg targets
%     kincal_biopsy_rotation  eq. (3): the orientation error a biopsy allows
%     kincal_identify_constraints  calibration without an instrument: contacts held at
%                             targets or on planes, known distances, sessions, partial
%                             coordinates; the gauge named
%     kincal_diagnose         the sim-to-real gap diagnosis (REPORT.json fields as a struct)
%   Measurement set-up (Section 5.1)
%     kincal_register         pose of a marker body from motion-capture data, outliers named
%     kincal_t_base_ee        end-effector pose in the base frame from two registrations
%   Data and results
%     kincal_read_measurements, kincal_write_measurements   the measurement CSV (read by
%                             the CLI's reader through the C ABI)
%     kincal_print_params     parameter table of several models side by side
%     kincal_plot_errors      the paper's 4x4 error figures (PNG/SVG, headless)
%   Workflows (matlab/workflows, Section 4.1.4 of the paper)
%     workflow_a_virtual      calibration on virtual data (Table 3 truth)
%     workflow_b_tool_design  calibration-tool design: Table 2, optimal, clustering
%     workflow_c_real_data    calibration from a measurement CSV
%   Build and test
%     make_kincal             make_kincal / make_kincal('clean') / make_kincal('test')
%     kincal_version          library version and the gateway's operations
%
%   Units: metres and radians (CSV columns may say _mm, _deg). Joint, link and pose
%   numbers in messages and labels are 1-based.
%
%   Errors: kincal:badClass, kincal:badSize, kincal:nonFinite, kincal:badValue,
%   kincal:missingField, kincal:unknownField, kincal:unknownOption, kincal:badArgCount,
%   kincal:csv (measurement files), and for every status of the C ABI kincal:<name>,
%   e.g. kincal:outOfLimits, kincal:unreachable, kincal:rankDeficient,
%   kincal:notConverged, kincal:invalidTransform, kincal:unknownLabel.
help('kincal');
end
