function [fitted, report] = kincal_identify(robot, varargin)
%KINCAL_IDENTIFY  Identify the model parameters from measured poses (Sections 3.2-4.1).
%   [FITTED, REPORT] = KINCAL_IDENTIFY(ROBOT, Q, T) fits the parameters of ROBOT (the initial
%   model, e.g. KINCAL_ROBOT('aria')) to the measured tool poses T (4 x 4 x M, base frame, m)
%   at the joint readings Q (N x M, rad): min sum_l |p_meas - p_model|^2 + |phi|^2, phi the
%   rotation vector of R_meas R_model'. FITTED is the identified robot struct.
%   [FITTED, REPORT] = KINCAL_IDENTIFY(ROBOT, DATA) takes a struct from
%   KINCAL_READ_MEASUREMENTS (position-only data fit the position rows only).
%   Options (name-value):
%       'algorithm'  'ols' (default): Gauss-Newton with the minimum-norm step (lsqminnorm);
%                    'opt1': bounded fit inside prior intervals (fmincon in the paper);
%                    'opt2': Levenberg-Marquardt (lsqnonlin)
%       'effects'    cell of effect names identified with the geometry (KINCAL_EFFECTS)
%       'requested'  parameters to identify: a cell of labels or a logical mask over
%                    ROBOT.params (default: theta0, a, alpha, d or beta of every link, plus
%                    the effects' parameters); only the identifiable subset is fitted
%       'lower', 'upper'  OPT1 intervals, P x 1 absolute values (+-Inf allowed); default
%                    +-5 mm on lengths and +-5 deg on angles around ROBOT (paper, Sec. 2.4)
%       'weights'    [w_pos, w_rot] row weights, 1/m^2 and 1/rad^2 (default [1 1])
%       'prior'      [length_m, angle_rad]: Gaussian prior around ROBOT on every link length
%                    and angle (the CLI's --prior; e.g. [5e-3, pi/180]), for any algorithm;
%                    meaningful with whitening weights [1/sigma_pos^2, 1/sigma_rot^2]
%       'prior_sigma' P x 1 prior sigma per parameter (Inf: none), after 'prior'
%       'pose_weights' 1 x M weight of each pose (>= 0; 0 holds a pose out, e.g. for
%                    cross-validation; default all 1)
%       'orientation' 'exact' (default) or 'small_angle' (eq. 16)
%       'max_iterations' (200), 'allow_data_deficiency' (false), 'xtol' (1e-12),
%       'ftol' (1e-14), 'abs_cost_tol' (1e-28), 'rank_tol' (1e-6)
%       'components' 'pose' or 'position', or 1 x M bit masks of [x y z phix phiy phiz]
%       'approach', 'temp_c' as KINCAL_FK
%   REPORT: algorithm, iterations, analysis (rank, condition_number, singular_values,
%   identifiable / structural / data_deficient masks and labels, partner labels and
%   cosines), initial and fitted residual statistics (cost, rms/max position [m] and
%   rotation [rad]), sigma2, std_errors (P x 1, SI), at_bound (OPT1), correlations
%   (pairs with |rho| > 0.95: labels a, b and rho), prior_chi2 and prior_rows (with a prior;
%   std_errors are then the posterior ones).
%   Errors: kincal:rankDeficient when the data leave requested parameters undetermined
%   (see KINCAL_IDENTIFIABILITY, or 'allow_data_deficiency', true), kincal:notConverged,
%   kincal:invalidParameter (OPT1 start outside its interval), argument errors.
%
%   Example (the paper's simulation, Table 3):
%       truth = kincal_robot('aria_true');
%       [Tt, seed] = kincal_aria_tool();
%       q = kincal_ik(truth, Tt, seed);           % the true robot holds the tool poses
%       [fit, rep] = kincal_identify(kincal_robot('aria'), q, Tt, 'algorithm', 'ols');
%       kincal_print_params({kincal_robot('aria'), fit, truth}, {'NOM', 'OLS', 'TRUE'});
%
%   See also KINCAL_IDENTIFIABILITY, KINCAL_VALIDATE, KINCAL_PRINT_PARAMS.
if nargin < 2
    error('kincal:badArgCount', 'kincal_identify takes ROBOT and data');
end
check_robot(robot);
[q, T, components, aux, rest] = measurement_args(robot, varargin, 'kincal_identify');
opts = identify_options(robot, rest, {});
[fitted, report] = kincal_mex('identify', robot, q, T, components, aux, opts);
end
