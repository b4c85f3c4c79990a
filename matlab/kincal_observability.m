function [indices, sv] = kincal_observability(robot, q, varargin)
%KINCAL_OBSERVABILITY  Observability indices of a set of configurations (Section 3.3).
%   [I, SV] = KINCAL_OBSERVABILITY(ROBOT, Q) takes the singular values SV (descending, p x 1)
%   of the stacked identification Jacobian of ROBOT (normally the nominal model) at the
%   configurations Q (N x M, rad): six rows [dp (m); dphi (rad)] per pose, one column per
%   parameter. Fields of I:
%       o (eq. 17, sigma_min/sigma_max), o1 (Borm-Menq), o2 (inverse condition number),
%       o3 (sigma_min), o4 (sigma_min^2/sigma_max), o5 (1/sigma_max), a_optimality,
%       d_optimality (ln det J'J), sigma_min, sigma_max, poses (M), params (p)
%   Options (name-value):
%       'params'     P x 1 logical mask over robot.params, or [] (default) for the geometric
%                    parameters theta0, a, alpha and d-or-beta of every link
%       'scaling'    'unit' (default: unit-norm columns), 'none', or 'tolerance'
%       'tolerance'  [length_m angle_rad] for 'scaling' 'tolerance'
%
%   Example:
%       [Tt, seed] = kincal_aria_tool();
%       r = kincal_robot('aria');
%       I = kincal_observability(r, kincal_ik(r, Tt, seed));
%       fprintf('O = %.4g\n', I.o);
%
%   See also KINCAL_SELECT_POSES, KINCAL_IDENTIFIABILITY.
if nargin < 2
    error('kincal:badArgCount', 'kincal_observability takes ROBOT and Q');
end
check_robot(robot);
o = parse_options(varargin, struct('params', [], 'scaling', 'unit', 'tolerance', []));
[indices, sv] = kincal_mex('observability', robot, q, o.params, o.scaling, o.tolerance);
end
