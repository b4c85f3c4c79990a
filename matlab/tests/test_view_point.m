function tests = test_view_point()
%TEST_VIEW_POINT  Where camera poses look (kincal_view_point, C ABI kincal_view_point and
%   kincal_moved_to_point): a known target recovered, the other axes, agreement with the
%   CLI's `kincal observed-point` on the same file, and the bad inputs.
tests = {
    'known_target_recovered', @known_target
    'help_example', @help_example
    'other_axes', @other_axes
    'matches_cli_observed_point', @matches_cli
    'bad_inputs', @bad_inputs
    };
end

% A camera at EYE whose z axis looks at TARGET, rolled by ROLL about that axis.
function T = look_at(eye_, target, roll)
z = (target(:) - eye_(:)) / norm(target(:) - eye_(:));
if abs(z(1)) < 0.9
    h = [1; 0; 0];
else
    h = [0; 1; 0];
end
x = cross(h, z);
x = x / norm(x);
y = cross(z, x);
c = cos(roll);
s = sin(roll);
R = [x y z] * [c -s 0; s c 0; 0 0 1];
T = [R eye_(:); 0 0 0 1];
end

function [T, target, d] = cameras()
target = [1.2; -0.3; 0.4];
eyes = [1.0 0.0 0.8; 1.6 -0.2 0.7; 1.1 -0.7 0.9; 1.3 0.1 0.95; 0.8 -0.4 0.85]';
m = size(eyes, 2);
T = zeros(4, 4, m);
d = zeros(1, m);
for k = 1:m
    T(:, :, k) = look_at(eyes(:, k), target, 0.3 * k);
    d(k) = norm(eyes(:, k) - target);
end
end

function known_target()
[T, target, d] = cameras();
[v, Tat] = kincal_view_point(T);
expect_near(v.point_m, target, 1e-12, 'point');
expect_near(v.mean_distance_m, mean(d), 1e-12, 'mean distance');
expect_near(v.min_distance_m, min(d), 1e-12, 'min distance');
expect_near(v.max_distance_m, max(d), 1e-12, 'max distance');
expect_true(v.miss_rms_m < 1e-12 && v.miss_max_m < 1e-12, 'axes meet: miss %g', v.miss_max_m);
expect_true(v.miss_max_pose >= 1 && v.miss_max_pose <= 5, 'miss_max_pose 1-based');
fields = {'point_m', 'mean_distance_m', 'min_distance_m', 'max_distance_m', 'miss_rms_m', ...
    'miss_max_m', 'miss_max_pose'};
expect_true(isequal(sort(fieldnames(v)), sort(fields(:))), 'fields');
s = v.mean_distance_m;
for k = 1:size(T, 3)
    expect_near(Tat(:, :, k), T(:, :, k) * [eye(3) [0; 0; s]; 0 0 0 1], 1e-14, ...
        sprintf('moved pose %d', k));
end
% One camera's axis offset 3 mm sideways: it misses most, by about that much.
T(1:3, 4, 4) = T(1:3, 4, 4) + 3e-3 * T(1:3, 1, 4);
v = kincal_view_point(T, 'z');
expect_true(v.miss_max_pose == 4, 'pose 4 misses most, got %d', v.miss_max_pose);
expect_true(v.miss_max_m > 1e-3 && v.miss_max_m < 3e-3, 'miss %g', v.miss_max_m);
end

function help_example()
T = zeros(4, 4, 3);
T(:, :, 1) = [0 0 -1 1; 1 0 0 -0.2; 0 -1 0 0.3; 0 0 0 1];
T(:, :, 2) = [1 0 0 0.5; 0 -1 0 -0.2; 0 0 -1 1.3; 0 0 0 1];
T(:, :, 3) = [1 0 0 0.5; 0 0 -1 0.5; 0 1 0 0.3; 0 0 0 1];
v = kincal_view_point(T);
expect_near(v.point_m, [0.5; -0.2; 0.3], 1e-12, 'point');
expect_near([v.min_distance_m v.max_distance_m v.mean_distance_m], [0.5 1 2.2 / 3], 1e-12, ...
    'distances');
end

function other_axes()
[T, target] = cameras();
% The same cameras with x (then y) as the viewing direction: permute the frame's columns.
Px = [0 1 0; 0 0 1; 1 0 0];   % new x = old z, new y = old x, new z = old y
Tx = T;
Ty = T;
for k = 1:size(T, 3)
    Tx(1:3, 1:3, k) = T(1:3, 1:3, k) * Px;
    Ty(1:3, 1:3, k) = T(1:3, 1:3, k) * Px';
end
vx = kincal_view_point(Tx, 'x');
vy = kincal_view_point(Ty, 'y');
expect_near(vx.point_m, target, 1e-12, 'x axis');
expect_near(vy.point_m, target, 1e-12, 'y axis');
end

% The numeric columns of a CSV written by the CLI: header names and an M x K matrix.
function [names, values] = read_csv(file)
lines = strsplit(fileread(file), sprintf('\n'));
lines = lines(~cellfun(@isempty, lines));
lines = lines(~strncmp(lines, '#', 1));
names = strtrim(strsplit(lines{1}, ','));
values = zeros(numel(lines) - 1, numel(names));
for r = 2:numel(lines)
    values(r - 1, :) = str2double(strsplit(lines{r}, ','));
end
end

function matches_cli()
require_cli_command('observed-point');
[T, ~] = cameras();
% Not quite converging: a few millimetres of miss, well under the CLI's 25 % limit.
T(1:3, 4, 2) = T(1:3, 4, 2) + [2e-3; -1e-3; 0];
T(1:3, 4, 5) = T(1:3, 4, 5) + [0; 1.5e-3; 1e-3];
[d, cleanup] = temp_path(); %#ok<ASGLU> removed on return
mkdir(d);
data = fullfile(d, 'cameras.csv');
out = fullfile(d, 'observed.csv');
kincal_write_measurements(data, zeros(6, size(T, 3)), T);
cli('observed-point', data, '--out', out);
% The poses as the CLI read them (the file's rpy), through the toolbox.
m = kincal_read_measurements(data);
[v, Tat] = kincal_view_point(m.T);
[names, values] = read_csv(out);
col = @(n) values(:, strcmp(names, n));
expect_near(col('point_x'), zeros(5, 1), 0, 'point_x');
expect_near(col('point_y'), zeros(5, 1), 0, 'point_y');
expect_near(col('point_z'), repmat(v.mean_distance_m, 5, 1), 1e-12, 's = point_z');
expect_near([col('x') col('y') col('z')], squeeze(Tat(1:3, 4, :))', 1e-12, 'positions');
expect_true(v.miss_max_m > 1e-4, 'the set does not converge exactly: miss %g', v.miss_max_m);
end

function bad_inputs()
[T, ~] = cameras();
expect_error('kincal:badArgCount', @() kincal_view_point());
expect_error('kincal:badSize', @() kincal_view_point(T(1:3, :, :)));
expect_error('kincal:badClass', @() kincal_view_point(single(T)));
Tn = T;
Tn(2, 4, 3) = NaN;
expect_error('kincal:nonFinite', @() kincal_view_point(Tn));
expect_error('kincal:badValue', @() kincal_view_point(T, 'w'));
expect_error('kincal:badClass', @() kincal_view_point(T, 3));
expect_error('kincal:tooFewData', @() kincal_view_point(T(:, :, 1)));
Tb = T;
Tb(1:3, 1:3, 2) = 1.01 * Tb(1:3, 1:3, 2);
expect_error('kincal:invalidTransform', @() kincal_view_point(Tb), 'pose 2');
Tb = T;
Tb(4, 1, 3) = 0.5;
expect_error('kincal:invalidTransform', @() kincal_view_point(Tb), 'pose 3');
P = zeros(4, 4, 3);
for k = 1:3
    P(:, :, k) = look_at([0.1 * k; 0; 1], [0.1 * k; 0; 0], 0.2 * k);
end
expect_error('kincal:rankDeficient', @() kincal_view_point(P));
% The gateway checks on its own too (the wrapper's checks bypassed).
expect_error('kincal:badSize', @() gateway('view_point', zeros(3, 4, 2), 'z'));
expect_error('kincal:badValue', @() gateway('view_point', T, 'xy'));
end
