function e = kincal_pose_error(measured, model, form)
%KINCAL_POSE_ERROR  Kinematic error of measured poses relative to model poses.
%   E = KINCAL_POSE_ERROR(MEASURED, MODEL) is 6 x M: E(:, k) = [dp; dphi] of pose k,
%   dp = p_measured - p_model (m) and dphi the rotation vector of R_meas R_model' (rad),
%   both in the base frame (Section 3.2). MEASURED is 4 x 4 x M, MODEL 4 x 4 x M or 4 x 4.
%   E = KINCAL_POSE_ERROR(MEASURED, MODEL, 'small_angle') uses eq. (16),
%   S(dphi) = (R_meas - R_model) R_model' (skew part), instead of the exact log ('exact',
%   the default).
%   Inputs must be rigid transforms (kincal:invalidTransform otherwise).
%
%   Example (position error in mm of the nominal model against the true robot):
%       q = [0.3; 0.7; -0.4; 1.1; -0.6; 0.9];
%       e = kincal_pose_error(kincal_fk(kincal_robot('aria_true'), q), ...
%                             kincal_fk(kincal_robot('aria'), q));
%       1000 * e(1:3)
%
%   See also KINCAL_FK, KINCAL_VALIDATE.
if nargin < 2
    error('kincal:badArgCount', 'kincal_pose_error takes two or three arguments');
end
if nargin < 3
    form = 'exact';
end
measured = check_poses(measured, 'measured');
model = check_poses(model, 'model');
check_string(form, 'form', {'exact', 'small_angle'});
e = kincal_mex('pose_error', measured, model, form);
end
