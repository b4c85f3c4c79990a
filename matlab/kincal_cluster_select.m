function [q, info] = kincal_cluster_select(robot, m, pool, varargin)
%KINCAL_CLUSTER_SELECT  The paper's workspace-clustering design (Section 4.2).
%   [Q, INFO] = KINCAL_CLUSTER_SELECT(ROBOT, M, POOL, 'region', REGION) chooses M of the
%   candidate configurations POOL (N x K, rad) whose end-effector positions lie in mutually
%   different cubes of side 'cube_m' of REGION and whose per-pose observability (the six
%   singular values of the pose's identification Jacobian block) matches a target pose's
%   within 'max_spread' (max_k |ln s_k - ln s_k*|). Among targets whose design is within it,
%   the index 'objective' of the M poses decides; otherwise the smallest spread wins. Q
%   (N x M) are pool members; the result is deterministic. The same design as the CLI's
%   `kincal select-poses --design clustering` on the same pool (one core function,
%   kincal::selection::cluster_select, through the C ABI's kincal_cluster_select).
%   Fields of INFO: chosen (1 x M pool columns), spread, value (the objective of Q),
%   target (pool column of the target pose), within_tolerance, occupied_cubes.
%   Options (name-value):
%       'region'      3 x 2 [min max] box of the end-effector position (m); required
%       'cube_m'      cube side (m, default 0.1)
%       'max_spread'  accepted spread of the per-pose indices (default 0.1, about 10 %)
%       'objective'   'o' (default, eq. 17), 'o1' ... 'o5', 'aopt', 'dopt'
%       'params', 'scaling', 'tolerance'  as KINCAL_OBSERVABILITY
%   M is at most 61 and at most the number of cubes that hold a candidate.
%
%   Example:
%       r = kincal_robot('aria');
%       pool = r.limits(:, 1) + rand(6, 3000) .* diff(r.limits, 1, 2);
%       region = [-0.5 0.5; -0.5 0.5; 0 0.6];
%       [q, info] = kincal_cluster_select(r, 10, pool, 'region', region, 'cube_m', 0.2);
%
%   See also KINCAL_SELECT_POSES, KINCAL_OBSERVABILITY.
if nargin < 3
    error('kincal:badArgCount', 'kincal_cluster_select takes ROBOT, M and POOL');
end
check_robot(robot);
o = parse_options(varargin, struct('region', [], 'cube_m', 0.1, 'max_spread', 0.1, ...
    'objective', 'o', 'params', [], 'scaling', 'unit', 'tolerance', []));
if isempty(o.region)
    error('kincal:badArgCount', ['kincal_cluster_select: option ''region'' (3 x 2 [min max], ' ...
        'm) is required: the cubes split it']);
end
[q, info] = kincal_mex('cluster_select', robot, pool, m, o.params, o.scaling, o.tolerance, ...
    o.objective, o.region, o.cube_m, o.max_spread);
end
