%WORKFLOW_B_TOOL_DESIGN  Toolbox workflow (b): calibration-tool design and analysis
%   (paper, Sections 4.2-4.4). Compares the poses a calibration tool could hold:
%     - "Table 2": the paper's arbitrary-choice tool, ten poses on a circle;
%     - "clustering": the paper's workspace-clustering design (Section 4.2), by
%       KINCAL_CLUSTER_SELECT: ten candidate poses in ten different cubes of side 0.1 m of
%       the biopsy working region whose per-pose observability is equal within 10 %
%       (the CLI's `select-poses --design clustering`, one core function);
%     - "optimal": ten poses maximising the observability index O, eq. (18), selected
%       by KINCAL_SELECT_POSES from candidates with the tool in the working region.
%   For each design: the identifiability analysis (rank, condition number of the scaled
%   identification Jacobian), OLS / OPT1 / OPT2 from the Table 1 nominal model, the
%   parameter table, and the errors at a common grid of validation poses. The "true" arm
%   is the Table 4 robot plus joint compliance (as in make_example_data.m): its
%   non-geometric errors reach a geometric calibration differently for each design, which
%   is what separates the designs on noise-free data.
%   Figures (PNG): the tool positions of the designs, and per design the 4x4 error figures
%   (position mm, orientation deg; NOM, OLS, OPT1, OPT2) at the validation poses.
%
%   Run:  cd matlab/workflows; workflow_b_tool_design
%   Outputs: $KINCAL_OUT/b_tool_design, default matlab/out/b_tool_design.
%
%   See also WORKFLOW_A_VIRTUAL, WORKFLOW_C_REAL_DATA, KINCAL_IDENTIFIABILITY.

out = setup_toolbox('b_tool_design');
nominal = kincal_robot('aria');
truth = kincal_robot('aria_real');
compliance = [0, 1.5e-4, 1.0e-4, 0.5e-4, 0.5e-4, 0];   % rad/(N m), as make_example_data.m
for j = 1:6
    truth = kincal_param(truth, sprintf('compliance_%d', j), compliance(j));
end
names = {'NOM', 'OLS', 'OPT1', 'OPT2'};
[T_tool, seed] = kincal_aria_tool();

% The designs: target tool poses.
designs = struct('name', {}, 'targets', {});
designs(end + 1) = struct('name', 'Table 2', 'targets', T_tool);
% Optimal poses (eq. 18): candidates inside the joint limits (deterministic, golden-ratio
% sequence) whose tool position lies in the working region, selected on the nominal model.
region = [0.066, 0.566; 0.116, 0.592; 0.235, 0.335];
k = 6000;
u = reshape(mod((1:6 * k)' * 0.6180339887498949, 1), 6, k);
pool = repmat(nominal.limits(:, 1), 1, k) + u .* repmat(diff(nominal.limits, 1, 2), 1, k);
T_pool = kincal_fk(nominal, pool);
p = reshape(T_pool(1:3, 4, :), 3, k);
inside = all(p >= repmat(region(:, 1), 1, k) & p <= repmat(region(:, 2), 1, k), 1);
[q_opt, sel] = kincal_select_poses(nominal, 10, pool(:, inside), 'seed', 1, 'region', region);
% Workspace clustering (Section 4.2) on the same candidates: cubes of 0.1 m of the region
% (5 x 5 x 1), one pose per cube, per-pose singular values within 10 % of a target pose's.
[q_cl, cl] = kincal_cluster_select(nominal, 10, pool(:, inside), 'region', region, ...
    'cube_m', 0.1, 'max_spread', 0.1);
fprintf(['workspace clustering: %d poses in different 0.1 m cubes (%d occupied), per-pose ' ...
    'singular values within %.1f %% of the target''s (ln-ratio %.3f)%s\n'], size(q_cl, 2), ...
    cl.occupied_cubes, (exp(cl.spread) - 1) * 100, cl.spread, ...
    repmat(', above the tolerance: the smallest spread found', 1, ~cl.within_tolerance));
designs(end + 1) = struct('name', 'clustering', 'targets', kincal_fk(nominal, q_cl));
I_t2 = kincal_observability(nominal, kincal_ik(nominal, T_tool, seed));
fprintf('\nobservability O (eq. 17): Table 2 %.4g, optimal %.4g (%d candidates)\n', ...
    I_t2.o, sel.indices.o, nnz(inside));
designs(end + 1) = struct('name', 'optimal', 'targets', kincal_fk(nominal, q_opt));

% Validation poses: the biopsy region above the tool plate, measured on the truth.
targets = region_poses(linspace(0.166, 0.466, 3), linspace(0.204, 0.504, 3), ...
    [0.235, 0.335], [-150, -160]);
[q_val, T_val] = reach(truth, targets, seed);
val = struct('q', q_val, 'T', T_val);

summary = {};
files = {};
for d = 1:numel(designs)
    fprintf('\n(b) design "%s"\n', designs(d).name);
    [q, T] = reach(truth, designs(d).targets, seed);   % the true arm holds the tool poses
    designs(d).reached = T;
    data = struct('q', q, 'T', T);
    a = kincal_identifiability(nominal, data);
    fprintf('%d poses; identifiability: rank %d of %d, condition number %.4g\n', ...
        size(q, 2), a.rank, nnz(a.requested), a.condition_number);
    [models, reports] = calibrate_three(nominal, data, [], []);
    fprintf('\n');
    kincal_print_params(models, names, 'title', sprintf('Identified parameters, design "%s"', ...
        designs(d).name));
    e_val = validate_all(models, names, val, sprintf('Errors at the validation poses, design "%s"', ...
        designs(d).name), [{[]}, reports]);
    [~, s_ols] = kincal_validate(models{2}, val);
    summary(end + 1, :) = {designs(d).name, size(q, 2), a.rank, a.condition_number, ...
        1000 * s_ols.rms_pos_m, 1000 * s_ols.max_pos_m, s_ols.max_rot_rad * 180 / pi}; %#ok<SAGROW>
    tag = regexprep(lower(designs(d).name), '[^a-z0-9]+', '_');
    files = [files, kincal_plot_errors(e_val, names, 'file', ...
        fullfile(out, ['validation_errors_' tag]), 'title', ...
        sprintf('(b) design %s, validation poses', designs(d).name))]; %#ok<AGROW>
end

fprintf('\nDesign comparison (OLS model, %d validation poses)\n', size(val.q, 2));
fprintf('%-10s %6s %5s %10s %13s %13s %15s\n', 'design', 'poses', 'rank', 'cond', ...
    'rms e_p [mm]', 'max e_p [mm]', 'max e_phi [deg]');
for k = 1:size(summary, 1)
    fprintf('%-10s %6d %5d %10.4g %13.4g %13.4g %15.4g\n', summary{k, :});
end

% Where the designs put the tool (positions of the poses the true arm reached).
fig = figure('visible', 'off');
set(fig, 'PaperUnits', 'inches', 'PaperPosition', [0 0 8 6]);
markers = {'o', 's', '^'};
hold on
for d = 1:numel(designs)
    p = reshape(designs(d).reached(1:3, 4, :), 3, []) * 1000;
    plot3(p(1, :), p(2, :), p(3, :), markers{d}, 'MarkerSize', 7, 'LineWidth', 1.5);
end
pv = reshape(val.T(1:3, 4, :), 3, []) * 1000;
plot3(pv(1, :), pv(2, :), pv(3, :), 'k.', 'MarkerSize', 10);
hold off
grid on
view(-35, 30);
xlabel('x [mm]'); ylabel('y [mm]'); zlabel('z [mm]');
legend([{designs.name}, {'validation'}], 'Location', 'eastoutside');
title('(b) tool positions of the designs and the validation poses (base frame)');
files{end + 1} = fullfile(out, 'designs.png');
print(fig, '-dpng', '-r100', files{end});
close(fig);
fprintf('\nfigures:\n%s', sprintf('  %s\n', files{:}));
