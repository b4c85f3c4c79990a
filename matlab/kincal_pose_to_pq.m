function pq = kincal_pose_to_pq(T)
%KINCAL_POSE_TO_PQ  Position and unit quaternion of poses.
%   PQ = KINCAL_POSE_TO_PQ(T) converts the 4 x 4 x M rigid transforms T to PQ (7 x M:
%   px, py, pz in m; qw, qx, qy, qz with qw >= 0).
%
%   See also KINCAL_POSE_FROM_PQ, KINCAL_POSE_TO_XYZRPY.
T = check_poses(T, 'T');
pq = kincal_mex('pose_to_pq', T);
end
