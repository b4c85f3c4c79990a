function [fitted, report] = kincal_identify_constraints(robot, q, rows, varargin)
%KINCAL_IDENTIFY_CONSTRAINTS  Calibrate without a measuring instrument (docs/constraints.md):
%   from contacts that hold the tool point at targets or on planes, known distances, known
%   targets and planes, and optional partial coordinates.
%   [FITTED, REPORT] = KINCAL_IDENTIFY_CONSTRAINTS(ROBOT, Q, ROWS) fits the parameters of
%   ROBOT to the rows at joint readings Q (N x L, rad). ROWS is a struct of 1 x L fields:
%       target   target of each row, 1..T (0: not a target row)
%       plane    plane of each row, 1..P (0: not a plane row)
%       session  set-up of each row, 1..S (optional; a target or plane lies in one session,
%                a session holds at least 3 rows, instrument rows lie in one session)
%       point    the tool point in the tool frame, 3 x 1 or 3 x L [m] (optional; default
%                the tool-frame origin), e.g. the ball centre
%       coords   measured coordinates of the point in the base frame, 3 x L [m], NaN where
%                not measured (optional; rows with coordinates are instrument rows)
%   Every row is exactly one of a target row, a plane row or an instrument row. The 3
%   coordinates of every unknown target or plane are eliminated, never fitted.
%   Options (name-value): those of KINCAL_IDENTIFY ('algorithm', 'requested', 'effects',
%   'lower', 'upper', 'weights', 'allow_data_deficiency', ...), plus
%       'constraints'  struct with optional fields
%                      n_targets, n_planes  counts (default: the largest ids in ROWS)
%                      known_targets  3 x T known positions [m] (NaN columns: unknown)
%                      known_planes   4 x P [normal; offset_m] (normal.p = offset_m, NaN
%                                     columns: unknown)
%                      distances      K x 3 [a b m] or K x 4 [a b m weight], targets 1-based
%   REPORT: identify (the report of KINCAL_IDENTIFY: analysis, residuals before and after,
%   std_errors, correlations), gauge / gauge_labels (what no row can see: the base frame
%   without an external reference, one length without a length reference), the flags
%   external_reference and length_reference, n_instrument_rows, n_contacts, targets and
%   planes (struct arrays: point, normal, offset_m, contacts, rms_m, max_m, mean_m, aspect at
%   the identified model) and distances_m (predicted, K x 1).
%   Errors name the row: kincal:badGroup (a target with one row, a plane with fewer than
%   3), kincal:degenerateGroup (collinear plane contacts), kincal:badDistance (a distance
%   naming an unknown target), kincal:invalidArgument (a row that is two kinds or none, a
%   target in two sessions), kincal:tooFewData (a session with fewer than 3 rows).
%
%   Example (two sockets 50 mm apart, ball 10 cm out along the tool z axis):
%       rows = struct('target', tid, 'point', [0; 0; 0.1]);
%       cons = struct('distances', [1 2 0.05]);
%       [fit, rep] = kincal_identify_constraints(kincal_robot('aria'), q, rows, ...
%           'constraints', cons, 'allow_data_deficiency', true);
%       rep.gauge_labels      % base_px ... base_rz: no external reference
%
%   See also KINCAL_IDENTIFY, KINCAL_DIAGNOSE.
if nargin < 3
    error('kincal:badArgCount', 'kincal_identify_constraints takes ROBOT, Q and ROWS');
end
check_robot(robot);
q = check_matrix(q, 'q', robot.n_joints, NaN);
if ~isstruct(rows) || ~isscalar(rows)
    error('kincal:badClass', 'kincal_identify_constraints: ROWS must be a 1x1 struct');
end
[opts, rest] = identify_options(robot, varargin, {'constraints'});
[fitted, report] = kincal_mex('identify_constraints', robot, q, rows, rest.constraints, opts);
end
