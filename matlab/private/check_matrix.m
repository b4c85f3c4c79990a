function x = check_matrix(x, name, rows, cols)
%CHECK_MATRIX  M-side check of a numeric argument (private).
%   X = CHECK_MATRIX(X, NAME, ROWS, COLS) raises kincal:badClass unless X is a real dense
%   double array, kincal:badSize unless it is ROWS x COLS (NaN: any size) and
%   kincal:nonFinite unless every element is finite. The identifiers and wording are the
%   gateway's, which checks again (a direct call must not be able to crash it).
if ~isa(x, 'double') || ~isreal(x) || issparse(x)
    error('kincal:badClass', 'argument ''%s'' must be a real dense double array, got %s', ...
        name, describe_class(x));
end
sz = size(x);
if numel(sz) ~= 2 || (~isnan(rows) && sz(1) ~= rows) || (~isnan(cols) && sz(2) ~= cols)
    error('kincal:badSize', 'argument ''%s'' must be %sx%s, got %s', name, dim(rows), ...
        dim(cols), size_string(sz));
end
bad = find(~isfinite(x), 1);
if ~isempty(bad)
    error('kincal:nonFinite', 'argument ''%s'' must be finite: element %d is %g', name, bad, ...
        x(bad));
end
end

function s = dim(n)
if isnan(n)
    s = 'M';
else
    s = sprintf('%d', n);
end
end

function s = size_string(sz)
s = sprintf('%dx', sz);
s = s(1:end-1);
end

function s = describe_class(x)
s = class(x);
if isnumeric(x) && ~isreal(x)
    s = ['complex ' s];
end
if issparse(x)
    s = ['sparse ' s];
end
end
