function out = setup_toolbox(name)
%SETUP_TOOLBOX  Puts the toolbox on the path, builds the MEX gateway when it is missing, and
%   returns the output folder of workflow NAME: $KINCAL_OUT/NAME when the environment
%   variable KINCAL_OUT is set, else <repo>/matlab/out/NAME (private to the workflows).
here = fileparts(fileparts(mfilename('fullpath')));   % matlab/workflows
toolbox = fileparts(here);                              % matlab
addpath(toolbox);
if ~exist(fullfile(toolbox, 'private', ['kincal_mex.' mexext()]), 'file')
    make_kincal('all');
end
if exist('OCTAVE_VERSION', 'builtin')
    warning('off', 'Octave:gnuplot-graphics');
end
base = getenv('KINCAL_OUT');
if isempty(base)
    base = fullfile(toolbox, 'out');
end
out = fullfile(base, name);
if ~exist(out, 'dir')
    mkdir(out);
end
fprintf('kincal %s: outputs in %s\n', kincal_version(), out);
end
