function out = cli(varargin)
%CLI  Runs the kincal command-line tool with the given arguments and returns its standard
%   output; fails (test:cli) on a non-zero exit status. The binary is $KINCAL_CLI or
%   <target>/release/kincal (cargo build --release -p kincal-cli). Arguments are quoted for a
%   POSIX shell.
exe = getenv('KINCAL_CLI');
if isempty(exe)
    exe = fullfile(target_dir(), 'release', 'kincal');
end
if ~exist(exe, 'file')
    error('test:cli', 'the kincal CLI is not built: %s (cargo build --release -p kincal-cli)', exe);
end
cmd = quote(exe);
for k = 1:numel(varargin)
    cmd = [cmd, ' ', quote(varargin{k})]; %#ok<AGROW>
end
[status, out] = system([cmd ' 2>&1']);
if status ~= 0
    error('test:cli', 'kincal exited with status %d:\n%s\n%s', status, cmd, out);
end
end

function s = quote(a)
s = ['''' strrep(a, '''', '''\''''') ''''];
end
