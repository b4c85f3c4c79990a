function tau = kincal_gravity_torques(robot, q)
%KINCAL_GRAVITY_TORQUES  Gravity torque about each joint axis.
%   TAU = KINCAL_GRAVITY_TORQUES(ROBOT, Q) is N x M (N m) for the configurations in the
%   columns of Q (N x M, rad), from ROBOT's point-mass model and nominal geometry: the
%   torques the joint_compliance effect multiplies.
%
%   See also KINCAL_ROBOT, KINCAL_EFFECTS.
check_robot(robot);
q = check_matrix(q, 'q', robot.n_joints, NaN);
tau = kincal_mex('gravity_torques', robot, q);
end
