function expect_error(identifier, fh, message_part)
%EXPECT_ERROR  Calls FH and fails unless it raises an error with IDENTIFIER (and, when
%   given, a message containing MESSAGE_PART).
try
    fh();
catch err
    if ~strcmp(err.identifier, identifier)
        error('test:wrongError', 'expected error %s, got %s: %s', identifier, ...
            err.identifier, err.message);
    end
    if nargin > 2 && isempty(strfind(err.message, message_part))
        error('test:wrongMessage', 'error %s: message "%s" lacks "%s"', identifier, ...
            err.message, message_part);
    end
    return
end
error('test:noError', 'expected error %s, but the call succeeded', identifier);
end
