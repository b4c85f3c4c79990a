function make_example_data(file)
%MAKE_EXAMPLE_DATA  Writes the example measurement file of workflow (c).
%   MAKE_EXAMPLE_DATA(FILE) writes a stand-in for a real experiment (the paper's Section 5
%   data are not public) in the format of spec/measurements.md; without FILE it rewrites
%   data/aria_example.csv next to this file. Everything is computed by the library:
%     - the "real" arm: the Table 4 robot (KINCAL_ROBOT('aria_real')) plus joint compliance
%       (the non-geometric effect the paper suspects: the arm's lack of stiffness), which a
%       geometric calibration cannot absorb;
%     - commanded poses: the ten Table 2 tool poses (role "calibration") and a grid in the
%       biopsy region above the tool plate (role "validation"), each solved by inverse
%       kinematics on the nominal model, as the controller would;
%     - the measured pose of each row: forward kinematics of the "real" arm at the joint
%       readings (no noise: the mismatch is the model's, which makes it reproducible).
%
%   See also WORKFLOW_C_REAL_DATA.
here = fileparts(mfilename('fullpath'));
if nargin < 1
    file = fullfile(here, 'data', 'aria_example.csv');
end
addpath(fileparts(here));
nominal = kincal_robot('aria');
real_arm = kincal_robot('aria_real');
compliance = [0, 1.5e-4, 1.0e-4, 0.5e-4, 0.5e-4, 0];   % rad/(N m), joints 1..6
for j = 1:6
    real_arm = kincal_param(real_arm, sprintf('compliance_%d', j), compliance(j));
end
[T_tool, seed] = kincal_aria_tool();
q_cal = kincal_ik(nominal, T_tool, seed);
[x, y, z] = ndgrid([0.216, 0.316, 0.416], [0.254, 0.354, 0.454], [0.26, 0.31]);
m = numel(x);
roll = repmat([-150, -160], 1, m / 2) * pi / 180;
T_grid = kincal_pose_from_xyzrpy([x(:)'; y(:)'; z(:)'; roll; zeros(2, m)]);
q_val = kincal_ik(nominal, T_grid, seed);
q = [q_cal, q_val];
T = kincal_fk(real_arm, q);
ids = [arrayfun(@(k) sprintf('tool%d', k), 1:10, 'UniformOutput', false), ...
    arrayfun(@(k) sprintf('grid%d', k), 1:m, 'UniformOutput', false)];
roles = [repmat({'calibration'}, 10, 1); repmat({'validation'}, m, 1)];
kincal_write_measurements(file, q, T, 'pose_id', ids, 'extra_names', {'extra_role'}, ...
    'extra', roles, 'comments', {'robot: aria', ...
    'synthetic stand-in for a real experiment, written by make_example_data.m:', ...
    'Table 4 robot plus joint compliance [0 1.5e-4 1e-4 5e-5 5e-5 0] rad/(N m), no noise', ...
    'extra_role: calibration = Table 2 tool poses, validation = biopsy-region grid'});
fprintf('wrote %s (%d poses)\n', file, numel(ids));
end
