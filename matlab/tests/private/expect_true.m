function expect_true(cond, varargin)
%EXPECT_TRUE  Fails with the sprintf message VARARGIN unless COND is true.
if ~(islogical(cond) || isnumeric(cond)) || isempty(cond) || ~all(cond(:))
    error('test:false', varargin{:});
end
end
