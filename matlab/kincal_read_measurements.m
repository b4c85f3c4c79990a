function data = kincal_read_measurements(file, varargin)
%KINCAL_READ_MEASUREMENTS  Read a measurement CSV (spec/measurements.md).
%   DATA = KINCAL_READ_MEASUREMENTS(FILE) reads one calibration experiment: one measured pose
%   per row. DATA = KINCAL_READ_MEASUREMENTS(FILE, 'robot', ROBOT) also checks the joint
%   count and the joint limits of ROBOT (inclusive; 'allow_out_of_limits', true accepts
%   readings outside them). 'require_pose', true rejects a file without x, y, z.
%
%   The file: UTF-8, comma-separated, '#' comment lines before one header row. Columns are
%   found by name in any order: q1..qN (required), x y z, roll pitch yaw or qw qx qy qz,
%   pose_id, s1..sN, temp_c, and extra_* (carried through). Angles may carry _rad (default)
%   or _deg, lengths _m (default) or _mm: q1_deg, x_mm, roll_deg. Blank lines are skipped.
%   Cells may be double-quoted, but a quoted cell cannot hold a comma or a line break.
%
%   DATA fields (SI units: rad, m):
%       file, comments (cell of the '#' lines), columns (header names as written)
%       n_joints, n_poses, line (1 x M file line of each row)
%       q          N x M joint readings (rad)
%       T          4 x 4 x M measured tool poses in the base frame (m); [] without x, y, z.
%                  With position only the rotation part is the identity and unused.
%       components 'pose' (x, y, z and an orientation), 'position' or 'none'
%       orientation 'rpy', 'quaternion' or '' (the form the file used)
%       pose_id    1 x M cell of labels, or {} ; approach N x M (-1, 0, +1) or [];
%       temp_c     1 x M (deg C) or [] ; extra_names 1 x K cell, extra M x K cell of text
%
%   Every rejection raises kincal:csv with the file, line and column and what was
%   expected: missing or duplicated columns, unknown columns, a non-number, NaN or
%   infinity, a quaternion whose norm is off 1 by more than 1e-6 (within it: normalised),
%   both orientation forms, a joint count that disagrees with ROBOT, a reading outside the
%   limits, an empty file.
%
%   Example:
%       robot = kincal_robot('aria');
%       data = kincal_read_measurements('poses.csv', 'robot', robot);
%       e = kincal_pose_error(data.T, kincal_fk(robot, data.q));
%
%   See also KINCAL_WRITE_MEASUREMENTS, KINCAL_IDENTIFY.
if nargin < 1
    error('kincal:badArgCount', 'kincal_read_measurements takes a file name');
end
check_string(file, 'file');
opts = parse_options(varargin, struct('robot', [], 'allow_out_of_limits', false, ...
    'require_pose', false));
if ~isempty(opts.robot)
    check_robot(opts.robot);
end

[fid, msg] = fopen(file, 'r');
if fid < 0
    error('kincal:csv', '%s: cannot open: %s', file, msg);
end
text = fread(fid, Inf, '*char')';
fclose(fid);
if numel(text) >= 3 && all(double(text(1:3)) == [239 187 191])
    text = text(4:end);   % UTF-8 byte order mark
end
lines = regexp(text, '\r\n|\n|\r', 'split');

% Preamble: comments and blank lines, then the header.
comments = {};
k = 1;
while k <= numel(lines) && (isempty(strtrim(lines{k})) || lines{k}(1) == '#')
    if ~isempty(strtrim(lines{k}))
        comments{end + 1} = strtrim(lines{k}(2:end)); %#ok<AGROW>
    end
    k = k + 1;
end
if k > numel(lines)
    fail(file, [], '', 'empty file: expected a header row (q1..qN, ...) and data rows');
end
header_line = k;
header = split_cells(lines{k}, file, k);
layout = classify_header(header, file, header_line, opts.robot);

% Rows.
rows = {};
row_lines = [];
for k = header_line + 1:numel(lines)
    if isempty(strtrim(lines{k}))
        continue
    end
    if lines{k}(1) == '#'
        fail(file, k, '', ['comment line after the header: comments (''#'') are only ' ...
            'allowed before the header']);
    end
    cells = split_cells(lines{k}, file, k);
    if numel(cells) ~= numel(header)
        fail(file, k, '', sprintf('expected %d cells (one per header column), found %d', ...
            numel(header), numel(cells)));
    end
    rows(end + 1, :) = cells; %#ok<AGROW>
    row_lines(end + 1) = k; %#ok<AGROW>
end
m = numel(row_lines);
if m == 0
    fail(file, header_line, '', 'no data rows after the header');
end
n = layout.n_joints;

data = struct();
data.file = file;
data.comments = comments;
data.columns = header;
data.n_joints = n;
data.n_poses = m;
data.line = row_lines;
data.q = numbers(rows, layout.q, header, layout.scale_q, file, row_lines)';
if ~isempty(opts.robot) && ~opts.allow_out_of_limits
    for j = 1:m
        try
            kincal_check_limits(opts.robot, data.q(:, j));
        catch err
            % The library's message names the joint (1-based): point at its column.
            what = regexprep(err.message, '^(kincal_mex: )?(kincal_check_limits: )?', '');
            joint = regexp(what, 'joint (\d+)', 'tokens', 'once');
            column = '';
            if ~isempty(joint)
                column = header{layout.q(str2double(joint{1}))};
            end
            fail(file, row_lines(j), column, [what ...
                ' (pass ''allow_out_of_limits'', true to accept it)']);
        end
    end
end

data.T = [];
data.components = 'none';
data.orientation = '';
if ~isempty(layout.pos)
    p = numbers(rows, layout.pos, header, layout.scale_pos, file, row_lines)';
    if ~isempty(layout.rpy)
        data.orientation = 'rpy';
        a = numbers(rows, layout.rpy, header, layout.scale_rpy, file, row_lines)';
        data.T = kincal_pose_from_xyzrpy([p; a]);
        data.components = 'pose';
    elseif ~isempty(layout.quat)
        data.orientation = 'quaternion';
        qt = numbers(rows, layout.quat, header, [1 1 1 1], file, row_lines)';
        norms = sqrt(sum(qt .^ 2, 1));
        bad = find(abs(norms - 1) > 1e-6, 1);
        if ~isempty(bad)
            fail(file, row_lines(bad), 'qw', sprintf(['quaternion norm %.17g is not 1 ' ...
                '(tolerance 1e-6)'], norms(bad)));
        end
        data.T = kincal_pose_from_pq([p; qt]);
        data.components = 'pose';
    else
        data.T = kincal_pose_from_xyzrpy([p; zeros(3, m)]);
        data.components = 'position';
    end
elseif opts.require_pose
    fail(file, header_line, 'x', 'measured poses are required: expected columns x, y, z');
end

data.pose_id = {};
if ~isempty(layout.pose_id)
    data.pose_id = strtrim(rows(:, layout.pose_id))';
    empty = find(cellfun('isempty', data.pose_id), 1);
    if ~isempty(empty)
        fail(file, row_lines(empty), 'pose_id', 'expected a pose label, found an empty cell');
    end
end
data.approach = [];
if ~isempty(layout.approach)
    data.approach = numbers(rows, layout.approach, header, ones(1, n), file, row_lines)';
    [r, c] = find(data.approach ~= -1 & data.approach ~= 0 & data.approach ~= 1, 1);
    if ~isempty(r)
        fail(file, row_lines(c), header{layout.approach(r)}, sprintf(['an approach ' ...
            'direction must be -1, 0 or 1, found %.17g'], data.approach(r, c)));
    end
end
data.temp_c = [];
if ~isempty(layout.temp)
    data.temp_c = numbers(rows, layout.temp, header, 1, file, row_lines)';
end
data.extra_names = header(layout.extra);
data.extra = rows(:, layout.extra);
end

function cells = split_cells(line, file, k)
if any(line == '"')
    cells = {};
    rest = line;
    while true
        rest = regexprep(rest, '^\s+', '');
        if ~isempty(rest) && rest(1) == '"'
            close = find(rest(2:end) == '"', 1);
            if isempty(close)
                fail(file, k, '', 'unbalanced double quote');
            end
            cells{end + 1} = rest(2:close); %#ok<AGROW>
            rest = strtrim(rest(close + 2:end));
            if ~isempty(rest) && rest(1) ~= ','
                fail(file, k, '', 'text after a quoted cell');
            end
        else
            comma = find(rest == ',', 1);
            if isempty(comma)
                comma = numel(rest) + 1;
            end
            cells{end + 1} = rest(1:comma - 1); %#ok<AGROW>
            rest = rest(comma:end);
        end
        if isempty(rest)
            break
        end
        rest = rest(2:end);   % the comma
        if isempty(rest)
            cells{end + 1} = ''; %#ok<AGROW>
            break
        end
    end
else
    cells = regexp(line, ',', 'split');
end
cells = strtrim(cells);
end

function layout = classify_header(header, file, line, robot)
layout = struct('q', [], 'scale_q', [], 'pos', [], 'scale_pos', [], 'rpy', [], ...
    'scale_rpy', [], 'quat', [], 'pose_id', [], 'approach', [], 'temp', [], 'extra', []);
joints = [];    % column of q_k at joints(k)
joint_scale = [];
approach = [];
pos = zeros(1, 3); pos_scale = ones(1, 3);
rpy = zeros(1, 3); rpy_scale = ones(1, 3);
quat = zeros(1, 4);
seen = containers.Map();
known = ['known columns: q1..qN, x, y, z, roll, pitch, yaw, qw, qx, qy, qz, pose_id, ' ...
    's1..sN, temp_c, extra_*; units _rad/_deg (angles), _m/_mm (lengths)'];
for i = 1:numel(header)
    name = header{i};
    if isempty(name)
        fail(file, line, sprintf('#%d', i), ['empty column name: ' known]);
    end
    if strncmp(name, 'extra_', 6)
        key = name;
        layout.extra(end + 1) = i;
    else
        [key, kind, unit] = parse_name(name);
        if isempty(kind)
            fail(file, line, name, ['unknown column (prefix user columns with extra_): ' known]);
        end
        if ~isempty(unit) && ~any(strcmp(unit, allowed_units(kind)))
            fail(file, line, name, sprintf('unit _%s is not allowed here (%s)', unit, ...
                strjoin(strcat('_', allowed_units(kind)), ', ')));
        end
        scale = unit_scale(unit);
        switch kind
            case 'joint'
                k = str2double(key(2:end));
                joints(k) = i; %#ok<AGROW>
                joint_scale(k) = scale; %#ok<AGROW>
            case 'approach'
                approach(str2double(key(2:end))) = i; %#ok<AGROW>
            case 'pos'
                a = find(strcmp(key, {'x', 'y', 'z'}));
                pos(a) = i; pos_scale(a) = scale;
            case 'rpy'
                a = find(strcmp(key, {'roll', 'pitch', 'yaw'}));
                rpy(a) = i; rpy_scale(a) = scale;
            case 'quat'
                quat(strcmp(key, {'qw', 'qx', 'qy', 'qz'})) = i;
            case 'pose_id'
                layout.pose_id = i;
            case 'temp'
                layout.temp = i;
        end
    end
    if isKey(seen, key)
        fail(file, line, name, sprintf('duplicate column (same quantity as ''%s'')', ...
            seen(key)));
    end
    seen(key) = name;
end
n = numel(joints);
if ~isempty(robot)
    if n > robot.n_joints
        fail(file, line, sprintf('q%d', n), sprintf(['the robot has %d joints: expected ' ...
            'joint columns q1..q%d only'], robot.n_joints, robot.n_joints));
    end
    n = robot.n_joints;
    joints(end + 1:n) = 0;
    joint_scale(end + 1:n) = 1;
end
if n == 0
    fail(file, line, 'q1', 'missing required column: expected joint columns q1..qN');
end
missing = find(joints == 0, 1);
if ~isempty(missing)
    fail(file, line, sprintf('q%d', missing), sprintf(['missing required column: ' ...
        'expected q1..q%d'], n));
end
layout.n_joints = n;
layout.q = joints;
layout.scale_q = joint_scale;
if ~isempty(approach)
    if numel(approach) > n
        fail(file, line, sprintf('s%d', numel(approach)), sprintf(['expected approach ' ...
            'columns s1..s%d only'], n));
    end
    approach(end + 1:n) = 0;
    missing = find(approach == 0, 1);
    if ~isempty(missing)
        fail(file, line, sprintf('s%d', missing), sprintf(['approach columns come as a ' ...
            'group: expected s1..s%d'], n));
    end
    layout.approach = approach;
end
layout.pos = group(pos, {'x', 'y', 'z'}, file, line);
layout.scale_pos = pos_scale;
layout.rpy = group(rpy, {'roll', 'pitch', 'yaw'}, file, line);
layout.scale_rpy = rpy_scale;
layout.quat = group(quat, {'qw', 'qx', 'qy', 'qz'}, file, line);
if ~isempty(layout.rpy) && ~isempty(layout.quat)
    fail(file, line, 'qw', ['both orientation forms: give roll, pitch, yaw or qw, qx, qy, ' ...
        'qz, not both']);
end
if isempty(layout.pos) && (~isempty(layout.rpy) || ~isempty(layout.quat))
    fail(file, line, 'x', 'an orientation without a position: expected columns x, y, z');
end
end

function cols = group(cols, names, file, line)
if all(cols == 0)
    cols = [];
elseif any(cols == 0)
    missing = names(cols == 0);
    fail(file, line, missing{1}, sprintf('columns %s come as a group: %s is missing', ...
        strjoin(names, ', '), missing{1}));
end
end

function [key, kind, unit] = parse_name(name)
kind = '';
unit = '';
key = name;
tok = regexp(name, '^(.*)_(rad|deg|mm|m)$', 'tokens', 'once');
if ~isempty(tok)
    key = tok{1};
    unit = tok{2};
end
if ~isempty(regexp(key, '^q[1-9][0-9]*$', 'once'))
    kind = 'joint';
elseif ~isempty(regexp(key, '^s[1-9][0-9]*$', 'once'))
    kind = 'approach';
elseif any(strcmp(key, {'x', 'y', 'z'}))
    kind = 'pos';
elseif any(strcmp(key, {'roll', 'pitch', 'yaw'}))
    kind = 'rpy';
elseif any(strcmp(key, {'qw', 'qx', 'qy', 'qz'}))
    kind = 'quat';
elseif strcmp(key, 'pose_id')
    kind = 'pose_id';
elseif strcmp(name, 'temp_c')
    kind = 'temp';
    key = name;
    unit = '';
end
end

function u = allowed_units(kind)
switch kind
    case {'joint', 'rpy'}
        u = {'rad', 'deg'};
    case 'pos'
        u = {'m', 'mm'};
    otherwise
        u = {};
end
end

function s = unit_scale(unit)
switch unit
    case 'deg'
        s = pi / 180;
    case 'mm'
        s = 1e-3;
    otherwise
        s = 1;
end
end

function v = numbers(rows, cols, header, scale, file, row_lines)
% The cells of columns COLS as numbers (M x numel(COLS)), each times its unit scale.
text = rows(:, cols);
v = str2double(text);
bad = ~isfinite(v);
if any(bad(:))
    [r, c] = find(bad, 1);
    cell = text{r, c};
    if isempty(cell)
        what = 'expected a number, found an empty cell';
    elseif isnan(v(r, c)) && isempty(regexpi(cell, '^[+-]?nan$', 'once'))
        what = sprintf('expected a number, found ''%s''', cell);
    else
        what = sprintf('expected a finite number, found ''%s''', cell);
    end
    fail(file, row_lines(r), header{cols(c)}, what);
end
v = v .* repmat(scale(:)', size(v, 1), 1);
end

function fail(file, line, column, what)
where = file;
if ~isempty(line)
    where = sprintf('%s:%d', file, line);
end
if ~isempty(column)
    where = sprintf('%s: column %s', where, column);
end
error('kincal:csv', '%s: %s', where, what);
end
