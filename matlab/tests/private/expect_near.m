function expect_near(actual, expected, tol, what)
%EXPECT_NEAR  Fails unless ACTUAL and EXPECTED have the same size and max |a - e| <= TOL.
if nargin < 4
    what = 'value';
end
if ~isequal(size(actual), size(expected))
    error('test:size', '%s: size %s, expected %s', what, mat2str(size(actual)), ...
        mat2str(size(expected)));
end
d = abs(actual(:) - expected(:));
if any(isnan(d)) || (~isempty(d) && max(d) > tol)
    [worst, k] = max(d);
    error('test:near', '%s: element %d differs by %.3g (tolerance %.3g): %.17g vs %.17g', ...
        what, k, worst, tol, actual(k), expected(k));
end
end
