function T = kincal_fk(robot, q, varargin)
%KINCAL_FK  Forward kinematics: the tool pose in the base frame.
%   T = KINCAL_FK(ROBOT, Q) is the 4 x 4 x M stack of tool poses T_e^b (metres) for the
%   M configurations in the columns of Q (N x M joint readings, radians). Effects in ROBOT
%   (compliance, scale, ...) are applied. Joint limits are not checked (KINCAL_CHECK_LIMITS).
%   T = KINCAL_FK(ROBOT, Q, 'approach', S, 'temp_c', TC) passes approach directions
%   (N x M, each -1, 0 or +1) for a model with backlash and arm temperatures (1 x M, deg C)
%   for a model with thermal expansion.
%
%   Example:
%       robot = kincal_robot('aria');
%       T = kincal_fk(robot, zeros(6, 1));   % T(1:3, 4) is the tool position
%
%   See also KINCAL_FRAMES, KINCAL_JACOBIAN, KINCAL_IK.
if nargin < 2
    error('kincal:badArgCount', 'kincal_fk takes at least two arguments');
end
check_robot(robot);
q = check_matrix(q, 'q', robot.n_joints, NaN);
opts = parse_options(varargin, struct('approach', [], 'temp_c', []));
T = kincal_mex('fk', robot, q, make_aux(opts, robot.n_joints, size(q, 2)));
end
