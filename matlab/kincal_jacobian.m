function [J, T] = kincal_jacobian(robot, q, varargin)
%KINCAL_JACOBIAN  Identification Jacobian: derivative of the tool pose by the parameters.
%   [J, T] = KINCAL_JACOBIAN(ROBOT, Q) is the 6 x (5N+12) Jacobian at Q (N x 1, rad) with
%   respect to the geometric parameters (links, base, tool: the first 5N+12 entries of
%   ROBOT.params, labels ROBOT.labels(1:5N+12)). Rows are [dp (m); dphi (rad)] in the base
%   frame (the row order of KINCAL_POSE_ERROR); link columns follow eq. (13a-e) of the ARIA
%   paper. T is the tool pose at Q.
%   KINCAL_JACOBIAN(..., 'columns', 'all') gives all 12N+13 columns (with the effects).
%   Options 'approach' and 'temp_c' as KINCAL_FK.
%
%   See also KINCAL_FK, KINCAL_IDENTIFY.
if nargin < 2
    error('kincal:badArgCount', 'kincal_jacobian takes at least two arguments');
end
check_robot(robot);
q = check_matrix(q, 'q', robot.n_joints, 1);
opts = parse_options(varargin, struct('columns', 'geometric', 'approach', [], 'temp_c', []));
check_string(opts.columns, 'columns', {'geometric', 'all'});
[J, T] = kincal_mex('jacobian', robot, q, make_aux(opts, robot.n_joints, 1), opts.columns);
end
