function kincal_check_limits(robot, q)
%KINCAL_CHECK_LIMITS  Check joint readings against the joint limits.
%   KINCAL_CHECK_LIMITS(ROBOT, Q) returns silently when every column of Q (N x M, rad) lies
%   within ROBOT.limits (inclusive) and raises kincal:outOfLimits otherwise, naming the
%   joint and the column (1-based), the value and the limits.
%
%   See also KINCAL_ROBOT.
check_robot(robot);
q = check_matrix(q, 'q', robot.n_joints, NaN);
kincal_mex('check_limits', robot, q);
end
