function files = kincal_plot_errors(errors, names, varargin)
%KINCAL_PLOT_ERRORS  The paper's 4x4 error figures (Fig. 7/11 layout).
%   FILES = KINCAL_PLOT_ERRORS(ERRORS, NAMES) draws two figures, one for the position error
%   (mm) and one for the orientation error (deg). Columns: the models in NAMES (e.g.
%   {'NOM', 'OLS', 'OPT1', 'OPT2'}); rows: e_x, e_y, e_z and the norm, against the pose
%   index. ERRORS is a cell with one entry per model: the 8 x M per-pose errors of
%   KINCAL_VALIDATE ([e_p (m); e_phi (rad); |e_p|; |e_phi|]) or the 6 x M errors of
%   KINCAL_POSE_ERROR (the norms are then taken here, for the plot only).
%   Options (name-value):
%       'file'      path prefix: writes <file>_position.<fmt> and <file>_orientation.<fmt>
%                   ('' draws on screen and writes nothing; the default)
%       'format'    'png' (default) or 'svg'
%       'visible'   false by default when 'file' is given (headless), else true
%       'title'     text above both figures
%       'target_pos_mm' (1), 'target_rot_deg' (0.66): dashed red line in the norm rows
%   FILES is a 1 x 2 cell of the files written (empty without 'file').
%   Headless use (no display): GNU Octave's gnuplot toolkit prints PNG and SVG from
%   octave-cli; Matlab prints invisible figures the same way.
%
%   Example:
%       kincal_plot_errors({e_nom, e_ols}, {'NOM', 'OLS'}, 'file', 'out/errors');
%
%   See also KINCAL_VALIDATE, KINCAL_POSE_ERROR, KINCAL_PRINT_PARAMS.
if nargin < 2
    error('kincal:badArgCount', 'kincal_plot_errors takes ERRORS and NAMES');
end
if ~iscell(errors) || ~iscell(names) || numel(errors) ~= numel(names) || isempty(errors)
    error('kincal:badClass', 'ERRORS and NAMES must be cells of the same non-zero length');
end
opts = parse_options(varargin, struct('file', '', 'format', 'png', 'visible', [], ...
    'title', '', 'target_pos_mm', 1, 'target_rot_deg', 0.66));
check_string(opts.format, 'format', {'png', 'svg'});
% gnuplot (Octave's toolkit without a display) cannot draw a double quote in a text.
opts.title = strrep(opts.title, '"', '''');
names = strrep(names, '"', '''');
if isempty(opts.visible)
    opts.visible = isempty(opts.file);
end
for k = 1:numel(errors)
    e = errors{k};
    if ~isa(e, 'double') || ~any(size(e, 1) == [6 8])
        error('kincal:badSize', 'ERRORS{%d} must be 6xM or 8xM, got %dx%d', k, size(e, 1), ...
            size(e, 2));
    end
    if size(e, 1) == 6
        % Norms for display only (KINCAL_VALIDATE reports them computed by the library).
        errors{k} = [e; sqrt(sum(e(1:3, :) .^ 2, 1)); sqrt(sum(e(4:6, :) .^ 2, 1))];
    end
end

kinds = struct('name', {'position', 'orientation'}, 'rows', {1:3, 4:6}, ...
    'norm_row', {7, 8}, 'scale', {1000, 180 / pi}, 'unit', {'mm', 'deg'}, ...
    'symbol', {'p', '\phi'}, 'target', {opts.target_pos_mm, opts.target_rot_deg});
files = {};
for kind = kinds
    fig = figure('visible', on_off(opts.visible));
    set(fig, 'PaperUnits', 'inches', 'PaperPosition', [0 0 13 9.5]);
    labels = {['e_{' kind.symbol ',x}'], ['e_{' kind.symbol ',y}'], ...
        ['e_{' kind.symbol ',z}'], ['|e_{' kind.symbol '}|']};
    nm = numel(names);
    for col = 1:nm
        e = errors{col};
        m = size(e, 2);
        rows = [e(kind.rows, :); e(kind.norm_row, :)] * kind.scale;
        for row = 1:4
            ax = subplot(4, nm, (row - 1) * nm + col);
            v = rows(row, :);
            h = stem(1:m, v, 'filled');
            set(h, 'MarkerSize', 3);
            hold on
            % Axes no finer than 1e-6 (mm or deg): gnuplot cannot draw smaller ranges, and
            % the subplot title gives the exact largest value anyway.
            lim = max(max(abs(v)), 1e-6);
            if row == 4
                ylim([0, 1.15 * max(lim, 0)]);
                % The target line where it is visible: errors within 50 times the target.
                if max(v) >= 0.05 * kind.target && max(v) <= 50 * kind.target
                    plot([0.5, m + 0.5], [kind.target, kind.target], 'r--');
                    ylim([0, 1.15 * max(lim, kind.target)]);
                end
            else
                ylim([-1.15 * lim, 1.15 * lim]);
            end
            xlim([0.5, max(m, 1) + 0.5]);
            set(ax, 'FontSize', 8);

            grid on
            set(ax, 'GridLineStyle', ':');
            hold off
            peak = sprintf('max |%s| = %.3g %s', strtok(labels{row}, '|'), max(abs(v)), ...
                kind.unit);
            if row == 1
                % The model's name heads its column (a two-line title loses a line in
                % gnuplot).
                title(sprintf('%s:  %s', names{col}, peak), 'FontSize', 9);
            else
                title(peak, 'FontSize', 8);
            end
            if col == 1
                ylabel(sprintf('%s [%s]', labels{row}, kind.unit));
            end
            if row == 4
                xlabel('pose');
            end
        end
    end
    heading = sprintf('%s error [%s]', kind.name, kind.unit);
    if ~isempty(opts.title)
        heading = [opts.title ': ' heading];
    end
    annotation_title(fig, heading);
    if ~isempty(opts.file)
        out = sprintf('%s_%s.%s', opts.file, kind.name, opts.format);
        folder = fileparts(out);
        if ~isempty(folder) && ~exist(folder, 'dir')
            mkdir(folder);
        end
        print(fig, ['-d' opts.format], '-r100', out);
        files{end + 1} = out; %#ok<AGROW>
    end
    if ~opts.visible
        close(fig);
    end
end
end

function s = on_off(tf)
if tf
    s = 'on';
else
    s = 'off';
end
end

function annotation_title(fig, heading)
% A figure-wide title (sgtitle is missing in Octave 7 and old Matlab).
ax = axes('Parent', fig, 'Position', [0 0.95 1 0.05], 'Visible', 'off');
text(0.5, 0.5, heading, 'Parent', ax, 'HorizontalAlignment', 'center', ...
    'FontWeight', 'bold', 'FontSize', 12);
end
