function d = target_dir()
%TARGET_DIR  Cargo's target directory: $CARGO_TARGET_DIR (relative to the repository root
%   when relative) or <repo>/target.
d = getenv('CARGO_TARGET_DIR');
root = repo_root();
if isempty(d)
    d = fullfile(root, 'target');
elseif d(1) ~= '/' && ~(numel(d) > 1 && d(2) == ':')
    d = fullfile(root, d);
end
end
