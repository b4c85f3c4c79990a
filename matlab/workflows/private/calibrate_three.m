function [models, reports] = calibrate_three(start, data, opt1_lower, opt1_upper)
%CALIBRATE_THREE  OLS, OPT1 and OPT2 from the same start and data (private to the
%   workflows). DATA is a struct with q and T (and components). OPT1 uses the intervals
%   OPT1_LOWER/OPT1_UPPER ([] for the library's default, +-5 mm / +-5 deg). MODELS is
%   {start, OLS, OPT1, OPT2}, REPORTS the three identification reports.
models = {start};
reports = {};
for alg = {'ols', 'opt1', 'opt2'}
    args = {'algorithm', alg{1}};
    if strcmp(alg{1}, 'opt1') && ~isempty(opt1_lower)
        args = [args, {'lower', opt1_lower, 'upper', opt1_upper}]; %#ok<AGROW>
    end
    t0 = tic();
    [fit, rep] = kincal_identify(start, data, args{:});
    fprintf(['  %-4s %3d iterations, %.2f s: rms %.4f mm / %.4f deg -> %.3g mm / %.3g deg' ...
        '%s\n'], upper(alg{1}), rep.iterations, toc(t0), 1000 * rep.initial.rms_pos_m, ...
        rep.initial.rms_rot_rad * 180 / pi, 1000 * rep.fitted.rms_pos_m, ...
        rep.fitted.rms_rot_rad * 180 / pi, at_bound_note(rep));
    models{end + 1} = fit; %#ok<AGROW>
    reports{end + 1} = rep; %#ok<AGROW>
end
end

function s = at_bound_note(rep)
s = '';
if ~isempty(rep.at_bound_labels)
    s = sprintf(' (on a bound: %s)', strjoin(rep.at_bound_labels, ', '));
end
end
