function tests = test_csv()
%TEST_CSV  The measurement CSV reader and writer against spec/measurements.md.
tests = {
    'spec_example', @spec_example
    'units_order_and_extras', @units_order_and_extras
    'quaternions', @quaternions
    'write_read_round_trip', @round_trip
    'line_endings_bom_blank_lines', @line_endings
    'rejections_name_file_line_column', @rejections
    };
end

function f = write_file(text)
% A temporary CSV file holding TEXT; the calling test removes it with remove_written.
f = [tempname(tempdir()) '.csv'];
fid = fopen(f, 'w');
fwrite(fid, text);
fclose(fid);
written_files(f);
end

function list = written_files(f)
% The files write_file wrote since the last call without an argument (which returns them).
persistent files
if isempty(files)
    files = {};
end
if nargin > 0
    files{end + 1} = f;
else
    list = files;
    files = {};
end
end

function remove_written()
list = written_files();
for k = 1:numel(list)
    if exist(list{k}, 'file')
        delete(list{k});
    end
end
end

function spec_example()
cleanup = onCleanup(@remove_written); %#ok<NASGU> the files write_file wrote
f = write_file(sprintf(['# robot: aria\n# instrument: motion capture, 0.1 mm\n' ...
    'pose_id,q1,q2,q3,q4,q5,q6,x,y,z,roll_deg,pitch_deg,yaw_deg\n' ...
    '1,0.4813,0.7750,-1.0383,3.6605,1.1053,-2.8499,0.566,0.354,0.235,-150,0,0\n']));
r = kincal_robot('aria');
d = kincal_read_measurements(f, 'robot', r);
expect_true(isequal(d.comments, {'robot: aria', 'instrument: motion capture, 0.1 mm'}), ...
    'comments');
expect_true(d.n_poses == 1 && d.n_joints == 6 && d.line == 4, 'one pose on line 4');
expect_true(strcmp(d.components, 'pose') && strcmp(d.orientation, 'rpy'), 'full pose');
expect_true(isequal(d.pose_id, {'1'}), 'pose_id');
[Tt, ~] = kincal_aria_tool();
expect_near(d.T, Tt(:, :, 1), 1e-15, 'Table 2 pose 1');
% 4-decimal joint values: FK within a fraction of a millimetre of the tool pose.
e = kincal_pose_error(d.T, kincal_fk(r, d.q));
expect_true(norm(e(1:3)) < 1e-4, 'spec example is Table 2 pose 1 on the nominal ARIA');
end

function units_order_and_extras()
cleanup = onCleanup(@remove_written); %#ok<NASGU> the files write_file wrote
rad = write_file(sprintf(['q1,q2,q3,q4,q5,q6,x,y,z,roll,pitch,yaw\n' ...
    '0.1,0.2,0.3,0.4,0.5,0.6,0.5,0.25,0.125,0.5,0.25,-0.5\n']));
deg = write_file(sprintf(['extra_operator,yaw_deg,z_mm,q6_deg,q5,q4,q3,q2,q1_rad,x_m,y,' ...
    'roll_rad,pitch_deg,temp_c\n' ...
    'ann,%.17g,125,%.17g,0.5,0.4,0.3,0.2,0.1,0.5,0.25,0.5,%.17g,21.5\n'], ...
    -0.5 * 180 / pi, 0.6 * 180 / pi, 0.25 * 180 / pi));
a = kincal_read_measurements(rad);
b = kincal_read_measurements(deg);
expect_near(b.q, a.q, 1e-15, 'joint units');
expect_near(b.T, a.T, 1e-15, 'pose units');
expect_true(isequal(b.extra_names, {'extra_operator'}) && isequal(b.extra, {'ann'}), ...
    'extra columns carried');
expect_true(b.temp_c == 21.5, 'temperature');
p = write_file(sprintf('q1,q2,x,y,z\n0.1,0.2,1,2,3\n'));
c = kincal_read_measurements(p);
expect_true(strcmp(c.components, 'position') && isequal(c.T(1:3, 4), [1; 2; 3]), ...
    'position-only data');
j = write_file(sprintf('q2,q1,s2,s1\n0.2,0.1,1,-1\n'));
d = kincal_read_measurements(j);
expect_true(isempty(d.T) && isequal(d.q, [0.1; 0.2]) && isequal(d.approach, [-1; 1]), ...
    'joints only, with approach directions');
end

function quaternions()
cleanup = onCleanup(@remove_written); %#ok<NASGU> the files write_file wrote
[Tt, ~] = kincal_aria_tool();
pq = kincal_pose_to_pq(Tt(:, :, 3));
cells = arrayfun(@(v) sprintf('%.17g', v), [pq(1:3); pq(4:7) * (1 + 5e-7)], ...
    'UniformOutput', false);
f = write_file(sprintf('q1,q2,q3,q4,q5,q6,x,y,z,qw,qx,qy,qz\n0,0,0,0,0,0,%s\n', ...
    strjoin(cells', ',')));
d = kincal_read_measurements(f);
expect_near(d.T, Tt(:, :, 3), 1e-15, 'quaternion within 1e-6 of unit: normalised');
g = write_file(sprintf('q1,q2,q3,q4,q5,q6,x,y,z,qw,qx,qy,qz\n0,0,0,0,0,0,0,0,0,1.001,0,0,0\n'));
expect_error('kincal:csv', @() kincal_read_measurements(g), 'has norm 1.001');
end

function round_trip()
r = kincal_robot('aria');
[Tt, seed] = kincal_aria_tool();
q = kincal_ik(r, Tt, seed);
[f, cleanup] = temp_path('.csv'); %#ok<ASGLU> deleted on return
kincal_write_measurements(f, q, Tt, 'pose_id', 1:10, 'comments', {'robot: aria'});
d = kincal_read_measurements(f, 'robot', r);
expect_true(isequal(d.q, q), 'joint readings bit for bit');
expect_near(d.T, Tt, 1e-15, 'poses through roll, pitch, yaw');
expect_true(isequal(d.pose_id, arrayfun(@num2str, 1:10, 'UniformOutput', false)), 'ids');
kincal_write_measurements(f, q, Tt, 'orientation', 'quaternion', 'approach', ...
    ones(6, 10), 'temp_c', 20 + (1:10));
d = kincal_read_measurements(f);
expect_true(isequal(d.q, q) && isequal(d.approach, ones(6, 10)) && ...
    isequal(d.temp_c, 20 + (1:10)), 'aux columns');
expect_near(d.T, Tt, 1e-15, 'poses through quaternions');
end

function line_endings()
cleanup = onCleanup(@remove_written); %#ok<NASGU> the files write_file wrote
text = sprintf('\xEF\xBB\xBF# c\r\n\r\nq1,q2\r\n0.5,0.25\r\n\r\n0.125,1\r\n\r\n');
d = kincal_read_measurements(write_file(text));
expect_true(isequal(d.q, [0.5 0.125; 0.25 1]) && isequal(d.line, [4 6]), ...
    'CRLF, BOM and blank lines; lines %s', mat2str(d.line));
d = kincal_read_measurements(write_file(sprintf('"q1", q2\n"0.5" , 0.25\n')));
expect_true(isequal(d.q, [0.5; 0.25]), 'quoted cells and spaces');
end

function rejections()
cleanup = onCleanup(@remove_written); %#ok<NASGU> the files write_file wrote
% The messages are kincal-io's, the reader the CLI uses (the toolbox's own .m parser is
% gone): "file:line: column 'name': what was expected".
r = kincal_robot('aria');
h = 'q1,q2,q3,q4,q5,q6,x,y,z,roll,pitch,yaw';
row = '0,0,0,0,0,0,0.5,0,0.3,0,0,0';
cases = {
    '', 'empty file'
    sprintf('# only a comment\n'), 'empty file'
    sprintf('%s\n', h), 'no data rows'
    sprintf('%s,colour\n%s,red\n', h, row), 'column ''colour'': unknown column'
    sprintf('%s,q1_deg\n%s,0\n', h, row), 'column ''q1_deg'': duplicate column'
    sprintf('q1,q2,q3,q5,q6,x,y,z,roll,pitch,yaw\n0,0,0,0,0,0.5,0,0.3,0,0,0\n'), ...
    'column ''q4'': missing required column'
    sprintf('%s,qw,qx,qy,qz\n%s,1,0,0,0\n', h, row), 'both orientation forms'
    sprintf('q1,q2,q3,q4,q5,q6,x,y,z,roll,pitch\n0,0,0,0,0,0,0.5,0,0.3,0,0\n'), ...
    'column ''yaw'': missing column: orientation columns roll, pitch, yaw come together'
    sprintf('%s\n%s\n0,0,abc,0,0,0,0.5,0,0.3,0,0,0\n', h, row), ':3: column ''q3'': expected a number'
    sprintf('%s\n0,0,NaN,0,0,0,0.5,0,0.3,0,0,0\n', h), ':2: column ''q3'': expected a finite'
    sprintf('%s\n0,0,0,0,0,0,Inf,0,0.3,0,0,0\n', h), 'column ''x'': expected a finite'
    sprintf('%s\n0,0,0,0,0,0,,0,0.3,0,0,0\n', h), 'empty cell'
    sprintf('%s\n0,0,0\n', h), ':2: column ''q4'': expected 12 fields as in the header'
    sprintf('%s\n%s\n# late\n', h, row), ':3: comment line after the header'
    sprintf('%s\n0,4,0,0,0,0,0.5,0,0.3,0,0,0\n', h), ':2: column ''q2'': joint 2 reading 4 rad'
    sprintf('%s,q7\n%s,0\n', h, row), 'the robot has 6 joints'
    sprintf('q1,q2,q3,q4,q5,q6,x_cm\n0,0,0,0,0,0,1\n'), 'column ''x_cm'': unknown column'
    sprintf('q1,q2,q3,q4,q5,q6,x_deg,y,z\n0,0,0,0,0,0,1,1,1\n'), '''x'' is a length: expected no unit suffix, _m or _mm'
    sprintf('q1,q2,q3,q4,q5,q6,s1,s2,s3,s4,s5,s6\n0,0,0,0,0,0,0,0,2,0,0,0\n'), ...
    'column ''s3'': expected -1, 0 or 1'
    };
for k = 1:size(cases, 1)
    f = write_file(cases{k, 1});
    expect_error('kincal:csv', @() kincal_read_measurements(f, 'robot', r), cases{k, 2});
    % The file name is in every message.
    expect_error('kincal:csv', @() kincal_read_measurements(f, 'robot', r), f);
end
% Out-of-limits readings are accepted on request.
f = write_file(sprintf('%s\n0,4,0,0,0,0,0.5,0,0.3,0,0,0\n', h));
d = kincal_read_measurements(f, 'robot', r, 'allow_out_of_limits', true);
expect_true(d.q(2) == 4, 'allowed out of limits');
expect_error('kincal:csv', @() kincal_read_measurements(write_file(sprintf('q1\n0\n')), ...
    'require_pose', true), 'measured poses are required');
end
