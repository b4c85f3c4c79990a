function [T, seed] = kincal_aria_tool()
%KINCAL_ARIA_TOOL  The ARIA calibration tool of the paper (Table 2).
%   [T, SEED] = KINCAL_ARIA_TOOL() gives the ten reference poses (4 x 4 x 10, on a circle of
%   radius 0.25 m at z = 0.235 m) and a configuration SEED (6 x 1, rad) from which
%   KINCAL_IK reaches every pose on the same branch.
%
%   See also KINCAL_IK, KINCAL_ROBOT.
[T, seed] = kincal_mex('aria_tool');
end
