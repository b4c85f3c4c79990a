function tests = test_registration()
%TEST_REGISTRATION  Marker registration (Section 5.1) and robots built from joint axes.
tests = {
    'register_recovers_a_pose', @register_pose
    'register_names_missing_and_moved_markers', @register_outliers
    'register_bad_inputs', @register_bad
    'register_flags_an_ambiguous_frame', @register_ambiguous
    't_base_ee', @t_base_ee
    'robot_from_axes_matches_aria', @from_axes
    };
end

function require_registration()
[~, ops] = kincal_version();
if ~any(strcmp(ops, 'register'))
    error('test:pendingExport', 'the gateway has no register operation (C ABI kincal_register)');
end
end

% A cross-shaped probe: four tips and the centre, 5 cm arms, in the body frame [m].
function d = probe()
d = [0.05 0 0; -0.05 0 0; 0 0.05 0; 0 -0.07 0; 0 0 0.02];
end

function m = seen(T, design)
m = (T(1:3, 1:3) * design' + repmat(T(1:3, 4), 1, size(design, 1)))';
end

function register_pose()
require_registration();
T = kincal_pose_from_xyzrpy([1.2; -0.4; 0.9; 0.3; -0.2; 2.1]);
[Tr, info] = kincal_register(probe(), seen(T, probe()), 'sigma_m', 1e-4);
expect_near(Tr, T, 1e-12, 'registered pose');
expect_true(info.n_used == 5 && info.consistent && ~info.ambiguous && info.rms_m < 1e-12, ...
    'fit report');
expect_true(all(strcmp({info.markers.status}, 'inlier')), 'all inliers');
end

function register_outliers()
require_registration();
T = kincal_pose_from_xyzrpy([0.2; 0.1; 1.5; 0; 0.4; -1]);
m = seen(T, probe());
m(2, :) = NaN;                      % marker 2 not seen
m(4, :) = m(4, :) + [0.005 0 0];    % marker 4 moved by 5 mm
[Tr, info] = kincal_register(probe(), m, 'sigma_m', 1e-4);
expect_true(strcmp(info.markers(2).status, 'missing'), 'marker 2 missing');
expect_true(~strcmp(info.markers(4).status, 'inlier'), 'marker 4 flagged: %s', ...
    info.markers(4).status);
expect_true(info.n_used == 3, 'three markers used: %d', info.n_used);
expect_near(Tr, T, 1e-9, 'pose from the good markers');
end

function register_bad()
require_registration();
d = probe();
expect_error('kincal:missingField', @() kincal_register(d, d));
expect_error('kincal:badSize', @() kincal_register(d, d(1:4, :), 'sigma_m', 1e-4));
expect_error('kincal:badSize', @() kincal_register(d(:, 1:2), d(:, 1:2), 'sigma_m', 1e-4));
line = [0 0 0; 1 0 0; 2 0 0; 3 0 0];
expect_error('kincal:rankDeficient', @() kincal_register(line, line, 'sigma_m', 1e-4));
m = d;
m(1:3, :) = NaN;
expect_error('kincal:tooFewData', @() kincal_register(d, m, 'sigma_m', 1e-4));
m = d;
m(1, 1) = Inf;
expect_error('kincal:nonFinite', @() kincal_register(d, m, 'sigma_m', 1e-4), 'marker 1');
expect_error('kincal:invalidParameter', @() kincal_register(d, d, 'sigma_m', -1));
end

function register_ambiguous()
% A rhombus seen with P4 reported where P3 is: excluding P3 or P4 fits equally well, with
% poses 180 degrees apart; the registration says so instead of choosing.
require_registration();
d = [0 0 0; 0.06 0 0; 0.03 0.04 0; 0.03 -0.04 0];
T = kincal_pose_from_xyzrpy([0.2; 0.1; 1.5; 0; 0.4; -1]);
m = seen(T, d);
m(4, :) = m(3, :);
[~, info] = kincal_register(d, m, 'sigma_m', 1e-4);
expect_true(info.consistent && info.ambiguous, 'ambiguous frame flagged');
[~, info] = kincal_register(d, seen(T, d), 'sigma_m', 1e-4);
expect_true(~info.ambiguous, 'a clean frame is not ambiguous');
end

function t_base_ee()
require_registration();
Tb = kincal_pose_from_xyzrpy([0.5; 0.2; -0.1; 0.1; 0.2; 0.3]);
Te = kincal_pose_from_xyzrpy([0.9 1.0; 0.1 -0.3; 0.4 0.5; 2 -1; 0.3 0.2; -0.5 1]);
T = kincal_t_base_ee(Tb, Te);
for k = 1:2
    expect_near(T(:, :, k), Tb \ Te(:, :, k), 1e-14, sprintf('pose %d', k));
end
expect_error('kincal:invalidTransform', @() kincal_t_base_ee(2 * eye(4), eye(4)));
end

function from_axes()
a = kincal_robot('aria_real');
n = a.n_joints;
F = kincal_frames(a, zeros(n, 1));
ax.points = squeeze(F(1:3, 4, 1:n))';       % axis i: origin and z of frame i-1 at q = 0
ax.directions = squeeze(F(1:3, 3, 1:n))';
ax.t_ref_tool = F(:, :, n + 2);
ax.limits = a.limits;
ax.name = 'from_axes';
r = kincal_robot(ax);
expect_true(strcmp(r.name, 'from_axes') && isequal(r.length_param, a.length_param), ...
    'name and d/beta choice');
q = [0.3 0.7 -0.4 1.1 -0.6 0.9; -1 2 0.5 -2 1 3]';
expect_near(kincal_fk(r, q), kincal_fk(a, q), 1e-12, 'FK of the robot built from its axes');
bad = ax;
bad.directions(3, :) = 0;
expect_error('kincal:degenerateAxis', @() kincal_robot(bad), 'joint 3');
bad = ax;
bad.colour = 1;
expect_error('kincal:unknownField', @() kincal_robot(bad));
end
