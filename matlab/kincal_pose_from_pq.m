function T = kincal_pose_from_pq(pq)
%KINCAL_POSE_FROM_PQ  Poses from position and unit quaternion.
%   T = KINCAL_POSE_FROM_PQ(PQ) converts the columns of PQ (7 x M: px, py, pz in m; qw, qx,
%   qy, qz) to a 4 x 4 x M stack. Quaternions are normalised; a zero quaternion raises
%   kincal:invalidParameter.
%
%   See also KINCAL_POSE_TO_PQ, KINCAL_POSE_FROM_XYZRPY.
pq = check_matrix(pq, 'pq', 7, NaN);
T = kincal_mex('pose_from_pq', pq);
end
