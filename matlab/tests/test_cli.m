function tests = test_cli()
%TEST_CLI  The toolbox against the kincal CLI on the same inputs: the same Rust code behind
%   two front ends must agree to 1e-12 wherever the computation is deterministic.
tests = {
    'predict_matches_fk', @predict_matches_fk
    'calibrate_matches_identify', @calibrate_matches_identify
    'validate_matches_validate', @validate_matches_validate
    'model_file_matches_robot', @model_file_matches_robot
    'model_files_the_cli_refuses_are_refused', @model_files_the_cli_refuses_are_refused
    };
end

function [d, cleanup] = work_dir()
% A fresh folder, removed when the caller's CLEANUP goes out of scope.
[d, cleanup] = temp_path();
mkdir(d);
end

% Configurations: the Table 2 tool poses solved on the nominal robot plus a deterministic
% spread over the joint limits.
function q = configurations(robot)
[Tt, seed] = kincal_aria_tool();
q = kincal_ik(robot, Tt, seed);
lim = robot.limits;
f = mod((1:20)' * [0.618034 0.414214 0.732051 0.236068 0.645751 0.316625], 1);
q = [q, (repmat(lim(:, 1)', 20, 1) + f .* repmat(diff(lim, 1, 2)', 20, 1))'];
end

function [q, T] = tool_data(truth)
[Tt, seed] = kincal_aria_tool();
q = kincal_ik(truth, Tt, seed);
T = kincal_fk(truth, q);
end

function predict_matches_fk()
require_cli_command('predict');
[d, cleanup] = work_dir(); %#ok<ASGLU> removed on return
r = kincal_robot('aria');
q = configurations(r);
joints = fullfile(d, 'joints.csv');
poses = fullfile(d, 'poses.csv');
kincal_write_measurements(joints, q, [], 'pose_id', 1:size(q, 2));
cli('predict', 'aria', joints, '--out', poses);
p = kincal_read_measurements(poses, 'robot', r);
expect_true(isequal(p.q, q), 'the CLI read the joint readings bit for bit');
expect_true(strcmp(p.orientation, 'quaternion'), 'predict writes quaternions');
expect_near(p.T, kincal_fk(r, q), 1e-12, 'CLI predict vs kincal_fk');
end

function calibrate_matches_identify()
require_cli_command('calibrate');
require_function('kincal_identify', 'kincal_identify');
[d, cleanup] = work_dir(); %#ok<ASGLU> removed on return
start = kincal_robot('aria');
[q, T] = tool_data(kincal_robot('aria_real'));
data = fullfile(d, 'data.csv');
model = fullfile(d, 'model.json');
kincal_write_measurements(data, q, T);
meas = kincal_read_measurements(data, 'robot', start);
cli('calibrate', data, '--robot', 'aria', '--algorithm', 'all', '--out', model);
m = kincal_load_model(model);
for alg = {'ols', 'opt1', 'opt2'}
    [fitted, report] = kincal_identify(start, meas.q, meas.T, 'algorithm', alg{1});
    cli_params = m.results.(alg{1}).params;
    expect_near(fitted.params, cli_params, 1e-12, ['identified parameters, ' upper(alg{1})]);
    expect_true(report.iterations == m.results.(alg{1}).iterations, '%s iterations', alg{1});
end
end

function validate_matches_validate()
require_cli_command('validate');
require_function('kincal_validate', 'kincal_validate');
[d, cleanup] = work_dir(); %#ok<ASGLU> removed on return
r = kincal_robot('aria');
[q, T] = tool_data(kincal_robot('aria_true'));
data = fullfile(d, 'data.csv');
json = fullfile(d, 'validation.json');
kincal_write_measurements(data, q, T);
meas = kincal_read_measurements(data, 'robot', r);
cli('validate', 'aria', data, '--json', json, '--quiet');
v = jsondecode(fileread(json));
[errors, summary] = kincal_validate(r, meas.q, meas.T);
poses = v.poses;
if iscell(poses)
    poses = [poses{:}];
end
% JSON numbers pass through Octave's jsondecode, which may round the last bit.
expect_near(summary.rms_pos_m, v.summary.rms_pos_m, 1e-12, 'RMS position error');
expect_near(summary.max_pos_m, v.summary.max_pos_m, 1e-12, 'max position error');
expect_near(summary.rms_rot_rad, v.summary.rms_rot_rad, 1e-12, 'RMS orientation error');
expect_near(summary.max_rot_rad, v.summary.max_rot_rad, 1e-12, 'max orientation error');
expect_near(errors(7, :), [poses.e_pos_norm_m], 1e-12, 'per-pose |e_p|');
expect_near(errors(8, :), [poses.e_rot_norm_rad], 1e-12, 'per-pose |e_phi|');
expect_near(errors(1:3, :), [poses.e_pos_m], 1e-12, 'per-pose e_p');
expect_near(errors(4:6, :), [poses.e_rot_rad], 1e-12, 'per-pose e_phi');
expect_true(summary.pos_ok == v.summary.pos_ok && summary.rot_ok == v.summary.rot_ok, ...
    'verdicts');
end

function model_file_matches_robot()
require_cli_command('calibrate');
require_function('kincal_load_model', 'kincal_identify (for the calibrated model)');
[d, cleanup] = work_dir(); %#ok<ASGLU> removed on return
start = kincal_robot('aria');
[q, T] = tool_data(kincal_robot('aria_true'));
data = fullfile(d, 'data.csv');
model = fullfile(d, 'model.json');
kincal_write_measurements(data, q, T);
cli('calibrate', data, '--robot', 'aria', '--algorithm', 'opt2', '--out', model);
m = kincal_load_model(model);
joints = fullfile(d, 'joints.csv');
poses = fullfile(d, 'poses.csv');
qs = configurations(start);
kincal_write_measurements(joints, qs, []);
cli('predict', model, joints, '--out', poses);
p = kincal_read_measurements(poses);
expect_near(p.T, kincal_fk(m.robot, qs), 1e-12, 'FK of the loaded model vs CLI predict');
end

% Issue #16 item 10: kincal_load_model used to accept files the CLI refuses (a missing
% parameter kept its nominal value, a relabelled one won, an unknown length parameter became
% d, n_joints was ignored). Both front ends read through kincal-io now: each broken copy of
% a CLI-written model is refused by the CLI (exit 3) and by Octave (kincal:badFile, the
% CLI's file:line:column message).
function model_files_the_cli_refuses_are_refused()
require_cli_command('calibrate');
[d, cleanup] = work_dir(); %#ok<ASGLU> removed on return
[q, T] = tool_data(kincal_robot('aria_true'));
data = fullfile(d, 'data.csv');
model = fullfile(d, 'model.json');
kincal_write_measurements(data, q, T);
cli('calibrate', data, '--robot', 'aria', '--algorithm', 'all', '--out', model);
text = fileread(model);
m = kincal_load_model(model);
expect_true(isfield(m.results, 'opt2'), 'the calibrated runs are read');
broken = {
    'missing parameter', 'theta0_4', ...
        regexprep(text, '\{\s*"label": "theta0_4"[^}]*\},\s*', '', 'once')
    'relabelled parameter', 'theta0_5', ...
        regexprep(text, '"label": "theta0_4"', '"label": "theta0_5"', 'once')
    'unknown length parameter', 'length', ...
        regexprep(text, '("length_params": \[\s*)"(d|beta)"', '$1"q"', 'once')
    'wrong joint count', 'parameter', ...
        regexprep(text, '"n_joints": 6', '"n_joints": 5', 'once')
    };
joints = fullfile(d, 'joints.csv');
kincal_write_measurements(joints, q, []);
for k = 1:size(broken, 1)
    expect_true(~strcmp(broken{k, 3}, text), 'the edit "%s" changed the file', broken{k, 1});
    bad = fullfile(d, sprintf('broken_%d.json', k));
    fid = fopen(bad, 'w');
    fwrite(fid, broken{k, 3});
    fclose(fid);
    status = cli_status('predict', bad, joints, '--out', fullfile(d, 'poses.csv'));
    expect_true(status == 3, '%s: the CLI exits 3 (got %d)', broken{k, 1}, status);
    expect_error('kincal:badFile', @() kincal_load_model(bad), [bad ':']);
end
% The message names the line and column of a syntax error, as the CLI's does.
bad = fullfile(d, 'syntax.json');
fid = fopen(bad, 'w');
fwrite(fid, strrep(text, '"robot":', '"robot":,'));
fclose(fid);
line = numel(strfind(text(1:strfind(text, '"robot":')), sprintf('\n'))) + 1;
expect_error('kincal:badFile', @() kincal_load_model(bad), sprintf('%s:%d:', bad, line));
end

function status = cli_status(varargin)
try
    cli(varargin{:});
    status = 0;
catch err
    tok = regexp(err.message, 'exited with status (\d+)', 'tokens', 'once');
    status = str2double(tok{1});
end
end
