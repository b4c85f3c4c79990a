function varargout = gateway(varargin)
%GATEWAY  Calls the compiled MEX gateway directly, bypassing the M-side checks of the
%   wrappers, so the tests can check that the gateway validates on its own. The gateway
%   lives in matlab/private (callable only from matlab/); a copy named kincal_mex_direct in
%   a temporary folder on the path is used instead (copied again when that folder is gone).
persistent copy_dir
if isempty(copy_dir) || ~exist(fullfile(copy_dir, ['kincal_mex_direct.' mexext()]), 'file')
    % First call, or the copy went with an earlier test's temporary folder (run_tests gives
    % each test a fresh TMPDIR and removes it afterwards): copy it again for this test.
    if ~isempty(copy_dir)
        clear('kincal_mex_direct');
        if any(strcmp(copy_dir, strsplit(path(), pathsep())))
            rmpath(copy_dir);
        end
    end
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
    copy_dir = dir;
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
