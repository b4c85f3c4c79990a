function [q, info] = kincal_ik(robot, T, seed, varargin)
%KINCAL_IK  Inverse kinematics: joint readings that reach tool poses.
%   [Q, INFO] = KINCAL_IK(ROBOT, T, SEED) solves for each pose of T (4 x 4 x M) the
%   readings Q(:, k) (N x M, rad, within the joint limits) whose FK (effects included)
%   reaches T(:,:,k). Damped least squares from SEED (N x 1 for all poses, or N x M) and a
%   few deterministic extra seeds; the solution nearest to the seed is returned.
%   INFO(k) has residual_pos_m, residual_rot_rad, iterations and seed (0 = the caller's).
%   Options (name-value):
%       'max_iterations' (200), 'extra_seeds' (16), 'first_solution' (false),
%       'tol_pos_m' (1e-11), 'tol_rot_rad' (1e-11), 'approach', 'temp_c' (as KINCAL_FK).
%   A pose no seed reaches raises kincal:unreachable (with the best residual found).
%
%   Example (the Table 2 calibration-tool poses):
%       [Tt, seed] = kincal_aria_tool();
%       q = kincal_ik(kincal_robot('aria'), Tt, seed);
%
%   See also KINCAL_FK, KINCAL_ARIA_TOOL.
if nargin < 3
    error('kincal:badArgCount', 'kincal_ik takes at least three arguments');
end
check_robot(robot);
T = check_poses(T, 'target');
m = size(T, 3);
seed = check_matrix(seed, 'seed', robot.n_joints, NaN);
if size(seed, 2) ~= 1 && size(seed, 2) ~= m
    error('kincal:badSize', 'argument ''seed'' must be %dx1 or %dx%d, got %dx%d', ...
        robot.n_joints, robot.n_joints, m, size(seed, 1), size(seed, 2));
end
defaults = struct('max_iterations', [], 'extra_seeds', [], 'first_solution', [], ...
    'tol_pos_m', [], 'tol_rot_rad', [], 'approach', [], 'temp_c', []);
opts = parse_options(varargin, defaults);
solver = struct();
for f = {'max_iterations', 'extra_seeds', 'first_solution', 'tol_pos_m', 'tol_rot_rad'}
    if ~isempty(opts.(f{1}))
        solver.(f{1}) = double(opts.(f{1}));
    end
end
if isempty(fieldnames(solver))
    solver = [];
end
[q, info] = kincal_mex('ik', robot, T, seed, make_aux(opts, robot.n_joints, m), solver);
end
