function mask = kincal_param_mask(robot, effects)
%KINCAL_PARAM_MASK  Which parameters are identified by default.
%   MASK = KINCAL_PARAM_MASK(ROBOT) is a P x 1 logical over ROBOT.params: theta0, a, alpha and
%   (d or beta, see ROBOT.length_param) of every link.
%   MASK = KINCAL_PARAM_MASK(ROBOT, EFFECTS) adds every parameter of the effects named in the
%   cell array EFFECTS (see KINCAL_EFFECTS for the names).
%
%   Example:
%       robot = kincal_robot('aria');
%       robot.labels(kincal_param_mask(robot))'
%
%   See also KINCAL_EFFECTS, KINCAL_IDENTIFY.
if nargin < 2
    effects = {};
end
check_robot(robot);
mask = kincal_mex('param_mask', robot, effects);
end
