function require_function(name, export)
%REQUIRE_FUNCTION  Fails with a clear message when the toolbox function NAME is missing
%   because the C ABI export EXPORT has not reached this branch.
if ~exist(name, 'file')
    error('test:pendingExport', ['%s is not available: it needs the C ABI export %s, which ' ...
        'has not reached this branch yet'], name, export);
end
end
