function [p, cleanup] = temp_path(ext)
%TEMP_PATH  A fresh temporary path (TEMPNAME in TEMPDIR, with extension EXT if given) and an
%   onCleanup object that deletes the file or folder there (recursively) when the caller's
%   variable holding it goes out of scope, also when the test fails:
%       [d, cleanup] = temp_path(); mkdir(d);   % removed when the test returns
if nargin < 1
    ext = '';
end
p = [tempname(tempdir()) ext];
cleanup = onCleanup(@() remove_path(p));
end

function remove_path(p)
if exist(p, 'dir')
    if exist('OCTAVE_VERSION', 'builtin')
        confirm_recursive_rmdir(false, 'local');
    end
    rmdir(p, 's');
elseif exist(p, 'file')
    delete(p);
end
end
