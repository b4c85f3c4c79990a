function make_kincal(target)
%MAKE_KINCAL  Build, clean or test the kincal MEX gateway (Matlab and GNU Octave).
%   MAKE_KINCAL or MAKE_KINCAL('all') compiles the one gateway private/kincal_mex.c against
%   the Rust static library into private/kincal_mex.<mexext>, with Matlab's MEX or Octave's
%   MKOCTFILE --mex.
%   MAKE_KINCAL('clean') deletes the compiled gateway.
%   MAKE_KINCAL('test') builds, then runs tests/run_tests.m (errors when a test fails).
%
%   The static library is, in this order:
%     1. the file named by the environment variable KINCAL_LIB, if set;
%     2. <target>/release/libkincal.a, where <target> is $CARGO_TARGET_DIR or <repo>/target;
%     3. built there with "cargo build --release -p kincal-ffi" when missing (an error
%        with identifier kincal:make:noCargo when cargo is not on the PATH).
%   The header is <repo>/include/kincal.h.
%
%   Example (from any directory):
%       run('path/to/kincal/matlab/make_kincal.m')   % or: cd matlab; make_kincal
%       addpath('path/to/kincal/matlab'); help kincal
%
%   Platforms: Linux with GCC is built and tested (Octave 7); Matlab's MEX uses the same
%   arguments plus -R2018a. On Windows the library is kincal.lib (MSVC toolchain) and the
%   system libraries that Rust's standard library needs are added; that path is untested.
%
%   See also KINCAL, MEX, MKOCTFILE.

if nargin < 1
    target = 'all';
end
if ~ischar(target)
    error('kincal:make:unknownTarget', 'make_kincal: the target must be a string');
end

here = fileparts(mfilename('fullpath'));
root = fileparts(here);

switch target
    case 'all'
        build(root, here);
    case 'clean'
        clean(here);
    case 'test'
        build(root, here);
        addpath(here);
        addpath(fullfile(here, 'tests'));
        failures = run_tests();
        if failures > 0
            error('kincal:make:testsFailed', 'make_kincal: %d test(s) failed', failures);
        end
    otherwise
        error('kincal:make:unknownTarget', ...
            'make_kincal: unknown target ''%s'' (use all, clean or test)', target);
end
end

function build(root, here)
lib = find_library(root);
gateway = fullfile(here, 'private', 'kincal_mex.c');
out = fullfile(here, 'private', ['kincal_mex.' mexext()]);
unload();
args = {['-I' fullfile(root, 'include')], '-o', out, gateway, lib};
args = [args, system_libraries()];
% Compile inside private/ so any object files stay next to the source; onCleanup restores
% the caller's directory even when the compiler fails.
old = cd(fullfile(here, 'private'));
restore = onCleanup(@() cd(old));
if is_octave()
    [output, status] = mkoctfile('--mex', args{:});
    if status ~= 0
        error('kincal:make:buildFailed', 'make_kincal: mkoctfile failed:\n%s', output);
    end
else
    mex('-R2018a', args{:});
end
fprintf('make_kincal: built %s\n', out);
end

function clean(here)
unload();
files = dir(fullfile(here, 'private', 'kincal_mex.mex*'));
for k = 1:numel(files)
    delete(fullfile(here, 'private', files(k).name));
    fprintf('make_kincal: removed %s\n', files(k).name);
end
objects = dir(fullfile(here, 'private', '*.o'));
for k = 1:numel(objects)
    delete(fullfile(here, 'private', objects(k).name));
end
end

function lib = find_library(root)
lib = getenv('KINCAL_LIB');
if ~isempty(lib)
    if ~exist(lib, 'file')
        error('kincal:make:noLibrary', 'make_kincal: KINCAL_LIB=%s does not exist', lib);
    end
    return
end
target_dir = getenv('CARGO_TARGET_DIR');
if isempty(target_dir)
    target_dir = fullfile(root, 'target');
elseif ~is_absolute(target_dir)
    target_dir = fullfile(root, target_dir);
end
if ispc()
    name = 'kincal.lib';
else
    name = 'libkincal.a';
end
lib = fullfile(target_dir, 'release', name);
if exist(lib, 'file')
    return
end
[status, ~] = system('cargo --version 2>&1');
if status ~= 0
    error('kincal:make:noCargo', ['make_kincal: %s is missing and cargo is not on the PATH; ' ...
        'install Rust (https://rustup.rs) or set KINCAL_LIB to a prebuilt library'], lib);
end
fprintf('make_kincal: building the Rust library (cargo build --release -p kincal-ffi)\n');
old = cd(root);
restore = onCleanup(@() cd(old));
status = system('cargo build --release -p kincal-ffi');
if status ~= 0 || ~exist(lib, 'file')
    error('kincal:make:cargoFailed', 'make_kincal: cargo build --release -p kincal-ffi failed');
end
end

function libs = system_libraries()
% What Rust's standard library needs from the system in a static link (rustc
% --print native-static-libs); Octave links most of them already, Matlab's MEX may not.
if ispc()
    libs = {'-lws2_32', '-luserenv', '-lbcrypt', '-lntdll', '-ladvapi32', '-lkernel32'};
elseif ismac()
    libs = {'-lSystem', '-lc', '-lm'};
else
    libs = {'-lpthread', '-ldl', '-lm'};
end
end

function unload()
% A loaded MEX file must be released before it is overwritten or deleted.
clear('kincal_mex');
if is_octave()
    clear('-f');
end
end

function tf = is_octave()
tf = exist('OCTAVE_VERSION', 'builtin') ~= 0;
end

function tf = is_absolute(p)
tf = ~isempty(p) && (p(1) == '/' || p(1) == '\' || (numel(p) > 1 && p(2) == ':'));
end
