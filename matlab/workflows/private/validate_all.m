function errors = validate_all(models, names, data, title, reports)
%VALIDATE_ALL  Validates every model on DATA (q, T) and prints one summary line per model:
%   RMS and maximum position error [mm] and orientation error [deg], and whether every pose
%   meets the paper's targets (1 mm, 0.66 deg). Returns the per-pose errors (cell of 8 x M)
%   for KINCAL_PLOT_ERRORS (private to the workflows).
%   REPORTS (optional, cell aligned with MODELS, [] where there is none) are identification
%   reports: a model whose fit ended on its OPT1 bounds gets its verdict explained, since
%   its errors then measure the intervals, not the data.
if nargin < 5
    reports = cell(1, numel(models));
end
fprintf('\n%s (%d poses)\n', title, size(data.q, 2));
fprintf('%-6s %12s %12s %13s %13s  %s\n', 'model', 'rms e_p [mm]', 'max e_p [mm]', ...
    'rms e_phi [deg]', 'max e_phi [deg]', 'targets 1 mm / 0.66 deg');
errors = cell(1, numel(models));
notes = {};
for k = 1:numel(models)
    [errors{k}, s] = kincal_validate(models{k}, data);
    verdict = 'met';
    if ~(s.pos_ok && s.rot_ok)
        verdict = 'NOT met';
    end
    n_bound = bound_count(reports, k);
    if n_bound > 0
        verdict = [verdict, ' (ended on its bounds, see below)'];
        notes{end + 1} = sprintf(['%s ended on its bounds (%d identified parameters at ' ...
            'their interval): its intervals exclude the data''s optimum, so its errors ' ...
            'measure the intervals, not the data; widen them (''lower''/''upper'').'], ...
            names{k}, n_bound); %#ok<AGROW>
    end
    fprintf('%-6s %12.4g %12.4g %13.4g %13.4g  %s\n', names{k}, 1000 * s.rms_pos_m, ...
        1000 * s.max_pos_m, s.rms_rot_rad * 180 / pi, s.max_rot_rad * 180 / pi, verdict);
end
fprintf('%s\n', notes{:});
end

function n = bound_count(reports, k)
n = 0;
if k <= numel(reports) && isstruct(reports{k}) && isfield(reports{k}, 'at_bound_labels')
    n = numel(reports{k}.at_bound_labels);
end
end
