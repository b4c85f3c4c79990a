function text = kincal_print_params(models, names, varargin)
%KINCAL_PRINT_PARAMS  Print a parameter table of several models side by side.
%   KINCAL_PRINT_PARAMS(MODELS, NAMES) prints one row per parameter and one column per
%   model: MODELS is a cell of robot structs (e.g. nominal, OLS, OPT1, OPT2), NAMES their
%   column titles. Lengths are shown in mm, angles in degrees (the parameter's SI value
%   times 1000 or 180/pi; compliance in deg/(N m), scale in ppm, thermal in ppm/K).
%   Options (name-value):
%       'labels'     cell of parameter labels to show, or a logical mask over
%                    MODELS{1}.params; default: the parameters identified by default
%                    (KINCAL_PARAM_MASK of MODELS{1}) plus every one that differs between
%                    the models
%       'std_errors' cell like MODELS of P x 1 standard errors (SI) or [] per model:
%                    shown as "value (+-se)"
%       'title'      a line printed above the table
%       'fid'        file id to print to (1 = the command window, the default)
%   TEXT = KINCAL_PRINT_PARAMS(...) also returns the table as a char row (with newlines).
%
%   Example:
%       kincal_print_params({kincal_robot('aria'), kincal_robot('aria_true')}, ...
%                           {'NOM', 'TRUE'});
%
%   See also KINCAL_IDENTIFY, KINCAL_PLOT_ERRORS.
if nargin < 2 || ~iscell(models) || ~iscell(names) || numel(models) ~= numel(names)
    error('kincal:badClass', 'MODELS and NAMES must be cells of the same length');
end
for k = 1:numel(models)
    check_robot(models{k});
end
opts = parse_options(varargin, struct('labels', [], 'std_errors', {{}}, 'title', '', ...
    'fid', 1));
labels = models{1}.labels;
if isempty(opts.labels)
    show = kincal_param_mask(models{1});
    for k = 2:numel(models)
        show = show | models{k}.params ~= models{1}.params;
    end
elseif islogical(opts.labels)
    show = opts.labels(:);
else
    show = ismember(labels, opts.labels);
    unknown = setdiff(opts.labels, labels);
    if ~isempty(unknown)
        error('kincal:unknownLabel', 'unknown parameter label ''%s''', unknown{1});
    end
end
rows = find(show);

width = 16;
if ~isempty(opts.std_errors)
    width = 26;
end
out = '';
if ~isempty(opts.title)
    out = sprintf('%s\n', opts.title);
end
out = [out, sprintf('%-14s %-9s', 'parameter', 'unit')];
for k = 1:numel(names)
    out = [out, sprintf(' %*s', width, names{k})]; %#ok<AGROW>
end
out = [out, sprintf('\n%s\n', repmat('-', 1, 24 + (width + 1) * numel(names)))];
for r = rows(:)'
    [scale, unit] = display_unit(labels{r});
    out = [out, sprintf('%-14s %-9s', labels{r}, unit)]; %#ok<AGROW>
    for k = 1:numel(models)
        v = models{k}.params(r) * scale;
        cell = sprintf('%.6f', v);
        if ~isempty(opts.std_errors) && numel(opts.std_errors) >= k && ...
                ~isempty(opts.std_errors{k}) && opts.std_errors{k}(r) > 0
            cell = sprintf('%.6f (+-%.2g)', v, opts.std_errors{k}(r) * scale);
        end
        out = [out, sprintf(' %*s', width, cell)]; %#ok<AGROW>
    end
    out = [out, sprintf('\n')]; %#ok<AGROW,SPRINTFN>
end
fprintf(opts.fid, '%s', out);
if nargout > 0
    text = out;
end
end

function [scale, unit] = display_unit(label)
% Display unit of a parameter from its label (formatting only).
if ~isempty(regexp(label, '^(d|a)_\d+$', 'once')) || ...
        ~isempty(regexp(label, '^(base|tool)_p[xyz]$', 'once'))
    scale = 1000; unit = 'mm';
elseif ~isempty(regexp(label, '^compliance_', 'once'))
    scale = 180 / pi; unit = 'deg/(N m)';
elseif ~isempty(regexp(label, '^scale_', 'once'))
    scale = 1e6; unit = 'ppm';
elseif strcmp(label, 'thermal_kappa')
    scale = 1e6; unit = 'ppm/K';
else
    scale = 180 / pi; unit = 'deg';
end
end
