function analysis = kincal_identifiability(robot, varargin)
%KINCAL_IDENTIFIABILITY  What a set of measurements can determine (Section 3.3).
%   A = KINCAL_IDENTIFIABILITY(ROBOT, Q, T) or (ROBOT, DATA) analyses the identification
%   Jacobian at ROBOT for the configurations Q (N x M) and the measured components, without
%   fitting. Fields of A:
%       rank, condition_number (sigma_max/sigma_min of the unit-column-scaled Jacobian of
%       the identifiable parameters), singular_values (descending)
%       requested, identifiable, structural (redundant whatever the poses), data_deficient
%       (identifiable in general but not from these poses): P x 1 logical masks, and the
%       same as label cells (*_labels)
%       partner (P x 1 cell): for a parameter not kept, the kept parameter whose column it
%       aligns with most; partner_cosine the |cos| of that angle
%   The poses enter only through Q (and the components); T sets the number of poses and
%   the measured components. Options as KINCAL_IDENTIFY ('requested', 'effects',
%   'components', 'rank_tol', 'weights', ...).
%
%   Example:
%       [Tt, seed] = kincal_aria_tool();
%       r = kincal_robot('aria');
%       a = kincal_identifiability(r, kincal_ik(r, Tt, seed), Tt);
%       fprintf('rank %d, condition number %.3g\n', a.rank, a.condition_number);
%
%   See also KINCAL_IDENTIFY, KINCAL_JACOBIAN.
if nargin < 2
    error('kincal:badArgCount', 'kincal_identifiability takes ROBOT and data');
end
check_robot(robot);
[q, T, components, aux, rest] = measurement_args(robot, varargin, 'kincal_identifiability');
opts = identify_options(robot, rest, {});
analysis = kincal_mex('identifiability', robot, q, T, components, aux, opts);
end
