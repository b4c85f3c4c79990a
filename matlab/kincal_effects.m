function names = kincal_effects(robot)
%KINCAL_EFFECTS  Names of the non-geometric effects.
%   NAMES = KINCAL_EFFECTS() lists every effect the library models (1 x K cell):
%     base_frame, tool_frame          a small rigid offset of the base / tool frame
%     joint_compliance                dtheta_j = c_j tau_j(q), tau_j the gravity torque
%     joint_scale                     dtheta_j = k_j q_j
%     joint_cyclic                    dtheta_j = a sin q + b cos q + c sin 2q + d cos 2q
%     backlash                        dtheta_j = b_j s_j (needs approach directions s)
%     thermal                         d and a scaled by 1 + kappa (T - 20 C) (needs temp_c)
%   NAMES = KINCAL_EFFECTS(ROBOT) lists the joint effects with a non-zero parameter in ROBOT.
%
%   See also KINCAL_PARAM_MASK, KINCAL_IDENTIFY.
if nargin == 0
    names = kincal_mex('effect_names');
else
    names = kincal_mex('active_effects', check_robot(robot));
end
end
