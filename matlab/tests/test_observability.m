function tests = test_observability()
%TEST_OBSERVABILITY  Observability indices and pose selection (eq. 17, 18) through the gateway.
tests = {
    'observability_of_table2', @table2
    'select_poses_beats_table2', @select_beats_table2
    'select_poses_bad_inputs', @select_bad
    'cluster_select_distinct_cubes_equal_observability', @cluster_select
    'cluster_select_bad_inputs', @cluster_bad
    };
end

function [r, q] = table2_q()
[Tt, seed] = kincal_aria_tool();
r = kincal_robot('aria');
q = kincal_ik(r, Tt, seed);
end

function pool = random_pool(r, k)
% Deterministic candidates inside the joint limits (an LCG, independent of rand's state).
u = mod((1:6 * k)' * 0.6180339887498949, 1);
pool = repmat(r.limits(:, 1), 1, k) + reshape(u, 6, k) .* repmat(diff(r.limits, 1, 2), 1, k);
end

function table2()
[r, q] = table2_q();
[I, sv] = kincal_observability(r, q);
% The value ffi/src/tests/observability.rs and tests/cpp/consumer.cpp assert (TABLE2_O).
expect_true(abs(I.o - 1.453933636665828e-2) < 1e-9 * 1.453933636665828e-2, 'Table 2 O');
expect_true(I.params == 24 && I.poses == 10 && numel(sv) == 24, 'sizes');
expect_true(sv(1) == I.sigma_max && sv(end) == I.sigma_min, 'sigma range');
It = kincal_observability(r, q, 'scaling', 'tolerance', 'tolerance', [1e-3, 1e-3]);
expect_true(It.o > 0 && It.sigma_max ~= I.sigma_max, 'tolerance scaling');
end

function select_beats_table2()
% Property: the selected set's index is at least the Table 2 tool's.
[r, q] = table2_q();
I = kincal_observability(r, q);
[qs, info] = kincal_select_poses(r, 10, random_pool(r, 150), 'seed', 3);
expect_true(isequal(size(qs), [6, 10]), 'size');
expect_true(info.indices.o >= I.o, 'selected O >= Table 2 O');
kincal_check_limits(r, qs);
I2 = kincal_observability(r, qs);
expect_true(I2.o == info.indices.o, 'reported indices are those of Q');
% Deterministic for a seed.
qs2 = kincal_select_poses(r, 10, random_pool(r, 150), 'seed', 3);
expect_true(isequal(qs, qs2), 'same seed, same poses');
end

function select_bad()
r = kincal_robot('aria');
pool = random_pool(r, 20);
expect_error('kincal:tooFewData', @() kincal_select_poses(r, 21, pool));
expect_error('kincal:badValue', @() kincal_select_poses(r, 5, pool, 'objective', 'o9'));
bad = pool;
bad(2, 3) = NaN;
expect_error('kincal:nonFinite', @() kincal_select_poses(r, 5, bad));
expect_error('kincal:badSize', @() kincal_observability(r, zeros(5, 3)));
end

function cluster_select()
% The workspace-clustering design: m pool members, one per cube, whose per-pose singular
% values (the six of a pose's own block, unit columns: KINCAL_OBSERVABILITY of that pose)
% are within the reported spread of the target's; recomputed here from the outputs.
r = kincal_robot('aria');
pool = random_pool(r, 1500);
region = [-1, 1; -1, 1; 0.05, 1.5];
cube = 0.4;
m = 8;
[q, info] = kincal_cluster_select(r, m, pool, 'region', region, 'cube_m', cube, ...
    'max_spread', 0.3);
expect_true(isequal(size(q), [6, m]) && isequal(q, pool(:, info.chosen)), 'm pool members');
T = kincal_fk(r, q);
p = reshape(T(1:3, 4, :), 3, m);
counts = ceil(diff(region, 1, 2) / cube - 1e-9);
idx = min(floor((p - repmat(region(:, 1), 1, m)) / cube), repmat(counts - 1, 1, m));
expect_true(all(all(p >= repmat(region(:, 1), 1, m) & p <= repmat(region(:, 2), 1, m))), ...
    'inside the region');
expect_true(size(unique(idx', 'rows'), 1) == m, 'one pose per cube');
sv = @(j) local_sv(r, pool(:, j));
target = sv(info.target);
spread = 0;
for j = info.chosen
    spread = max(spread, max(abs(log(sv(j)) - log(target))));
end
expect_true(abs(spread - info.spread) < 1e-9, 'spread %.17g vs reported %.17g', spread, ...
    info.spread);
expect_true(info.within_tolerance == (info.spread <= 0.3), 'within_tolerance');
I = kincal_observability(r, q);
expect_true(abs(I.o - info.value) <= 1e-9 * I.o, 'value is the O of the chosen poses');
% Deterministic.
q2 = kincal_cluster_select(r, m, pool, 'region', region, 'cube_m', cube, 'max_spread', 0.3);
expect_true(isequal(q, q2), 'same pool, same poses');
end

function s = local_sv(r, q)
[~, sv] = kincal_observability(r, q);
s = sv(1:6);
end

function cluster_bad()
r = kincal_robot('aria');
pool = random_pool(r, 40);
region = [-1, 1; -1, 1; 0.05, 1.5];
expect_error('kincal:badArgCount', @() kincal_cluster_select(r, 5, pool));
expect_error('kincal:tooFewData', @() kincal_cluster_select(r, 30, pool, 'region', region, ...
    'cube_m', 1.5));
expect_error('kincal:invalidArgument', @() kincal_cluster_select(r, 5, pool, 'region', ...
    region, 'cube_m', 0));
end
