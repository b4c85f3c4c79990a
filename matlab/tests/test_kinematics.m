function tests = test_kinematics()
%TEST_KINEMATICS  The wrappers' results against independent computations written here (the
%   tests may compute; the toolbox may not): an M-code FK chain, finite differences, the
%   Table 2 poses and the spec's example row, conversions and robots from tables.
tests = {
    'fk_matches_independent_chain', @fk_independent
    'fk_is_vectorised', @fk_vectorised
    'frames', @frames
    'jacobian_matches_finite_differences', @jacobian_fd
    'ik_reaches_table2_poses', @ik_table2
    'conversions_round_trip', @conversions
    'robot_from_table', @robot_from_table
    'params_by_label', @params_by_label
    'effects_and_masks', @effects_and_masks
    'help_text', @help_text
    };
end

% Independent FK (Section 2.1): A_i = Rz(q_i + theta0_i) Tz(d_i) Tx(a_i) Rx(alpha_i) Ry(beta_i).
function T = fk_reference(links, q)
T = eye(4);
for i = 1:size(links, 1)
    th = q(i) + links(i, 1);
    d = links(i, 2); a = links(i, 3); al = links(i, 4); be = links(i, 5);
    Rz = [cos(th) -sin(th) 0 0; sin(th) cos(th) 0 0; 0 0 1 0; 0 0 0 1];
    Tz = eye(4); Tz(3, 4) = d;
    Tx = eye(4); Tx(1, 4) = a;
    Rx = [1 0 0 0; 0 cos(al) -sin(al) 0; 0 sin(al) cos(al) 0; 0 0 0 1];
    Ry = [cos(be) 0 sin(be) 0; 0 1 0 0; -sin(be) 0 cos(be) 0; 0 0 0 1];
    T = T * Rz * Tz * Tx * Rx * Ry;
end
end

function links = links_of(robot)
links = reshape(robot.params(1:5 * robot.n_joints), 5, robot.n_joints)';
end

function fk_independent()
table1 = [0 0.205 0 pi/2 0; 0 0 0.41 0 0; pi/2 -0.0048 0.03 pi/2 0; 0 0.336 0 -pi/2 0; ...
    0 -0.049 0 pi/2 0; 0 0.202 0 0 0];
qs = [0.3 0.7 -0.4 1.1 -0.6 0.9; -1 2 0.5 -2 1 3; 0 0 0 0 0 0]';
for name = {'aria', 'aria_true', 'aria_real'}
    r = kincal_robot(name{1});
    for k = 1:size(qs, 2)
        expect_near(kincal_fk(r, qs(:, k)), fk_reference(links_of(r), qs(:, k)), 1e-14, ...
            sprintf('FK of %s, configuration %d', name{1}, k));
    end
end
r = kincal_robot('aria');
expect_near(r.params(1:30), reshape(table1', [], 1), 0, 'Table 1 in the nominal robot');
end

function fk_vectorised()
r = kincal_robot('aria_true');
q = [0.3 0.7 -0.4 1.1 -0.6 0.9; -1 2 0.5 -2 1 3; 0.1 0.2 0.3 0.4 0.5 0.6]';
T = kincal_fk(r, q);
expect_true(isequal(size(T), [4 4 3]), 'size of a stack of 3 poses');
for k = 1:3
    expect_true(isequal(T(:, :, k), kincal_fk(r, q(:, k))), 'column %d bit for bit', k);
end
end

function frames()
r = kincal_robot('aria_real');
q = [0.3; 0.7; -0.4; 1.1; -0.6; 0.9];
F = kincal_frames(r, q);
expect_true(isequal(size(F), [4 4 8]), 'N + 2 frames');
expect_near(F(:, :, 1), eye(4), 0, 'base frame');
expect_near(F(:, :, 8), kincal_fk(r, q), 1e-15, 'last frame is the tool');
L = links_of(r);
for i = 1:6
    expect_near(F(:, :, i + 1), fk_reference(L(1:i, :), q(1:i)), 1e-14, ...
        sprintf('frame %d', i));
end
end

function jacobian_fd()
r = kincal_robot('aria_true');
q = [0.3; 0.7; -0.4; 1.1; -0.6; 0.9];
[J, T0] = kincal_jacobian(r, q);
expect_true(isequal(size(J), [6, 5 * 6 + 12]), 'geometric Jacobian is 6 x 42');
expect_near(T0, kincal_fk(r, q), 0, 'pose returned with the Jacobian');
h = 1e-6;
for i = 1:size(J, 2)
    rp = r; rp.params(i) = rp.params(i) + h;
    rm = r; rm.params(i) = rm.params(i) - h;
    % Central difference of [p; phi]: the orientation part through the exact log.
    d = (kincal_pose_error(kincal_fk(rp, q), kincal_fk(rm, q))) / (2 * h);
    expect_near(J(:, i), d, 1e-7, sprintf('Jacobian column %d (%s)', i, r.labels{i}));
end
Jall = kincal_jacobian(r, q, 'columns', 'all');
expect_true(isequal(size(Jall), [6, 12 * 6 + 13]), 'full Jacobian is 6 x 85');
expect_near(Jall(:, 1:42), J, 0, 'geometric block of the full Jacobian');
end

function ik_table2()
[Tt, seed] = kincal_aria_tool();
expect_true(isequal(size(Tt), [4 4 10]) && isequal(size(seed), [6 1]), 'Table 2 sizes');
table2 = [0.566 0.354 -150; 0.518 0.501 -160; 0.393 0.592 -150; 0.238 0.592 -160; ...
    0.113 0.501 -150; 0.066 0.354 -160; 0.113 0.207 -150; 0.238 0.116 -160; ...
    0.393 0.116 -150; 0.518 0.207 -160];
for l = 1:10
    v = [table2(l, 1:2)'; 0.235; table2(l, 3) * pi / 180; 0; 0];
    expect_near(kincal_pose_from_xyzrpy(v), Tt(:, :, l), 1e-15, sprintf('Table 2 pose %d', l));
end
r = kincal_robot('aria');
[q, info] = kincal_ik(r, Tt, seed);
expect_near(kincal_fk(r, q), Tt, 1e-10, 'FK of the IK solutions');
expect_true(numel(info) == 10 && all([info.residual_pos_m] < 1e-10), 'IK residuals');
kincal_check_limits(r, q);
% The example row of spec/measurements.md (joint values rounded to 4 decimals).
expect_near(round(q(:, 1) * 1e4) / 1e4, [0.4813; 0.7750; -1.0383; 3.6605; 1.1053; -2.8499], ...
    1e-12, 'spec example row');
end

function conversions()
v = [0.1 -0.2; 0.3 0.4; 0.5 0.6; 0.7 -2.9; -0.4 1.2; 2.5 -3.0];
T = kincal_pose_from_xyzrpy(v);
expect_near(kincal_pose_to_xyzrpy(T), v, 1e-14, 'xyzrpy round trip');
% R = Rz(yaw) Ry(pitch) Rx(roll), written out here.
for k = 1:2
    c = cos(v(4:6, k)); s = sin(v(4:6, k));
    Rx = [1 0 0; 0 c(1) -s(1); 0 s(1) c(1)];
    Ry = [c(2) 0 s(2); 0 1 0; -s(2) 0 c(2)];
    Rz = [c(3) -s(3) 0; s(3) c(3) 0; 0 0 1];
    expect_near(T(1:3, 1:3, k), Rz * Ry * Rx, 1e-15, 'rpy convention');
end
pq = kincal_pose_to_pq(T);
expect_true(all(pq(4, :) >= 0), 'qw >= 0');
expect_near(sum(pq(4:7, :) .^ 2, 1), [1 1], 1e-15, 'unit quaternions');
expect_near(kincal_pose_from_pq(pq), T, 1e-15, 'pq round trip');
% Quaternions are normalised on the way in.
expect_near(kincal_pose_from_pq([pq(1:3, 1); 2 * pq(4:7, 1)]), T(:, :, 1), 1e-15, 'normalised');
% Small-angle vs exact orientation error: equal to first order.
T2 = kincal_pose_from_xyzrpy(v(:, 1) + [0; 0; 0; 1e-4; -2e-4; 3e-4]);
e_exact = kincal_pose_error(T2, T(:, :, 1));
e_small = kincal_pose_error(T2, T(:, :, 1), 'small_angle');
expect_near(e_small, e_exact, 1e-7, 'small-angle error close to the exact one');
end

function robot_from_table()
t.links = [0 0.205 0 pi/2 0; 0 0 0.41 0 0; pi/2 -0.0048 0.03 pi/2 0; 0 0.336 0 -pi/2 0; ...
    0 -0.049 0 pi/2 0; 0 0.202 0 0 0];
t.limits = [-2*pi 2*pi; -0.97 3.615; -pi 1.69; -2*pi 2*pi; -pi pi; -2*pi 2*pi];
t.name = 'my_aria';
r = kincal_robot(t);
a = kincal_robot('aria');
expect_true(strcmp(r.name, 'my_aria'), 'name kept');
expect_true(isequal(r.length_param, a.length_param), 'beta chosen for the parallel axes 2-3');
q = [0.3; 0.7; -0.4; 1.1; -0.6; 0.9];
expect_near(kincal_fk(r, q), kincal_fk(a, q), 1e-15, 'FK of the table robot');
t.base = [0.1 0 0 0 0 pi/2];
t.tool = [0 0 0.05 0 0 0];
t.link_masses_kg = [1.6; 2.2; 1.4; 1.2; 0.7; 0.4];
t.tool_mass_kg = 0.3;
t.gravity = [0; 0; -9.81];
r2 = kincal_robot(t);
Tb = kincal_pose_from_xyzrpy([0.1; 0; 0; 0; 0; pi/2]);
Tt = eye(4); Tt(3, 4) = 0.05;
expect_near(kincal_fk(r2, q), Tb * kincal_fk(a, q) * Tt, 1e-15, 'base and tool frames');
t3 = rmfield(t, 'base');
expect_near(kincal_gravity_torques(r2, q), kincal_gravity_torques(kincal_robot(t3), q), ...
    1e-12, 'gravity torques do not change with a base shift and yaw about the gravity axis');
expect_error('kincal:missingField', @() kincal_robot(rmfield(t, 'limits')));
expect_error('kincal:missingField', @() kincal_robot(rmfield(t, 'gravity')));
t.colour = 'red';
expect_error('kincal:unknownField', @() kincal_robot(t));
% A robot struct goes through kincal_robot unchanged.
expect_true(isequal(kincal_robot(a), a), 'robot struct round trip');
end

function params_by_label()
r = kincal_robot('aria');
expect_near(kincal_param(r, 'd_4'), 0.336, 0, 'd_4');
r2 = kincal_param(r, 'd_4', 0.34);
expect_near(kincal_param(r2, 'd_4'), 0.34, 0, 'd_4 set');
expect_near(r2.nominal(17), 0.336, 0, 'nominal unchanged');
expect_true(strcmp(r.labels{17}, 'd_4') && strcmp(r.labels{10}, 'beta_2'), 'labels');
end

function effects_and_masks()
names = kincal_effects();
expect_true(all(ismember({'base_frame', 'tool_frame', 'joint_compliance', 'joint_scale', ...
    'joint_cyclic', 'backlash', 'thermal'}, names)), 'effect names');
r = kincal_robot('aria');
m = kincal_param_mask(r);
expect_true(nnz(m) == 24, '4 geometric parameters per link: %d', nnz(m));
expect_true(m(10) && ~m(7), 'link 2 identifies beta, not d');
mc = kincal_param_mask(r, {'joint_compliance'});
expect_true(nnz(mc) == 30 && all(mc(43:48)), 'compliance adds 6');
expect_true(isempty(kincal_effects(r)), 'the nominal robot has no active effect');
rc = kincal_param(r, 'compliance_2', 1e-4);
expect_true(isequal(kincal_effects(rc), {'joint_compliance'}), 'compliance is active');
q = [0.3; 0.7; -0.4; 1.1; -0.6; 0.9];
theta = kincal_joint_angles(rc, q);
tau = kincal_gravity_torques(rc, q);
expect_near(theta - q, [0; 1e-4 * tau(2); 0; 0; 0; 0], 1e-15, 'compliance moves joint 2');
end

function help_text()
for f = {'kincal_robot', 'kincal_fk', 'kincal_ik', 'kincal_jacobian', ...
        'kincal_pose_error', 'kincal_read_measurements', 'make_kincal'}
    text = help(f{1});
    expect_true(~isempty(strfind(upper(text), upper(f{1}))) && numel(text) > 200, ...
        'help %s', f{1});
end
end
