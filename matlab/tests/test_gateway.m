function tests = test_gateway()
%TEST_GATEWAY  The MEX gateway on its own: bad inputs raise the right identifiers (never a
%   crash), the status-to-identifier table, and no state between calls. Calls go straight to
%   the gateway (see private/gateway.m), bypassing the wrappers' checks.
tests = {
    'unknown_operation', @unknown_operation
    'argument_counts', @argument_counts
    'classes', @classes
    'sizes', @sizes
    'non_finite', @non_finite
    'robot_struct_fields', @robot_struct_fields
    'rust_statuses_become_identifiers', @rust_statuses
    'one_based_numbers_in_messages', @one_based_numbers
    'status_table', @status_table
    'wrappers_raise_the_same_identifiers', @wrappers_same_ids
    'no_state_between_calls', @no_state
    'rust_panic_becomes_an_error', @rust_panic
    };
end

function r = aria()
r = gateway('robot_aria', 'aria');
end

function unknown_operation()
expect_error('kincal:unknownOperation', @() gateway());
expect_error('kincal:unknownOperation', @() gateway('no_such_op'), 'no_such_op');
expect_error('kincal:unknownOperation', @() gateway(42));
expect_error('kincal:unknownOperation', @() gateway(repmat('x', 1, 200)));
end

function argument_counts()
r = aria();
expect_error('kincal:badArgCount', @() gateway('fk', r, zeros(6, 1)));
expect_error('kincal:badArgCount', @() gateway('fk', r, zeros(6, 1), [], []));
expect_error('kincal:badArgCount', @() call_with_outputs(3, 'fk', r, zeros(6, 1), []));
end

function call_with_outputs(n, varargin)
out = cell(1, n);
[out{:}] = gateway(varargin{:});
end

function classes()
r = aria();
q = zeros(6, 1);
expect_error('kincal:badClass', @() gateway('fk', r, single(q), []), 'single');
expect_error('kincal:badClass', @() gateway('fk', r, int32(q), []), 'int32');
expect_error('kincal:badClass', @() gateway('fk', r, complex(q, 1), []), 'complex');
expect_error('kincal:badClass', @() gateway('fk', r, sparse(q), []), 'sparse');
expect_error('kincal:badClass', @() gateway('fk', r, {q}, []));
expect_error('kincal:badClass', @() gateway('fk', 'aria', q, []), 'robot');
expect_error('kincal:badClass', @() gateway('fk', [r, r], q, []), 'robot');
expect_error('kincal:badClass', @() gateway('robot_aria', 1));
expect_error('kincal:badClass', @() gateway('pose_error', eye(4), eye(4), 1));
bad = r;
bad.params = single(r.params);
expect_error('kincal:badClass', @() gateway('fk', bad, q, []), 'robot.params');
expect_error('kincal:badClass', @() gateway('fk', r, q, 'approach'), 'aux');
expect_error('kincal:badClass', @() gateway('param_mask', r, 5), 'effects');
end

function sizes()
r = aria();
expect_error('kincal:badSize', @() gateway('fk', r, zeros(5, 1), []), '6xM, got 5x1');
expect_error('kincal:badSize', @() gateway('fk', r, zeros(6, 2, 2), []), '6x2x2');
expect_error('kincal:badSize', @() gateway('frames', r, zeros(6, 2), []), '6x1');
expect_error('kincal:badSize', @() gateway('pose_error', eye(3), eye(4), 'exact'), ...
    'measured');
expect_error('kincal:badSize', @() gateway('pose_error', zeros(4, 4, 3), ...
    repmat(eye(4), [1 1 2]), 'exact'));
expect_error('kincal:badSize', @() gateway('pose_from_xyzrpy', zeros(5, 2)));
expect_error('kincal:badSize', @() gateway('pose_from_pq', zeros(6, 1)));
expect_error('kincal:badSize', @() gateway('ik', r, eye(4), zeros(6, 3), [], []), 'seed');
expect_error('kincal:badSize', @() gateway('robot_init', zeros(6, 4), zeros(6, 2), 'x'));
bad = r;
bad.params = r.params(1:end - 1);
expect_error('kincal:badSize', @() gateway('fk', bad, zeros(6, 1), []), 'robot.params');
bad = r;
bad.limits = r.limits';
expect_error('kincal:badSize', @() gateway('fk', bad, zeros(6, 1), []), 'robot.limits');
aux.approach = zeros(5, 1);
expect_error('kincal:badSize', @() gateway('fk', r, zeros(6, 1), aux), 'approach');
% Empty stacks are fine (M = 0).
T = gateway('fk', r, zeros(6, 0), []);
expect_true(isequal(size(T, 1), 4) && size(T, 3) == 0, 'FK of no configuration');
end

function non_finite()
r = aria();
q = zeros(6, 1);
q(3) = NaN;
expect_error('kincal:nonFinite', @() gateway('fk', r, q, []), 'element 3');
q(3) = Inf;
expect_error('kincal:nonFinite', @() gateway('fk', r, q, []));
T = eye(4);
T(2, 4) = -Inf;
expect_error('kincal:nonFinite', @() gateway('pose_error', T, eye(4), 'exact'));
bad = r;
bad.params(17) = NaN;
expect_error('kincal:nonFinite', @() gateway('fk', bad, zeros(6, 1), []), 'robot.params');
end

function robot_struct_fields()
r = aria();
q = zeros(6, 1);
bad = rmfield(r, 'nominal');
expect_error('kincal:missingField', @() gateway('fk', bad, q, []), 'nominal');
bad = r;
bad.extra_field = 1;
expect_error('kincal:unknownField', @() gateway('fk', bad, q, []), 'extra_field');
bad = r;
bad.n_joints = 0;
expect_error('kincal:badJointCount', @() gateway('fk', bad, q, []));
bad.n_joints = 13;   % KINCAL_MAX_JOINTS is 12
expect_error('kincal:badValue', @() gateway('fk', bad, q, []), 'n_joints');
bad.n_joints = 2.5;
expect_error('kincal:badValue', @() gateway('fk', bad, q, []), 'n_joints');
bad = r;
bad.length_param(4) = 2;
expect_error('kincal:badValue', @() gateway('fk', bad, q, []), 'link 4');
bad = r;
bad.limits(2, :) = [1, -1];
expect_error('kincal:invalidLimits', @() gateway('fk', bad, q, []), 'joint 2');
bad = r;
bad.link_masses_kg(1) = -1;
expect_error('kincal:invalidParameter', @() gateway('fk', bad, q, []));
opts.no_such_option = 1;
[Tt, seed] = gateway('aria_tool');
expect_error('kincal:unknownField', @() gateway('ik', r, Tt(:, :, 1), seed, [], opts));
opts = struct('max_iterations', -1);
expect_error('kincal:badValue', @() gateway('ik', r, Tt(:, :, 1), seed, [], opts));
end

function rust_statuses()
r = aria();
[Tt, seed] = gateway('aria_tool');
% Not a rigid transform: the library says so.
T = eye(4);
T(1, 1) = 2;
expect_error('kincal:invalidTransform', @() gateway('pose_error', T, eye(4), 'exact'));
expect_error('kincal:invalidTransform', @() gateway('pose_to_pq', T));
% A pose far outside the workspace.
far = Tt(:, :, 1);
far(1:3, 4) = [5; 5; 5];
expect_error('kincal:unreachable', @() gateway('ik', r, far, seed, [], []), 'best residual');
expect_error('kincal:unknownLabel', @() gateway('param_get', r, 'theta0_9'), 'theta0_9');
expect_error('kincal:unknownLabel', @() gateway('param_mask', r, {'gravity_waves'}), ...
    'gravity_waves');
expect_error('kincal:invalidParameter', @() gateway('pose_from_pq', zeros(7, 1)));
% A model with backlash needs approach directions, which must be -1, 0 or +1.
b = gateway('param_set', r, 'backlash_2', 1e-3);
expect_error('kincal:missingInput', @() gateway('fk', b, zeros(6, 1), []));
aux.approach = [0; 0.5; 0; 0; 0; 0];
expect_error('kincal:invalidArgument', @() gateway('fk', b, zeros(6, 1), aux));
aux.approach = [0; 1; 0; 0; 0; 0];
gateway('fk', b, zeros(6, 1), aux);
expect_error('kincal:badValue', @() gateway('robot_aria', 'aria_fake'), 'aria_true');
expect_error('kincal:badValue', @() gateway('pose_error', eye(4), eye(4), 'big_angle'));
end

function one_based_numbers()
r = aria();
q = zeros(6, 3);
q(2, 3) = 3.7;   % joint 2 of configuration 3 above its upper limit 3.615
expect_error('kincal:outOfLimits', @() gateway('check_limits', r, q), 'joint 2');
expect_error('kincal:outOfLimits', @() gateway('check_limits', r, q), 'column 3 of q');
expect_error('kincal:outOfLimits', @() gateway('check_limits', r, q), 'value 3.7');
expect_error('kincal:indexOutOfRange', ...
    @() gateway('robot_set', r, 'length_param', [7, 1]), '1..6');
s = gateway('robot_set', r, 'length_param', [6, 1]);
expect_true(s.length_param(6) == 1, 'link 6 (1-based) is the last one');
end

function status_table()
[codes, ids, texts] = gateway('status_table');
expect_true(numel(codes) >= 20, 'the library knows %d statuses', numel(codes));
expect_true(numel(unique(ids)) == numel(ids), 'status identifiers are unique');
for k = 1:numel(codes)
    name = regexp(texts{k}, '^KINCAL_STATUS_([A-Z_]+):', 'tokens', 'once');
    expect_true(~isempty(name), 'status text "%s"', texts{k});
    parts = lower(strsplit(name{1}, '_'));
    camel = parts{1};
    for p = 2:numel(parts)
        camel = [camel, upper(parts{p}(1)), parts{p}(2:end)]; %#ok<AGROW>
    end
    expect_true(strcmp(ids{k}, ['kincal:' camel]), 'code %d: %s vs %s', codes(k), ids{k}, ...
        camel);
end
expect_true(any(strcmp(ids, 'kincal:badLength')) && any(strcmp(ids, 'kincal:panic')), ...
    'badLength and panic are listed');
expect_true(codes(1) == 0 && strcmp(ids{1}, 'kincal:ok'), 'OK is 0');
end

function wrappers_same_ids()
r = kincal_robot('aria');
expect_error('kincal:badSize', @() kincal_fk(r, zeros(5, 1)));
expect_error('kincal:badClass', @() kincal_fk(r, single(zeros(6, 1))));
expect_error('kincal:nonFinite', @() kincal_fk(r, [0; 0; NaN; 0; 0; 0]));
expect_error('kincal:badClass', @() kincal_fk(struct('a', 1), zeros(6, 1)));
expect_error('kincal:badSize', @() kincal_pose_error(eye(3), eye(4)));
expect_error('kincal:badValue', @() kincal_pose_error(eye(4), eye(4), 'big'));
expect_error('kincal:unknownOption', @() kincal_fk(r, zeros(6, 1), 'aproach', ones(6, 1)));
expect_error('kincal:badValue', @() kincal_robot('aria_fake'));
expect_error('kincal:unknownLabel', @() kincal_param(r, 'zeta_1'));
expect_error('kincal:outOfLimits', @() kincal_check_limits(r, [0; 4; 0; 0; 0; 0]), 'joint 2');
% Edited structs are checked by the gateway behind the wrapper.
bad = r;
bad.params = r.params(1:10);
expect_error('kincal:badSize', @() kincal_fk(bad, zeros(6, 1)));
end

function no_state()
r = aria();
q = [0.3; 0.7; -0.4; 1.1; -0.6; 0.9];
T1 = gateway('fk', r, q, []);
r2 = gateway('param_set', r, 'theta0_4', -0.8);
T2 = gateway('fk', r2, q, []);
T3 = gateway('fk', r, q, []);
expect_true(isequal(T1, T3), 'the same call gives the same bits');
expect_true(max(abs(T1(:) - T2(:))) > 1e-3, 'the robot is the argument, not hidden state');
% After errors the gateway still works (nothing half-set).
try
    gateway('fk', r, NaN(6, 1), []);
catch
end
expect_true(isequal(gateway('fk', r, q, []), T1), 'an error leaves nothing behind');
end

function rust_panic()
% A gateway built with -DKINCAL_TEST_PANIC against the test-panic library (tests/run.sh
% builds it and names it in $KINCAL_PANIC_MEX): the library panics on purpose; the panic is
% caught at the C ABI boundary and arrives as kincal:panic, and the session goes on.
mex_file = getenv('KINCAL_PANIC_MEX');
if isempty(mex_file)
    skip_test('needs the test-panic gateway that tests/run.sh builds ($KINCAL_PANIC_MEX)');
end
[folder, name] = fileparts(mex_file);
addpath(folder);
restore = onCleanup(@() rmpath(folder));
f = str2func(name);
expect_error('kincal:panic', @() f('test_panic'), 'panic');
expect_error('kincal:panic', @() f('test_panic'));
expect_true(ischar(f('version')), 'the gateway still works after two panics');
end
