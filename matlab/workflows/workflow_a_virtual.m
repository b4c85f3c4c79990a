%WORKFLOW_A_VIRTUAL  Toolbox workflow (a): calibration on virtual data (paper, Section 4.4).
%   The virtual "true" robot of Table 3 holds the ten calibration-tool poses of Table 2 (its
%   joint readings come from inverse kinematics on the truth), and the three algorithms
%   identify the model from the Table 1 nominal geometry:
%     1. the data, written to and read back from a measurement CSV;
%     2. the identifiability analysis of the tool poses (rank, condition number);
%     3. OLS, OPT1 (intervals +-5 mm, +-60 deg: the truth's theta0_4 = -0.8 rad lies outside
%        the paper's +-5 deg) and OPT2;
%     4. the parameter table NOM / OLS / OPT1 / OPT2 / TRUE (compare with Table 3);
%     5. validation on a grid of poses in the biopsy region above the tool plate, measured
%        on the truth, against the paper's targets (1 mm, 0.66 deg per pose);
%     6. the 4x4 error figures (position in mm, orientation in degrees; columns NOM, OLS,
%        OPT1, OPT2) at the calibration poses and at the validation poses, as PNG.
%   The data are noise-free, so OLS and OPT2 recover the truth to rounding (errors ~1e-9 mm).
%
%   Run:  cd matlab/workflows; workflow_a_virtual   (or run('.../workflow_a_virtual.m'))
%   Outputs: $KINCAL_OUT/a_virtual, default matlab/out/a_virtual.
%
%   See also WORKFLOW_B_TOOL_DESIGN, WORKFLOW_C_REAL_DATA, KINCAL_IDENTIFY.

out = setup_toolbox('a_virtual');
nominal = kincal_robot('aria');
truth = kincal_robot('aria_true');
names = {'NOM', 'OLS', 'OPT1', 'OPT2'};

% 1. Calibration data: the true robot holds the Table 2 tool poses.
[T_tool, seed] = kincal_aria_tool();
q_cal = kincal_ik(truth, T_tool, seed);
csv = fullfile(out, 'calibration.csv');
kincal_write_measurements(csv, q_cal, kincal_fk(truth, q_cal), 'pose_id', 1:size(q_cal, 2), ...
    'comments', {'robot: aria (virtual truth, Table 3)', 'poses: Table 2 calibration tool', ...
    'noise: none'});
cal = kincal_read_measurements(csv, 'robot', nominal);
fprintf('\n(a) calibration on virtual data: %d tool poses from %s\n', cal.n_poses, csv);

% 2. What the tool poses determine.
a = kincal_identifiability(nominal, cal);
fprintf('identifiability: rank %d of %d requested, condition number %.4g\n', a.rank, ...
    nnz(a.requested), a.condition_number);

% 3. The three algorithms.
[lower, upper] = opt1_intervals(nominal, 5e-3, 60 * pi / 180);
[models, reports] = calibrate_three(nominal, cal, lower, upper);

% 4. Parameter table (lengths in mm, angles in degrees).
fprintf('\n');
kincal_print_params([models, {truth}], [names, {'TRUE'}], 'title', ...
    'Identified parameters (compare with Table 3 of the paper)');

% 5. Validation in the biopsy region above the tool plate, measured on the truth.
targets = region_poses(linspace(0.166, 0.466, 3), linspace(0.204, 0.504, 3), ...
    [0.235, 0.335], [-150, -160]);
[q_val, T_val] = reach(truth, targets, seed);
val = struct('q', q_val, 'T', T_val);
e_cal = validate_all(models, names, cal, 'Errors at the calibration poses', [{[]}, reports]);
e_val = validate_all(models, names, val, 'Errors at the validation poses', [{[]}, reports]);

% 6. Figures.
files = [kincal_plot_errors(e_cal, names, 'file', fullfile(out, 'calibration_errors'), ...
    'title', '(a) virtual data, calibration poses'), ...
    kincal_plot_errors(e_val, names, 'file', fullfile(out, 'validation_errors'), ...
    'title', '(a) virtual data, validation poses')];
fprintf('\nfigures:\n%s', sprintf('  %s\n', files{:}));
