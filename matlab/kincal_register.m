function [T, info] = kincal_register(design, measured, varargin)
%KINCAL_REGISTER  Pose of a marker body from motion-capture data (Section 5.1).
%   [T, INFO] = KINCAL_REGISTER(DESIGN, MEASURED, 'sigma_m', S) fits the rigid transform T
%   (4 x 4, the body frame in the motion-capture frame) with MEASURED ~ T * DESIGN: DESIGN
%   (M x 3) holds the marker positions in the body frame, MEASURED (M x 3) where the
%   cameras saw them (a row of NaN: not seen), in metres, 3 <= M <= 32. Weighted Horn fit
%   with outlier identification; S is the stated measurement noise (1 sigma per axis, m).
%   Options: 'weights' (M x 1 relative weights), 'k_sigma' (outlier threshold in sigmas,
%   default 4), 'max_outliers' (default 2).
%   INFO: n_used, rms_m, consistent (every used marker within its threshold), ambiguous
%   (another exclusion fits as well with a different pose: T is not determined; do not use
%   it; typical of a ghost marker on a symmetric design), markers
%   (M x 1 struct: predicted_m, residual_m, distance_m, threshold_m, status 'inlier' /
%   'missing' / 'moved' / 'swapped' / 'suspect', swapped_with: the other marker, 1-based).
%   Errors: kincal:tooFewData (fewer than 3 markers used), kincal:rankDeficient (collinear
%   design), argument errors.
%
%   Example (base and end-effector markers to the pose of Section 5.1):
%       Tb = kincal_register(base_design, base_seen, 'sigma_m', 1e-4);
%       Te = kincal_register(probe_design, probe_seen, 'sigma_m', 1e-4);
%       T_base_ee = kincal_t_base_ee(Tb, Te);
%
%   See also KINCAL_T_BASE_EE, KINCAL_WRITE_MEASUREMENTS.
if nargin < 2
    error('kincal:badArgCount', 'kincal_register takes DESIGN, MEASURED and options');
end
design = check_matrix(design, 'design', NaN, 3);
if ~isa(measured, 'double') || ~isreal(measured) || issparse(measured)
    error('kincal:badClass', 'argument ''measured'' must be a real dense double array');
end
if ~isequal(size(measured), size(design))
    error('kincal:badSize', 'argument ''measured'' must be %dx3 like ''design''', ...
        size(design, 1));
end
opts = parse_options(varargin, struct('sigma_m', [], 'weights', [], 'k_sigma', [], ...
    'max_outliers', []));
if isempty(opts.sigma_m)
    error('kincal:missingField', 'option ''sigma_m'' (the measurement noise, m) is required');
end
o = struct('sigma_m', check_matrix(opts.sigma_m, 'sigma_m', 1, 1));
if ~isempty(opts.k_sigma)
    o.k_sigma = opts.k_sigma;
end
if ~isempty(opts.max_outliers)
    o.max_outliers = opts.max_outliers;
end
[T, info] = kincal_mex('register', design, measured, opts.weights, o);
end
