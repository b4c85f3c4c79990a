function [v, operations] = kincal_version()
%KINCAL_VERSION  Version of the linked kincal library and what this build can do.
%   V = KINCAL_VERSION() is the library version ('MAJOR.MINOR.PATCH').
%   [V, OPERATIONS] = KINCAL_VERSION() also lists the operations of the MEX gateway
%   (1 x K cell): the set depends on the C ABI the gateway was built against, e.g.
%   'identify' needs the library's identification exports.
v = kincal_mex('version');
if nargout > 1
    operations = kincal_mex('operations');
end
end
