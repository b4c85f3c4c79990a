function [q, info] = kincal_select_poses(robot, m, pool, varargin)
%KINCAL_SELECT_POSES  Calibration poses that maximise an observability index (eq. 18).
%   [Q, INFO] = KINCAL_SELECT_POSES(ROBOT, M, POOL) selects M configurations (Q, N x M, rad)
%   from the candidate configurations POOL (N x K, K >= M, within the joint limits and, if
%   given, the region): a greedy start, DETMAX exchange, then joint-space refinement (the
%   refined poses need not be pool members). The result depends only on the seed. Fields of
%   INFO: value (the objective of Q), initial_value, exchange_value, evaluations, exchanges,
%   refinements, start (1-based), indices (as KINCAL_OBSERVABILITY of Q).
%   Options (name-value):
%       'objective'     'o' (default, eq. 17), 'o1' ... 'o5', 'aopt', 'dopt'
%       'seed'          non-negative integer (default 1)
%       'region'        3 x 2 [min max] box of the end-effector position (m), or [] (default)
%       'joint_margin'  distance kept from the joint limits (rad, default 0)
%       'params', 'scaling', 'tolerance'  as KINCAL_OBSERVABILITY
%   M is at most 61.
%
%   Example:
%       r = kincal_robot('aria');
%       pool = r.limits(:, 1) + rand(6, 300) .* diff(r.limits, 1, 2);
%       [q, info] = kincal_select_poses(r, 10, pool, 'seed', 3);
%       T = kincal_fk(r, q);   % the tool poses
%
%   See also KINCAL_OBSERVABILITY, KINCAL_FK.
if nargin < 3
    error('kincal:badArgCount', 'kincal_select_poses takes ROBOT, M and POOL');
end
check_robot(robot);
o = parse_options(varargin, struct('objective', 'o', 'seed', 1, 'region', [], ...
    'joint_margin', 0, 'params', [], 'scaling', 'unit', 'tolerance', []));
[q, info] = kincal_mex('select_poses', robot, pool, m, o.params, o.scaling, o.tolerance, ...
    o.objective, o.seed, o.region, o.joint_margin);
end
