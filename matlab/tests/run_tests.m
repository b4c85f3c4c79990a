function failures = run_tests(varargin)
%RUN_TESTS  Runs the kincal Matlab/Octave tests (plain functions; Matlab and Octave).
%   FAILURES = RUN_TESTS() runs every test of the test_*.m files in this folder and returns
%   the number that failed. Each test_*.m returns a cell of {name, function handle} pairs;
%   a test passes when its handle returns without an error.
%   RUN_TESTS('filter', TEXT) runs only the tests whose "file/name" contains TEXT.
%   RUN_TESTS(..., 'exit', true) ends the interpreter with exit status 1 on a failure and 0
%   otherwise (for CI: octave-cli --eval "run_tests('exit', true)").
%   Each test runs with TEMPDIR (TMPDIR) set to a fresh folder that is removed after it,
%   whatever the test leaves; a test that leaves files there fails all the same (each test
%   removes its own files with onCleanup).
%   A test that cannot run here calls SKIP_TEST (printed as SKIP); when the environment
%   variable CI is "true" a skip counts as a failure.
%
%   Needs the MEX gateway (make_kincal) and, for the CLI cross-checks, the kincal CLI
%   (cargo build --release -p kincal-cli; $KINCAL_CLI overrides its path).
%
%   See also MAKE_KINCAL.
opts = struct('filter', '', 'exit', false);
for k = 1:2:numel(varargin)
    opts.(varargin{k}) = varargin{k + 1};
end
here = fileparts(mfilename('fullpath'));
addpath(fileparts(here));   % the toolbox
addpath(here);
if exist('OCTAVE_VERSION', 'builtin')
    % gnuplot is the toolkit octave-cli has; its "discouraged" notice is not a test result.
    warning('off', 'Octave:gnuplot-graphics');
end

files = dir(fullfile(here, 'test_*.m'));
names = sort({files.name});
failures = 0;
passed = 0;
skipped = 0;
failed = {};
ci = strcmp(getenv('CI'), 'true');
t_all = tic();
% Fixtures that live for the whole run (GATEWAY's copy of the MEX) go in a folder outside
% every test's sandbox, removed when the tests are done.
fixtures = tempname(tempdir());
mkdir(fixtures);
setenv('KINCAL_TEST_FIXTURES', fixtures);
for f = 1:numel(names)
    [~, fname] = fileparts(names{f});
    tests = feval(fname);
    for t = 1:size(tests, 1)
        id = sprintf('%s/%s', fname, tests{t, 1});
        if ~isempty(opts.filter) && isempty(strfind(id, opts.filter))
            continue
        end
        t0 = tic();
        try
            run_in_sandbox(tests{t, 2});
            passed = passed + 1;
            fprintf('PASS  %-60s %6.2f s\n', id, toc(t0));
        catch err
            if strcmp(err.identifier, 'test:skip') && ~ci
                skipped = skipped + 1;
                fprintf('SKIP  %-60s %6.2f s\n      %s\n', id, toc(t0), err.message);
                continue
            end
            failures = failures + 1;
            failed{end + 1} = id; %#ok<AGROW>
            fprintf('FAIL  %-60s %6.2f s\n      %s: %s\n', id, toc(t0), err.identifier, ...
                strrep(err.message, sprintf('\n'), sprintf('\n      ')));
        end
    end
end
release_fixtures(fixtures);
fprintf('\n%d passed, %d failed, %d skipped (%.1f s)\n', passed, failures, skipped, ...
    toc(t_all));
for k = 1:numel(failed)
    fprintf('  failed: %s\n', failed{k});
end
if opts.exit
    exit(double(failures > 0));
end
end

function run_in_sandbox(test)
% Runs TEST with TMPDIR (and so TEMPDIR and TEMPNAME) in a fresh folder; removes the folder
% afterwards (onCleanup: also when the test fails) and fails when the test left files in it.
outer = getenv('TMPDIR');
box = tempname(tempdir());
mkdir(box);
setenv('TMPDIR', box);
restore = onCleanup(@() leave_sandbox(box, outer)); %#ok<NASGU>
test();
left = dir(box);
left = {left(~ismember({left.name}, {'.', '..'})).name};
if ~isempty(left)
    error('test:tempFiles', 'the test left %d temporary file(s): %s', numel(left), ...
        strjoin(left, ', '));
end
end

function release_fixtures(fixtures)
% Unloads and removes the run's fixtures (their folders leave the path first).
clear('kincal_mex_direct');
entries = strsplit(path(), pathsep());
for k = 1:numel(entries)
    if strncmp(entries{k}, fixtures, numel(fixtures))
        rmpath(entries{k});
    end
end
if exist('OCTAVE_VERSION', 'builtin')
    confirm_recursive_rmdir(false, 'local');
end
if exist(fixtures, 'dir')
    rmdir(fixtures, 's');
end
setenv('KINCAL_TEST_FIXTURES', '');
end

function leave_sandbox(box, outer)
setenv('TMPDIR', outer);
if exist('OCTAVE_VERSION', 'builtin')
    confirm_recursive_rmdir(false, 'local');
end
if exist(box, 'dir')
    rmdir(box, 's');
end
end
