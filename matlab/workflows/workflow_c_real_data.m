%WORKFLOW_C_REAL_DATA  Toolbox workflow (c): calibration from a measurement CSV (Section 5).
%   Reads a measurement file (spec/measurements.md), calibrates the ARIA model with the three
%   algorithms and validates the result:
%     1. the data: $KINCAL_DATA, else data/aria_example.csv next to this script (a synthetic
%        stand-in for the paper's experiment, see make_example_data.m). Rows whose user
%        column extra_role says "validation" are kept out of the calibration; without that
%        column every row is used for both;
%     2. the identifiability analysis of the calibration poses;
%     3. OLS, OPT1 (the paper's intervals: +-5 mm, +-5 deg around Table 1) and OPT2;
%     4. the parameter table NOM / OLS / OPT1 / OPT2 with OLS standard errors (compare
%        with Table 4 of the paper);
%     5. errors at the calibration and validation poses against the 1 mm / 0.66 deg
%        targets, and whether identifying joint compliance as well closes the gap a
%        geometric calibration leaves (the paper's suspicion);
%     6. the 4x4 error figures (position mm, orientation deg; NOM, OLS, OPT1, OPT2) at the
%        validation poses, as PNG.
%
%   Run:  cd matlab/workflows; workflow_c_real_data
%         (your own file: setenv('KINCAL_DATA', 'my_poses.csv'); workflow_c_real_data)
%   Outputs: $KINCAL_OUT/c_real_data, default matlab/out/c_real_data.
%
%   See also WORKFLOW_A_VIRTUAL, WORKFLOW_B_TOOL_DESIGN, KINCAL_READ_MEASUREMENTS.

out = setup_toolbox('c_real_data');
data_file = getenv('KINCAL_DATA');
if isempty(data_file)
    data_file = fullfile(fileparts(mfilename('fullpath')), 'data', 'aria_example.csv');
end
nominal = kincal_robot('aria');
names = {'NOM', 'OLS', 'OPT1', 'OPT2'};

% 1. The data.
data = kincal_read_measurements(data_file, 'robot', nominal, 'require_pose', true);
role = find(strcmp(data.extra_names, 'extra_role'), 1);
if isempty(role)
    cal = data;
    val = data;
else
    is_val = strcmp(data.extra(:, role), 'validation')';
    cal = subset_data(data, ~is_val);
    val = subset_data(data, is_val);
end
fprintf('\n(c) calibration from %s\n', data_file);
fprintf('%s\n', data.comments{:});
fprintf('%d calibration poses, %d validation poses (%s)\n', cal.n_poses, val.n_poses, ...
    data.components);

% 2. What the calibration poses determine.
a = kincal_identifiability(nominal, cal);
fprintf('identifiability: rank %d of %d requested, condition number %.4g\n', a.rank, ...
    nnz(a.requested), a.condition_number);
if ~isempty(a.data_deficient_labels)
    fprintf('not determined by these poses: %s\n', strjoin(a.data_deficient_labels, ', '));
end

% 3. The three algorithms (OPT1 with the library's default intervals, the paper's).
[models, reports] = calibrate_three(nominal, cal, [], []);

% 4. Parameter table.
fprintf('\n');
kincal_print_params(models, names, 'std_errors', {[], reports{1}.std_errors, ...
    reports{2}.std_errors, reports{3}.std_errors}, 'title', ...
    'Identified parameters, value (+- standard error) (compare with Table 4 of the paper)');
if reports{1}.n_correlated > 0
    c = reports{1}.correlations;
    fprintf('OLS estimates correlated above 0.95: %s\n', strjoin(arrayfun(@(p) ...
        sprintf('%s/%s %.3f', p.a, p.b, p.rho), c, 'UniformOutput', false), ', '));
end

% 5. Errors, and the gap a geometric calibration leaves.
validate_all(models, names, cal, 'Errors at the calibration poses', [{[]}, reports]);
e_val = validate_all(models, names, val, 'Errors at the validation poses', [{[]}, reports]);
[with_c, rep_c] = kincal_identify(nominal, cal, 'effects', {'joint_compliance'}, ...
    'allow_data_deficiency', true);
fprintf(['\nOLS with joint compliance identified as well (%d parameters fitted, %d not ' ...
    'determined by these poses):\n'], rep_c.analysis.rank, numel(rep_c.analysis.data_deficient_labels));
validate_all({models{2}, with_c}, {'OLS', 'OLS+C'}, val, 'Errors at the validation poses');

% 6. Figures.
files = kincal_plot_errors(e_val, names, 'file', fullfile(out, 'validation_errors'), ...
    'title', '(c) measurement file, validation poses');
fprintf('\nfigures:\n%s', sprintf('  %s\n', files{:}));
