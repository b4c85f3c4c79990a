function v = kincal_pose_to_xyzrpy(T)
%KINCAL_POSE_TO_XYZRPY  Position and roll-pitch-yaw angles of poses.
%   V = KINCAL_POSE_TO_XYZRPY(T) converts the 4 x 4 x M rigid transforms T to V (6 x M:
%   x, y, z in m; roll, pitch, yaw in rad, R = Rz(yaw) Ry(pitch) Rx(roll), pitch in
%   [-pi/2, pi/2]; at gimbal lock roll = 0).
%
%   See also KINCAL_POSE_FROM_XYZRPY, KINCAL_POSE_TO_PQ.
T = check_poses(T, 'T');
v = kincal_mex('pose_to_xyzrpy', T);
end
