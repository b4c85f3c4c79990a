function [opts, rest] = identify_options(robot, args, extra_names)
%IDENTIFY_OPTIONS  The identification options struct for the gateway from name-value
%   pairs (private). Names: algorithm, effects, requested (labels or logical mask), lower,
%   upper, max_iterations, allow_data_deficiency, orientation, weights ([w_pos, w_rot]),
%   pose_weights (1 x M), xtol, ftol, abs_cost_tol, rank_tol, prior ([length_m, angle_rad]),
%   prior_sigma (P x 1), plus EXTRA_NAMES returned in REST.
defaults = struct('algorithm', 'ols', 'effects', {{}}, 'requested', [], 'lower', [], ...
    'upper', [], 'max_iterations', [], 'allow_data_deficiency', [], 'orientation', [], ...
    'weights', [], 'pose_weights', [], 'xtol', [], 'ftol', [], 'abs_cost_tol', [], ...
    'rank_tol', [], 'prior', [], 'prior_sigma', []);
for k = 1:numel(extra_names)
    defaults.(extra_names{k}) = [];
end
o = parse_options(args, defaults);
rest = struct();
for k = 1:numel(extra_names)
    rest.(extra_names{k}) = o.(extra_names{k});
end
check_string(o.algorithm, 'algorithm', {'ols', 'opt1', 'opt2'});
opts = struct('algorithm', o.algorithm);
if ~isempty(o.effects)
    opts.effects = o.effects;
end
if ~isempty(o.requested)
    req = o.requested;
    if iscell(req) || ischar(req)
        req = cellstr(req);
        unknown = setdiff(req, robot.labels);
        if ~isempty(unknown)
            error('kincal:unknownLabel', 'requested: unknown parameter label ''%s''', ...
                unknown{1});
        end
        req = ismember(robot.labels, req);
    elseif ~islogical(req)
        error('kincal:badClass', ['option ''requested'' must be a cell of labels or a ' ...
            'logical mask over robot.params']);
    end
    opts.requested = req(:);
end
for f = {'lower', 'upper', 'max_iterations', 'allow_data_deficiency', 'orientation', ...
        'pose_weights', 'xtol', 'ftol', 'abs_cost_tol', 'rank_tol', 'prior', 'prior_sigma'}
    if ~isempty(o.(f{1}))
        opts.(f{1}) = o.(f{1});
    end
end
if ~isempty(o.weights)
    w = check_matrix(o.weights(:)', 'weights', 1, 2);
    opts.weight_pos = w(1);
    opts.weight_rot = w(2);
end
end
