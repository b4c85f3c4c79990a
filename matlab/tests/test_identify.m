function tests = test_identify()
%TEST_IDENTIFY  Identification, identifiability and validation through the gateway: recovery
%   of known parameters, the options, and bad inputs.
tests = {
    'recovers_the_virtual_truth', @recovers_truth
    'data_struct_equals_arrays', @data_struct
    'requested_subset', @requested_subset
    'opt1_bounds', @opt1_bounds
    'position_only_data', @position_only
    'identifiability_structural_redundancy', @structural
    'too_few_poses', @too_few_poses
    'effects', @effects
    'pose_weights_hold_poses_out', @pose_weights
    'priors_pin_weak_directions', @priors
    'validate_metrics', @validate_metrics
    'biopsy_rotation', @biopsy
    'bad_inputs', @bad_inputs
    };
end

function [q, T] = tool_data(truth)
[Tt, seed] = kincal_aria_tool();
q = kincal_ik(truth, Tt, seed);
T = kincal_fk(truth, q);
end

function require_identify()
[~, ops] = kincal_version();
if ~any(strcmp(ops, 'identify'))
    error('test:pendingExport', ['the gateway has no identify operation: the C ABI it was ' ...
        'built against lacks kincal_identify']);
end
end

function priors()
% A prior through the gateway: counted (prior_rows), vanishing when weak, holding every
% link parameter at the start when overwhelming; bad sizes refused.
require_identify();
nominal = kincal_robot('aria');
truth = kincal_robot('aria_true');
[q, T] = tool_data(truth);
w = [1 / 1e-4^2, 1 / (0.02 * pi / 180)^2];
[plain, rep0] = kincal_identify(nominal, q, T, 'weights', w);
expect_true(rep0.prior_rows == 0 && rep0.prior_chi2 == 0, 'no prior by default');
[~, rep] = kincal_identify(nominal, q, T, 'weights', w, 'prior', [5e-3, pi / 180]);
expect_true(rep.prior_rows == 24 && rep.prior_chi2 > 0, 'prior rows %d', rep.prior_rows);
links = ~cellfun('isempty', regexp(nominal.labels, '^(theta0|d|a|alpha|beta)_\d+$'));
weak = inf(size(nominal.params));
weak(links) = 1e9;
fit = kincal_identify(nominal, q, T, 'weights', w, 'prior_sigma', weak);
expect_near(fit.params, plain.params, 1e-12, 'a vanishing prior');
strong = inf(size(nominal.params));
strong(links) = 1e-12;
fit = kincal_identify(nominal, q, T, 'weights', w, 'prior_sigma', strong);
expect_near(fit.params(links), nominal.params(links), 1e-9, 'an overwhelming prior');
bad = strong;
bad(2) = 0;
expect_error('kincal:invalidArgument', @() kincal_identify(nominal, q, T, 'prior_sigma', bad));
expect_error('kincal:invalidArgument', @() kincal_identify(nominal, q, T, 'prior', [-1, 1]));
expect_error('kincal:nonFinite', @() kincal_identify(nominal, q, T, 'prior', [NaN, 1]));
end

function recovers_truth()
require_identify();
nominal = kincal_robot('aria');
truth = kincal_robot('aria_true');
[q, T] = tool_data(truth);
mask = kincal_param_mask(nominal);
wide = 60 * pi / 180;
is_length = ~cellfun('isempty', regexp(nominal.labels, '^(d|a)_\d+$'));
tol = wide * ones(size(nominal.params));
tol(is_length) = 5e-3;
for alg = {'ols', 'opt1', 'opt2'}
    [fit, rep] = kincal_identify(nominal, q, T, 'algorithm', alg{1}, ...
        'lower', nominal.params - tol, 'upper', nominal.params + tol);
    expect_near(fit.params(mask), truth.params(mask), 1e-9, ['recovered parameters, ' alg{1}]);
    expect_true(rep.fitted.max_pos_m < 1e-10 && rep.fitted.max_rot_rad < 1e-10, ...
        '%s residual %g m', alg{1}, rep.fitted.max_pos_m);
    expect_true(strcmp(rep.algorithm, alg{1}) && rep.iterations > 0, 'report of %s', alg{1});
    expect_true(rep.analysis.rank == 24 && isempty(rep.analysis.data_deficient_labels), 'rank');
    expect_near(fit.nominal, nominal.nominal, 0, 'the nominal geometry stays');
    expect_near(fit.params(~mask), nominal.params(~mask), 0, 'unrequested parameters stay');
end
end

function data_struct()
require_identify();
nominal = kincal_robot('aria');
[q, T] = tool_data(kincal_robot('aria_real'));
[f, cleanup] = temp_path('.csv'); %#ok<ASGLU> deleted on return
kincal_write_measurements(f, q, T);
d = kincal_read_measurements(f, 'robot', nominal);
a = kincal_identify(nominal, q, T);
b = kincal_identify(nominal, d);
expect_near(b.params, a.params, 1e-12, 'identify from a data struct');
end

function requested_subset()
require_identify();
nominal = kincal_robot('aria');
truth = kincal_param(nominal, 'theta0_4', 0.01);
[q, T] = tool_data(truth);
[fit, rep] = kincal_identify(nominal, q, T, 'requested', {'theta0_4'});
expect_near(kincal_param(fit, 'theta0_4'), 0.01, 1e-12, 'theta0_4');
expect_true(isequal(rep.analysis.identifiable_labels, {'theta0_4'}), 'only theta0_4 fitted');
changed = find(fit.params ~= nominal.params);
expect_true(isequal(changed, 16), 'only parameter 16 changed');
expect_error('kincal:unknownLabel', @() kincal_identify(nominal, q, T, 'requested', {'zeta'}));
end

function opt1_bounds()
require_identify();
nominal = kincal_robot('aria');
[q, T] = tool_data(kincal_robot('aria_true'));   % theta0_4 = -0.8 rad, outside +-5 deg
[fit, rep] = kincal_identify(nominal, q, T, 'algorithm', 'opt1');
expect_true(any(strcmp(rep.at_bound_labels, 'theta0_4')), 'theta0_4 ends on its bound');
expect_near(kincal_param(fit, 'theta0_4'), -5 * pi / 180, 1e-12, 'the paper''s 5 deg bound');
expect_true(rep.fitted.rms_pos_m > 1e-3, 'a bounded fit cannot reach the truth');
lower = nominal.params;
upper = nominal.params;
lower(16) = -1;
upper(16) = 1;
[fit2, rep2] = kincal_identify(nominal, q, T, 'algorithm', 'opt1', 'lower', lower, ...
    'upper', upper, 'requested', {'theta0_4'});
expect_true(isempty(rep2.at_bound_labels) && kincal_param(fit2, 'theta0_4') < -0.5, ...
    'explicit intervals are used');
end

function position_only()
require_identify();
nominal = kincal_robot('aria');
truth = kincal_robot('aria_real');
[Tt, seed] = kincal_aria_tool();
targets = cat(3, Tt, Tt);
targets(3, 4, 11:20) = 0.3;   % a second layer of poses
q = kincal_ik(truth, targets, seed);
T = kincal_fk(truth, q);
[fit, rep] = kincal_identify(nominal, q, T, 'components', 'position', ...
    'allow_data_deficiency', true);
expect_true(rep.fitted.rows == 60, 'position rows only: %d', rep.fitted.rows);
% Position rows only. The structural analysis at the nominal model (tool origin on axis 6)
% drops theta0_6 and alpha_6 (and a_5, alpha_5); the truth's a_6 = -1.1 mm makes theta0_6
% matter a little, so the fit stops at a few micrometres rather than at rounding.
e = kincal_pose_error(T, kincal_fk(fit, q));
expect_true(max(max(abs(e(1:3, :)))) < 1e-5, 'positions fitted: %g m', max(max(abs(e(1:3, :)))));
expect_true(rep.fitted.rms_rot_rad == 0 && rep.fitted.rms_pos_m < 1e-5, 'residual statistics');
expect_true(any(strcmp(rep.analysis.structural_labels, 'theta0_6')), ...
    'theta0_6 is redundant for positions at the nominal model');
end

function structural()
require_identify();
nominal = kincal_robot('aria');
[q, T] = tool_data(kincal_robot('aria_true'));
labels = [nominal.labels(kincal_param_mask(nominal)); {'d_2'}];
a = kincal_identifiability(nominal, q, T, 'requested', labels);
expect_true(numel(a.requested_labels) == 25 && a.rank == 24, 'rank %d of 25', a.rank);
% Axes 2 and 3 are parallel: d_2 and d_3 both shift along them, one of the pair is
% redundant and names the other as its partner.
expect_true(numel(a.structural_labels) == 1 && ...
    any(strcmp(a.structural_labels{1}, {'d_2', 'd_3'})), ...
    'one of d_2/d_3 is structurally redundant: %s', strjoin(a.structural_labels, ','));
k = find(a.structural);
expect_true(any(strcmp(a.partner{k}, setdiff({'d_2', 'd_3'}, a.structural_labels))) && ...
    a.partner_cosine(k) > 0.99, 'the redundant parameter names its partner: %s %.3f', ...
    a.partner{k}, a.partner_cosine(k));
expect_true(a.condition_number >= 1 && numel(a.singular_values) == a.rank, 'conditioning');
end

function too_few_poses()
require_identify();
nominal = kincal_robot('aria');
[q, T] = tool_data(kincal_robot('aria_true'));
expect_error('kincal:rankDeficient', @() kincal_identify(nominal, q(:, 1:2), T(:, :, 1:2)));
a = kincal_identifiability(nominal, q(:, 1:2), T(:, :, 1:2));
expect_true(a.rank <= 12 && ~isempty(a.data_deficient_labels), 'deficiency reported');
[~, rep] = kincal_identify(nominal, q(:, 1:2), T(:, :, 1:2), 'allow_data_deficiency', true);
% The identifiable subset is fitted; at its minimum the data test, repeated at the fitted
% model, also finds alpha_4 undetermined (held at its start, the rest refitted).
expect_true(rep.analysis.rank < a.rank, 'rank %d at the fit, %d at the start', ...
    rep.analysis.rank, a.rank);
expect_true(all(ismember(a.data_deficient_labels, rep.analysis.data_deficient_labels)) ...
    && any(strcmp(rep.analysis.data_deficient_labels, 'alpha_4')), ...
    'the start''s data-deficient parameters and alpha_4 held');
end

function effects()
require_identify();
nominal = kincal_robot('aria');
truth = kincal_param(kincal_robot('aria'), 'compliance_2', 2e-4);
truth = kincal_param(truth, 'compliance_3', 1e-4);
[Tt, seed] = kincal_aria_tool();
targets = cat(3, Tt, Tt);
targets(3, 4, 11:20) = 0.32;
q = kincal_ik(truth, targets, seed);
T = kincal_fk(truth, q);
[fit, rep] = kincal_identify(nominal, q, T, 'effects', {'joint_compliance'}, ...
    'allow_data_deficiency', true);
expect_near(kincal_param(fit, 'compliance_2'), 2e-4, 1e-9, 'compliance_2 recovered');
expect_near(kincal_param(fit, 'compliance_3'), 1e-4, 1e-9, 'compliance_3 recovered');
expect_true(any(strcmp(rep.analysis.identifiable_labels, 'compliance_2')), 'reported');
expect_true(isequal(kincal_effects(fit), {'joint_compliance'}), 'the fitted model has it');
end

function pose_weights()
require_identify();
nominal = kincal_robot('aria');
[q, T] = tool_data(kincal_robot('aria_real'));
T(1:3, 4, 3) = T(1:3, 4, 3) + [0.01; 0; 0];   % pose 3 is a 10 mm glitch
w = ones(1, 10);
w(3) = 0;
held = kincal_identify(nominal, q, T, 'pose_weights', w);
clean = kincal_identify(nominal, q(:, [1:2, 4:10]), T(:, :, [1:2, 4:10]));
expect_near(held.params, clean.params, 1e-12, 'weight 0 = the pose left out');
expect_error('kincal:badSize', @() kincal_identify(nominal, q, T, 'pose_weights', w(1:9)));
w(5) = -1;
expect_error('kincal:invalidArgument', @() kincal_identify(nominal, q, T, 'pose_weights', w));
end

function validate_metrics()
require_identify();
nominal = kincal_robot('aria');
[q, T] = tool_data(kincal_robot('aria_real'));
[E, S] = kincal_validate(nominal, q, T);
expect_true(isequal(size(E), [8, 10]), 'errors 8 x M');
expect_near(E(1:6, :), kincal_pose_error(T, kincal_fk(nominal, q)), 1e-15, 'e_p, e_phi');
expect_near(E(7, :), sqrt(sum(E(1:3, :) .^ 2, 1)), 1e-15, '|e_p|');
expect_near(E(8, :), sqrt(sum(E(4:6, :) .^ 2, 1)), 1e-15, '|e_phi|');
expect_near(S.max_pos_m, max(E(7, :)), 0, 'max');
expect_near(S.rms_pos_m, sqrt(mean(E(7, :) .^ 2)), 1e-15, 'rms');
expect_true(S.count == 10 && ~S.pos_ok && ~S.rot_ok, 'the nominal model misses the targets');
[~, S2] = kincal_validate(nominal, q, T, 'targets', [1, 1]);
expect_true(S2.pos_ok && S2.rot_ok, 'loose targets are met');
fit = kincal_identify(nominal, q, T);
[~, S3] = kincal_validate(fit, q, T);
expect_true(S3.pos_ok && S3.rot_ok && S3.max_pos_m < 1e-9, 'the fitted model meets them');
end

function biopsy()
require_identify();
expect_near(kincal_biopsy_rotation(5e-3, sqrt(3) * 1e-3, 0.2) * 180 / pi, 0.66, 5e-3, ...
    'eq. (3) gives 0.66 deg');
expect_near(kincal_biopsy_rotation(5e-3, 1e-3, 0.2), 2 * asin(4e-3 / (2 * sqrt(2) * 0.2)), ...
    1e-15, 'eq. (3) written out');
expect_error('kincal:invalidParameter', @() kincal_biopsy_rotation(5e-3, 6e-3, 0.2));
end

function bad_inputs()
require_identify();
nominal = kincal_robot('aria');
[q, T] = tool_data(kincal_robot('aria_true'));
expect_error('kincal:badSize', @() kincal_identify(nominal, q, T(:, :, 1:9)));
expect_error('kincal:badValue', @() kincal_identify(nominal, q, T, 'algorithm', 'lm'));
expect_error('kincal:unknownOption', @() kincal_identify(nominal, q, T, 'algorthm', 'ols'));
lower = nominal.params - 1;
lower(16) = NaN;
expect_error('kincal:invalidArgument', @() kincal_identify(nominal, q, T, 'algorithm', ...
    'opt1', 'lower', lower, 'upper', nominal.params + 1), 'options.lower');
Tbad = T;
Tbad(1, 1, 4) = 2;
expect_error('kincal:invalidTransform', @() kincal_identify(nominal, q, Tbad), 'pose 4');
r = kincal_robot('aria');
expect_error('kincal:invalidArgument', @() gateway('identify', r, q, T, 100 * ones(1, 10), [], []), ...
    'components');
expect_error('kincal:badValue', @() gateway('identify', r, q, T, 0.5 * ones(1, 10), [], []));
expect_error('kincal:invalidArgument', @() gateway('identify', r, q, T, zeros(1, 10), [], []));
expect_error('kincal:unknownField', @() gateway('identify', r, q, T, [], [], ...
    struct('algo', 'ols')));
expect_error('kincal:badSize', @() gateway('validate', r, q, T, [], [1 2 3]));
expect_error('kincal:invalidArgument', @() gateway('validate', r, q, T, [], [-1 1]));
end
