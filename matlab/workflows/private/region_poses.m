function T = region_poses(xs, ys, zs, rolls_deg)
%REGION_POSES  Target tool poses on a grid (private to the workflows): every combination of
%   the positions XS x YS x ZS (m), the needle pointing down with roll ROLLS_DEG (deg,
%   alternating over the grid), pitch and yaw 0, like the Table 2 poses. x runs fastest.
[x, y, z] = ndgrid(xs, ys, zs);
m = numel(x);
roll = rolls_deg(mod(0:m - 1, numel(rolls_deg)) + 1) * pi / 180;
T = kincal_pose_from_xyzrpy([x(:)'; y(:)'; z(:)'; roll(:)'; zeros(2, m)]);
end
