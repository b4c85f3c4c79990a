function tests = test_observability()
%TEST_OBSERVABILITY  Observability indices and pose selection (eq. 17, 18) through the gateway.
tests = {
    'observability_of_table2', @table2
    'select_poses_beats_table2', @select_beats_table2
    'select_poses_bad_inputs', @select_bad
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
