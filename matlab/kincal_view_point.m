function [v, T_at] = kincal_view_point(T, axis)
%KINCAL_VIEW_POINT  Where camera poses look: the point their viewing axes converge on.
%   V = KINCAL_VIEW_POINT(T) takes camera poses T (4 x 4 x M, M >= 2, rigid transforms, all
%   in one frame) and finds the point nearest (least squares) to every viewing axis, the
%   line through each frame origin along its z axis (the optical axis of OpenCV and ROS
%   optical frames). V is a struct:
%       point_m          3 x 1 point, in the frame of the poses (m)
%       mean_distance_m  mean distance from the frame origins to the point, measured along
%                        each axis: the re-expression distance s (m)
%       min_distance_m, max_distance_m   smallest and largest such distance (negative: the
%                        point lies behind that camera)
%       miss_rms_m       RMS distance of the point from the viewing axes (m)
%       miss_max_m       largest distance of the point from a viewing axis (m)
%       miss_max_pose    the pose (1-based) whose axis passes farthest from the point
%   A large miss (compared with the distance) means the camera did not look at one place.
%   V = KINCAL_VIEW_POINT(T, AXIS) uses the frame axis AXIS ('x', 'y' or 'z', default 'z')
%   as the viewing direction.
%
%   [V, T_AT] = KINCAL_VIEW_POINT(...) also gives the poses moved (not rotated) to the point
%   they look at, T_AT(:, :, k) = T(:, :, k) * [eye(3) s*e; 0 0 0 1] with s =
%   V.mean_distance_m and e the unit AXIS: what `kincal observed-point` writes (its rows
%   then carry point_x..z = s*e). The camera pose is T = T_AT * [eye(3) -s*e; 0 0 0 1].
%
%   Errors: kincal:badSize (T not 4 x 4 x M), kincal:nonFinite, kincal:badValue (AXIS),
%   kincal:tooFewData (fewer than 2 poses), kincal:invalidTransform (a pose that is not a
%   rigid transform; the message names it), kincal:rankDeficient (the axes are parallel:
%   they converge on no point).
%
%   Example (three cameras aimed at one target):
%       T = zeros(4, 4, 3);
%       T(:, :, 1) = [0 0 -1 1; 1 0 0 -0.2; 0 -1 0 0.3; 0 0 0 1];   % at x = 1, looking -x
%       T(:, :, 2) = [1 0 0 0.5; 0 -1 0 -0.2; 0 0 -1 1.3; 0 0 0 1]; % at z = 1.3, looking -z
%       T(:, :, 3) = [1 0 0 0.5; 0 0 -1 0.5; 0 1 0 0.3; 0 0 0 1];   % at y = 0.5, looking -y
%       v = kincal_view_point(T)   % point_m = [0.5; -0.2; 0.3], distances 0.5, 1 and 0.7
%
%   See also KINCAL_POSE_ERROR, KINCAL_READ_MEASUREMENTS.
if nargin < 1 || nargin > 2
    error('kincal:badArgCount', 'kincal_view_point takes T and an optional AXIS');
end
if nargin < 2
    axis = 'z';
end
T = check_poses(T, 'T');
check_string(axis, 'axis', {'x', 'y', 'z'});
if nargout > 1
    [v, T_at] = kincal_mex('view_point', T, axis);
else
    v = kincal_mex('view_point', T, axis);
end
end
