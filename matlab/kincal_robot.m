function robot = kincal_robot(spec)
%KINCAL_ROBOT  A kincal robot model (modified DH / Hayati) as a plain struct.
%   ROBOT = KINCAL_ROBOT('aria')       the ARIA arm, Table 1 nominal geometry, joint limits of
%                                      eq. (2) (q3 lower limit assumed -pi), assumed masses
%   ROBOT = KINCAL_ROBOT('aria_true')  the paper's virtual "true" robot (Table 3)
%   ROBOT = KINCAL_ROBOT('aria_real')  the real robot identified in the paper (Table 4)
%   ROBOT = KINCAL_ROBOT(TABLE)        a robot from a parameter table, a struct with fields
%       links   N x 5, one row per link: [theta0 (rad), d (m), a (m), alpha (rad), beta (rad)]
%       limits  N x 2, [lower upper] per joint (rad, inclusive)
%     and optionally
%       base    1 x 6 [px py pz rx ry rz], base frame T_0^b (m; rotation vector, rad)
%       tool    1 x 6, tool frame T_e^N in the same form
%       link_masses_kg (N x 1), tool_mass_kg (scalar), gravity (3 x 1, m/s^2)
%       name    a label (informative)
%     Links whose axis is parallel to the next one identify beta, the others d.
%   ROBOT = KINCAL_ROBOT(AXES)         a robot from its joint axes at q = 0, a struct with
%       points      N x 3, a point on each joint axis (m), all in one reference frame
%       directions  N x 3, each axis direction (right-handed positive rotation)
%       limits      N x 2 joint limits (rad)
%     and optionally t_ref_base, t_ref_tool (4 x 4: the base frame and the tool frame at
%     q = 0 in the reference frame) and name. The mDH links, d/beta choices, base and tool
%     frames are computed so that the model's FK equals the axes' product of exponentials.
%   ROBOT = KINCAL_ROBOT(ROBOT)        checks an edited robot struct and refreshes it.
%
%   The struct is the whole model: nothing is kept inside the MEX file between calls, so a
%   robot can be saved, copied and edited like any other variable. Fields:
%       name            label (informative)
%       n_joints        N (1..12)
%       length_param    1 x N: 0 = link identifies d, 1 = link identifies beta
%       joint_kind      1 x N: 0 = revolute, 2 = sensor (a passive revolute joint read
%                       by an inclinometer/accelerometer; IK holds it at its reading),
%                       1 = prismatic (reading and limits in metres;
%                       optional on input, all revolute when absent)
%       params          P x 1 current parameters, P = 12N+13, flat layout: link i in
%                       5(i-1)+(1:5) as [theta0 d a alpha beta]; base (6), tool (6);
%                       compliance (N), scale (N), cyclic (4N), backlash (N), thermal (1)
%       labels          P x 1 cell of parameter labels ('theta0_3', 'beta_2', 'base_px', ...)
%       nominal         (5N+12) x 1 nominal geometry (links, base, tool), same layout
%       limits          N x 2 joint limits [lower upper] (rad; m for prismatic joints)
%       link_masses_kg  N x 1, tool_mass_kg, gravity (3 x 1): the point-mass model used by
%                       the joint-compliance effect
%   Units: metres and radians. Change parameters with KINCAL_PARAM (by label).
%
%   Example:
%       robot = kincal_robot('aria');
%       T = kincal_fk(robot, [0.3; 0.7; -0.4; 1.1; -0.6; 0.9]);
%
%   See also KINCAL_PARAM, KINCAL_FK, KINCAL_IDENTIFY, KINCAL_LOAD_MODEL.
if nargin ~= 1
    error('kincal:badArgCount', 'kincal_robot takes one argument');
end
if ischar(spec)
    robot = kincal_mex('robot_aria', check_string(spec, 'name', {'aria', 'aria_true', 'aria_real'}));
elseif isstruct(spec) && isscalar(spec) && isfield(spec, 'params')
    robot = kincal_mex('robot_check', spec);
elseif isstruct(spec) && isscalar(spec) && isfield(spec, 'points')
    robot = from_axes(spec);
elseif isstruct(spec) && isscalar(spec)
    robot = from_table(spec);
else
    error('kincal:badClass', ['argument ''spec'' must be a robot name, a parameter table ' ...
        'struct or a robot struct, got %s'], class(spec));
end
end

function robot = from_table(t)
known = {'links', 'limits', 'base', 'tool', 'link_masses_kg', 'tool_mass_kg', 'gravity', 'name'};
names = fieldnames(t);
for k = 1:numel(names)
    if ~any(strcmp(names{k}, known))
        error('kincal:unknownField', 'parameter table: unknown field ''%s''; known fields:%s', ...
            names{k}, sprintf(' %s', known{:}));
    end
end
for f = {'links', 'limits'}
    if ~isfield(t, f{1})
        error('kincal:missingField', 'parameter table: field ''%s'' is required', f{1});
    end
end
links = check_matrix(t.links, 'links', NaN, 5);
n = size(links, 1);
limits = check_matrix(t.limits, 'limits', n, 2);
name = 'table';
if isfield(t, 'name')
    name = check_string(t.name, 'name');
end
robot = kincal_mex('robot_init', links, limits, name);
if isfield(t, 'base')
    robot = kincal_mex('robot_set', robot, 'base', check_matrix(t.base(:)', 'base', 1, 6));
end
if isfield(t, 'tool')
    robot = kincal_mex('robot_set', robot, 'tool', check_matrix(t.tool(:)', 'tool', 1, 6));
end
mass_fields = {'link_masses_kg', 'tool_mass_kg', 'gravity'};
given = isfield(t, mass_fields);
if any(given)
    if ~all(given)
        error('kincal:missingField', ['parameter table: the mass model needs all of ' ...
            'link_masses_kg, tool_mass_kg and gravity']);
    end
    mass = struct('link_masses_kg', t.link_masses_kg, 'tool_mass_kg', t.tool_mass_kg, ...
        'gravity', t.gravity);
    robot = kincal_mex('robot_set', robot, 'mass', mass);
end
end

function robot = from_axes(a)
known = {'points', 'directions', 'limits', 't_ref_base', 't_ref_tool', 'name'};
names = fieldnames(a);
for k = 1:numel(names)
    if ~any(strcmp(names{k}, known))
        error('kincal:unknownField', 'axes: unknown field ''%s''; known fields:%s', ...
            names{k}, sprintf(' %s', known{:}));
    end
end
for f = {'points', 'directions', 'limits'}
    if ~isfield(a, f{1})
        error('kincal:missingField', 'axes: field ''%s'' is required', f{1});
    end
end
points = check_matrix(a.points, 'points', NaN, 3);
n = size(points, 1);
directions = check_matrix(a.directions, 'directions', n, 3);
limits = check_matrix(a.limits, 'limits', n, 2);
tb = [];
tt = [];
if isfield(a, 't_ref_base')
    tb = check_matrix(a.t_ref_base, 't_ref_base', 4, 4);
end
if isfield(a, 't_ref_tool')
    tt = check_matrix(a.t_ref_tool, 't_ref_tool', 4, 4);
end
name = 'axes';
if isfield(a, 'name')
    name = check_string(a.name, 'name');
end
robot = kincal_mex('robot_from_axes', points, directions, tb, tt, limits, name);
end
