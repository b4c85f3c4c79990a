function skip_test(reason)
%SKIP_TEST  Ends the calling test as skipped (RUN_TESTS prints SKIP; with CI=true it counts
%   as a failure).
error('test:skip', '%s', reason);
end
