function root = repo_root()
%REPO_ROOT  The repository root (two levels above this folder's parent).
root = fileparts(fileparts(fileparts(fileparts(mfilename('fullpath')))));
end
