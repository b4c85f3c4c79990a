function theta = kincal_joint_angles(robot, q, varargin)
%KINCAL_JOINT_ANGLES  Joint angles the geometry sees after the joint effects.
%   THETA = KINCAL_JOINT_ANGLES(ROBOT, Q) is N x M: q_j + dtheta_j (compliance, scale,
%   cyclic, backlash; without theta0) for the columns of Q (rad): what a controller that
%   compensates the calibrated model works with. Options 'approach' and 'temp_c' as
%   KINCAL_FK.
%
%   See also KINCAL_FK, KINCAL_EFFECTS.
check_robot(robot);
q = check_matrix(q, 'q', robot.n_joints, NaN);
opts = parse_options(varargin, struct('approach', [], 'temp_c', []));
theta = kincal_mex('joint_angles', robot, q, make_aux(opts, robot.n_joints, size(q, 2)));
end
