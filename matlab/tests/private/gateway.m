function varargout = gateway(varargin)
%GATEWAY  Calls the compiled MEX gateway directly, bypassing the M-side checks of the
%   wrappers, so the tests can check that the gateway validates on its own. The gateway
%   lives in matlab/private (callable only from matlab/); a copy named kincal_mex_direct in
%   a temporary folder on the path is used instead.
persistent ready
if isempty(ready)
    src = fullfile(repo_root(), 'matlab', 'private', ['kincal_mex.' mexext()]);
    if ~exist(src, 'file')
        error('test:noMex', 'the MEX gateway is not built: %s (run make_kincal)', src);
    end
    dir = fullfile(tempdir(), sprintf('kincal_mex_direct_%d', getpid_or_zero()));
    if ~exist(dir, 'dir')
        mkdir(dir);
    end
    copyfile(src, fullfile(dir, ['kincal_mex_direct.' mexext()]));
    addpath(dir);
    ready = true;
end
[varargout{1:nargout}] = kincal_mex_direct(varargin{:});
end

function p = getpid_or_zero()
if exist('getpid', 'builtin') || exist('getpid', 'file')
    p = getpid();
else
    p = feature('getpid');
end
end
