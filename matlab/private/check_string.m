function s = check_string(s, name, choices)
%CHECK_STRING  M-side check of a string argument (private): a character row vector, and one
%   of CHOICES (a cell array) when given; kincal:badClass / kincal:badValue otherwise.
if ~ischar(s) || (~isempty(s) && size(s, 1) ~= 1)
    error('kincal:badClass', 'argument ''%s'' must be a character row vector, got %s', ...
        name, class(s));
end
if nargin > 2 && ~any(strcmp(s, choices))
    list = sprintf(' ''%s''', choices{:});
    error('kincal:badValue', 'argument ''%s'': unknown value ''%s''; expected one of%s', ...
        name, s, list);
end
end
