function T = kincal_pose_from_xyzrpy(xyzrpy)
%KINCAL_POSE_FROM_XYZRPY  Poses from position and roll-pitch-yaw angles.
%   T = KINCAL_POSE_FROM_XYZRPY(V) converts the columns of V (6 x M: x, y, z in m; roll,
%   pitch, yaw in rad) to a 4 x 4 x M stack with R = Rz(yaw) Ry(pitch) Rx(roll), the
%   convention of Table 2 and of the measurement CSV.
%
%   Example (Table 2 pose 1):
%       T = kincal_pose_from_xyzrpy([0.566; 0.354; 0.235; -150*pi/180; 0; 0]);
%
%   See also KINCAL_POSE_TO_XYZRPY, KINCAL_POSE_FROM_PQ.
xyzrpy = check_matrix(xyzrpy, 'xyzrpy', 6, NaN);
T = kincal_mex('pose_from_xyzrpy', xyzrpy);
end
