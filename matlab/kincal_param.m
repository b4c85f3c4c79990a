function out = kincal_param(robot, label, value)
%KINCAL_PARAM  Read or set one model parameter by its label.
%   V = KINCAL_PARAM(ROBOT, LABEL) is the value of the parameter labelled LABEL.
%   ROBOT = KINCAL_PARAM(ROBOT, LABEL, V) sets it (current model only; the nominal geometry
%   stays).
%   Labels use 1-based link/joint numbers: 'theta0_3', 'd_4', 'a_2', 'alpha_2', 'beta_2',
%   'base_px' ... 'base_rz', 'tool_px' ... 'tool_rz', 'compliance_2', 'scale_1',
%   'cyclic_sin1_4', 'cyclic_cos2_4', 'backlash_6', 'thermal_kappa'. ROBOT.labels lists them.
%   Units: m, rad, rad/(N m) for compliance, 1 for scale, 1/K for thermal_kappa.
%   An unknown label raises kincal:unknownLabel.
%
%   Example:
%       robot = kincal_param(kincal_robot('aria'), 'theta0_4', -0.8);
%
%   See also KINCAL_ROBOT, KINCAL_PARAM_MASK.
if nargin < 2
    error('kincal:badArgCount', 'kincal_param takes two or three arguments');
end
check_robot(robot);
check_string(label, 'label');
if nargin < 3
    out = kincal_mex('param_get', robot, label);
else
    out = kincal_mex('param_set', robot, label, check_matrix(value, 'value', 1, 1));
end
end
