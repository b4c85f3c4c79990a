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
%   The file is read by the library's reader, the one the CLI uses (kincal-io through the C
%   ABI's kincal_measurements_read), so a file the CLI refuses is refused here with the same
%   message. Every rejection raises kincal:csv with the file, line and column and what was
%   expected: missing or duplicated columns, unknown columns, a non-number, NaN or
%   infinity, a quaternion whose norm is off 1 by more than 1e-6 (within it: normalised),
%   both orientation forms, a joint count that disagrees with ROBOT, a reading outside the
%   limits, an empty file. Files the struct cannot hold are refused too: contact columns
%   (point_x/y/z, target, plane, session) and rows with some of x, y, z empty; the CLI
%   reads those.
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
robot = [];
if ~isempty(opts.robot)
    check_robot(opts.robot);
    robot = opts.robot;
end
% Flags of the C ABI: 1 = KINCAL_READ_ALLOW_OUT_OF_LIMITS, 2 = KINCAL_READ_REQUIRE_POSE.
flags = double(logical(opts.allow_out_of_limits)) + 2 * double(logical(opts.require_pose));
r = kincal_mex('read_measurements', file, robot, flags);

data = struct();
data.file = file;
data.comments = strtrim(r.comments);
if isempty(data.comments)
    data.comments = {};
end
data.columns = r.columns;
data.n_joints = r.n_joints;
data.n_poses = r.n_poses;
data.line = r.line;
data.q = r.q;
data.T = [];
data.components = 'none';
data.orientation = r.orientation;
if r.has_position
    data.T = r.T;
    data.components = 'position';
    if ~isempty(r.orientation)
        data.components = 'pose';
    end
end
data.pose_id = r.pose_id;
if isempty(data.pose_id)
    data.pose_id = {};
end
data.approach = r.approach;
data.temp_c = r.temp_c;
extra = strncmp(r.columns, 'extra_', 6);
data.extra_names = r.columns(extra);
data.extra = r.extra;
end
