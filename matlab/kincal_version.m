function v = kincal_version()
%KINCAL_VERSION  Version of the linked kincal library ('MAJOR.MINOR.PATCH').
v = kincal_mex('version');
end
