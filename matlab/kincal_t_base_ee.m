function T = kincal_t_base_ee(t_mocap_base, t_mocap_ee)
%KINCAL_T_BASE_EE  End-effector pose in the robot base frame from two registrations.
%   T = KINCAL_T_BASE_EE(T_MOCAP_BASE, T_MOCAP_EE) is inv(T_MOCAP_BASE) * T_MOCAP_EE for
%   each pose: T_MOCAP_EE is 4 x 4 x M, T_MOCAP_BASE 4 x 4 x M or one 4 x 4 for all
%   (Section 5.1: b_T_e = (mocap_T_b)^-1 mocap_T_e).
%
%   See also KINCAL_REGISTER.
T = kincal_mex('t_base_ee', check_poses(t_mocap_base, 't_mocap_base'), ...
    check_poses(t_mocap_ee, 't_mocap_ee'));
end
