function [model, report, geometric] = kincal_diagnose(robot, varargin)
%KINCAL_DIAGNOSE  The sim-to-real gap diagnosis (kincal diagnose): where the residual of the
%   geometric calibration lies, which non-geometric effect causes it, how far the gap
%   shrinks once that effect is modelled (held out).
%   [MODEL, REPORT, GEOMETRIC] = KINCAL_DIAGNOSE(ROBOT, Q, T) or (ROBOT, DATA) diagnoses the
%   measured poses T (4 x 4 x M) at readings Q (N x M) against the robot description ROBOT
%   (nominal geometry, mass model; effect parameters zero). MODEL is the verdict's model
%   (geometry + effects) fitted on all rows, GEOMETRIC the geometric calibration.
%   Options (name-value):
%       'groups'        1 x M pose ids: repeats of one pose share an id (default: every
%                       pose its own group; then the noise must be stated)
%       'sigma_pos_m', 'sigma_rot_rad'  stated noise, 1 sigma per axis (default: from
%                       repeats)
%       'candidates'    cell of effect names (default: every effect whose inputs the rows
%                       carry), 'pairs' (true), 'folds' (5), 'seed', 'screen_outliers'
%                       (true), 'min_groups_per_fold' (5), 'z_gap', 'z_significance',
%                       'z_equivalence' (3), 'explained_fraction' (0.8),
%                       'partial_fraction' (0.25)
%       'components', 'approach', 'temp_c' as KINCAL_IDENTIFY
%   REPORT has the fields of the CLI's REPORT.json (same names and units: mm and degrees
%   where a name says so): method ('cross_validation' or 'in_sample_nested'), warnings
%   (code, part, ratio, z, ...), suspect_rows (1-based), noise_floor, baseline, candidates,
%   verdict (effects, status, confounded_with, confounded_candidates, gap_closed_fraction,
%   gap_closed_rot_fraction, gap_closed_total_fraction, reason, reason_part, reason_z,
%   reason_effects (for form_not_determined: the effect whose form the data do not
%   determine, REPORT.json's form.effect), beyond_library, beyond_library_share, heldout_rms_pos_mm, heldout_rms_rot_deg,
%   remaining_gap_z[_pos|_rot], remaining_gap_significant, remaining_rms_axis),
%   explainable and remaining_structure (the library-free smooth check), groups, folds.
%   REPORT.json's where, per-pose rows, reason_text, parameters and files are not here
%   (the identified effect parameters are in MODEL). REPORT.json's null is NaN: a component
%   type no pose measures and whose sigma was not stated (position-only data: orientation)
%   has noise_floor.rot_source (pos_source) 'not_measured' and rot_deg, rms_rot_deg, dof_rot
%   NaN; its residual RMS values are 0.
%
%   Example:
%       [model, rep] = kincal_diagnose(kincal_robot('aria'), q, T, 'groups', ids, ...
%           'sigma_pos_m', 1e-4, 'sigma_rot_rad', deg2rad(0.02));
%       rep.verdict.status, rep.verdict.effects
%
%   See also KINCAL_IDENTIFY, KINCAL_EFFECTS.
if nargin < 2
    error('kincal:badArgCount', 'kincal_diagnose takes ROBOT and data');
end
check_robot(robot);
[q, T, components, aux, rest] = measurement_args(robot, varargin, 'kincal_diagnose');
defaults = struct('groups', [], 'sigma_pos_m', [], 'sigma_rot_rad', [], 'candidates', [], ...
    'pairs', [], 'folds', [], 'seed', [], 'screen_outliers', [], 'min_groups_per_fold', [], ...
    'z_gap', [], 'z_significance', [], 'z_equivalence', [], 'explained_fraction', [], ...
    'partial_fraction', []);
o = parse_options(rest, defaults);
opts = struct();
names = fieldnames(defaults);
for k = 2:numel(names)
    if ~isempty(o.(names{k}))
        opts.(names{k}) = o.(names{k});
    end
end
if isempty(fieldnames(opts))
    opts = [];
end
[model, report, geometric] = kincal_mex('diagnose', robot, q, T, components, aux, o.groups, ...
    opts);
end
