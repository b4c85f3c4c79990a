function [errors, summary] = kincal_validate(robot, varargin)
%KINCAL_VALIDATE  Per-pose errors of a model on measured poses, and their summary.
%   [E, S] = KINCAL_VALIDATE(ROBOT, Q, T) or (ROBOT, DATA) compares the model's poses at Q
%   (N x M) with the measured full poses T (4 x 4 x M): measured minus model in the base
%   frame, exact rotation-vector orientation error. E is 8 x M per pose:
%       E(1:3, :)  e_p = [e_x; e_y; e_z] (m)
%       E(4:6, :)  e_phi (rad)
%       E(7, :)    |e_p| (m),   E(8, :)  |e_phi| (rad)
%   S: count, rms_pos_m, max_pos_m, rms_rot_rad, max_rot_rad (RMS = sqrt of the mean
%   squared norm), pos_ok and rot_ok (every pose below the targets).
%   Options: 'targets', [pos_m, rot_rad] (default the paper's [1e-3, 0.66 deg]),
%   'approach', 'temp_c' as KINCAL_FK.
%
%   Example:
%       [E, S] = kincal_validate(fitted, q_check, T_check);
%       kincal_plot_errors({E}, {'OLS'});
%
%   See also KINCAL_PLOT_ERRORS, KINCAL_POSE_ERROR, KINCAL_BIOPSY_ROTATION.
if nargin < 2
    error('kincal:badArgCount', 'kincal_validate takes ROBOT and data');
end
check_robot(robot);
[q, T, components, aux, rest] = measurement_args(robot, varargin, 'kincal_validate');
if ~isempty(components)
    error('kincal:badValue', 'kincal_validate needs full poses (position and orientation)');
end
opts = parse_options(rest, struct('targets', []));
targets = opts.targets;
if ~isempty(targets)
    targets = check_matrix(targets(:)', 'targets', 1, 2);
end
[errors, summary] = kincal_mex('validate', robot, q, T, aux, targets);
end
