function varargout = gateway(varargin)
%GATEWAY  Calls the compiled MEX gateway directly, bypassing the M-side checks of the
%   wrappers, so the tests can check that the gateway validates on its own. The gateway
%   lives in matlab/private (callable only from matlab/); a copy named kincal_mex_direct in
%   a folder on the path is used instead: run_tests' fixtures folder (outside the tests'
%   sandboxes, removed after the run), else TEMPDIR.
persistent copy_dir
if isempty(copy_dir) || ~exist(fullfile(copy_dir, ['kincal_mex_direct.' mexext()]), 'file')
    % First call, or the copy is gone (an earlier run removed its fixtures): copy it again.
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
    base = getenv('KINCAL_TEST_FIXTURES');   % run_tests' folder for the whole run
    if isempty(base)
        base = tempdir();
    end
    dir = fullfile(base, sprintf('kincal_mex_direct_%d', getpid_or_zero()));
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
