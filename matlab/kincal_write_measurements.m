function kincal_write_measurements(file, q, T, varargin)
%KINCAL_WRITE_MEASUREMENTS  Write a measurement CSV (spec/measurements.md).
%   KINCAL_WRITE_MEASUREMENTS(FILE, Q, T) writes one row per column of Q (N x M joint
%   readings, rad) with the measured tool pose T(:,:,k) (4 x 4 x M, m) as x, y, z and
%   roll, pitch, yaw (rad). T = [] writes the joint columns only (input for prediction).
%   Options (name-value):
%       'orientation'  'rpy' (default) or 'quaternion' (qw, qx, qy, qz, qw >= 0)
%       'position_only' true: x, y, z without orientation
%       'pose_id'      1 x M cell of labels (or numeric vector)
%       'approach'     N x M approach directions (-1, 0, +1) as s1..sN
%       'temp_c'       1 x M arm temperatures (deg C)
%       'comments'     cell of comment lines written before the header ('# ' added)
%       'extra_names'  1 x K cell of user column names (each starting with extra_) and
%       'extra'        M x K cell of their text cells (no commas, quotes or line breaks)
%   Numbers are written in the shortest decimal form that reads back to the same double,
%   so KINCAL_READ_MEASUREMENTS gives back Q exactly (T up to the rotation conversion).
%
%   Example:
%       [Tt, seed] = kincal_aria_tool();
%       q = kincal_ik(kincal_robot('aria'), Tt, seed);
%       kincal_write_measurements('tool.csv', q, Tt, 'comments', {'robot: aria'});
%
%   See also KINCAL_READ_MEASUREMENTS.
if nargin < 3
    error('kincal:badArgCount', 'kincal_write_measurements takes FILE, Q and T');
end
check_string(file, 'file');
q = check_matrix(q, 'q', NaN, NaN);
[n, m] = size(q);
opts = parse_options(varargin, struct('orientation', 'rpy', 'position_only', false, ...
    'pose_id', [], 'approach', [], 'temp_c', [], 'comments', {{}}, 'extra_names', {{}}, ...
    'extra', {{}}));
check_string(opts.orientation, 'orientation', {'rpy', 'quaternion'});

header = {};
cols = zeros(0, m);
text_cols = {};
if ~isempty(opts.pose_id)
    ids = opts.pose_id;
    if isnumeric(ids)
        ids = arrayfun(@(v) shortest(v), ids(:)', 'UniformOutput', false);
    end
    if ~iscell(ids) || numel(ids) ~= m
        error('kincal:badSize', 'option ''pose_id'' must have %d labels', m);
    end
    text_cols = ids(:);
    header{end + 1} = 'pose_id';
end
header = [header, arrayfun(@(k) sprintf('q%d', k), 1:n, 'UniformOutput', false)];
cols = [cols; q];
if ~isempty(T)
    T = check_poses(T, 'T');
    if size(T, 3) ~= m
        error('kincal:badSize', 'argument ''T'' must be 4x4x%d like q, got 4x4x%d', m, size(T, 3));
    end
    if opts.position_only
        header = [header, {'x', 'y', 'z'}];
        cols = [cols; reshape(T(1:3, 4, :), 3, m)];
    elseif strcmp(opts.orientation, 'rpy')
        header = [header, {'x', 'y', 'z', 'roll', 'pitch', 'yaw'}];
        cols = [cols; kincal_pose_to_xyzrpy(T)];
    else
        header = [header, {'x', 'y', 'z', 'qw', 'qx', 'qy', 'qz'}];
        cols = [cols; kincal_pose_to_pq(T)];
    end
end
if ~isempty(opts.approach)
    cols = [cols; check_matrix(opts.approach, 'approach', n, m)];
    header = [header, arrayfun(@(k) sprintf('s%d', k), 1:n, 'UniformOutput', false)];
end
if ~isempty(opts.temp_c)
    cols = [cols; check_matrix(opts.temp_c, 'temp_c', 1, m)];
    header{end + 1} = 'temp_c';
end

extra = opts.extra;
if ~isempty(opts.extra_names)
    names = opts.extra_names;
    if ~iscell(names) || ~iscell(extra) || size(extra, 1) ~= m || size(extra, 2) ~= numel(names)
        error('kincal:badSize', 'options ''extra_names''/''extra'': %d names need an %dx%d cell', ...
            numel(names), m, numel(names));
    end
    if ~all(strncmp(names, 'extra_', 6))
        error('kincal:badValue', 'user columns must be named extra_*');
    end
    if any(~cellfun(@ischar, extra(:))) || any(~cellfun('isempty', regexp(extra(:), '[,"\r\n]')))
        error('kincal:badValue', 'extra cells must be text without commas, quotes or line breaks');
    end
    header = [header, names(:)'];
else
    extra = cell(m, 0);
end

[fid, msg] = fopen(file, 'w');
if fid < 0
    error('kincal:csv', '%s: cannot write: %s', file, msg);
end
closer = onCleanup(@() fclose(fid));
for k = 1:numel(opts.comments)
    fprintf(fid, '# %s\n', opts.comments{k});
end
fprintf(fid, '%s\n', strjoin(header, ','));
for j = 1:m
    cells = arrayfun(@(v) shortest(v), cols(:, j)', 'UniformOutput', false);
    if ~isempty(text_cols)
        cells = [text_cols(j), cells]; %#ok<AGROW>
    end
    cells = [cells, extra(j, :)]; %#ok<AGROW>
    fprintf(fid, '%s\n', strjoin(cells, ','));
end
end

function s = shortest(v)
% The shortest of %.15g, %.16g, %.17g that reads back to exactly V.
for digits = 15:17
    s = sprintf('%.*g', digits, v);
    if str2double(s) == v
        return
    end
end
end
