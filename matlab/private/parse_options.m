function opts = parse_options(args, defaults)
%PARSE_OPTIONS  Name-value pairs ARGS (a cell) over the struct DEFAULTS (private).
%   Names are matched exactly (case-sensitive); an unknown name raises kincal:unknownOption,
%   a dangling name kincal:badArgCount.
opts = defaults;
if mod(numel(args), 2) ~= 0
    error('kincal:badArgCount', 'options must come in name-value pairs');
end
for k = 1:2:numel(args)
    name = args{k};
    if ~ischar(name) || ~isfield(defaults, name)
        if ischar(name)
            shown = name;
        else
            shown = class(name);
        end
        names = fieldnames(defaults);
        known = sprintf(' %s', names{:});
        error('kincal:unknownOption', 'unknown option ''%s''; known options:%s', shown, known);
    end
    opts.(name) = args{k + 1};
end
end
