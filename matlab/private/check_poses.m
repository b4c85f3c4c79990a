function T = check_poses(T, name)
%CHECK_POSES  M-side check of a stack of 4x4 poses, 4x4 or 4x4xM (private).
%   Identifiers as CHECK_MATRIX: kincal:badClass, kincal:badSize, kincal:nonFinite.
if ~isa(T, 'double') || ~isreal(T) || issparse(T)
    error('kincal:badClass', 'argument ''%s'' must be a real dense double array, got %s', ...
        name, class(T));
end
sz = size(T);
if numel(sz) > 3 || sz(1) ~= 4 || sz(2) ~= 4
    s = sprintf('%dx', sz);
    error('kincal:badSize', 'argument ''%s'' must be 4x4 or 4x4xM, got %s', name, s(1:end-1));
end
bad = find(~isfinite(T), 1);
if ~isempty(bad)
    error('kincal:nonFinite', 'argument ''%s'' must be finite: element %d is %g', name, bad, ...
        T(bad));
end
end
