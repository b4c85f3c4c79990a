function [lower, upper] = opt1_intervals(robot, length_tol_m, angle_tol_rad)
%OPT1_INTERVALS  Prior intervals for OPT1 around ROBOT's parameters (private to the
%   workflows): +-LENGTH_TOL_M on lengths (d, a, base/tool positions), +-ANGLE_TOL_RAD on
%   every other parameter. This is the user's prior knowledge, written out as input data
%   (the library's default is +-5 mm / +-5 deg, the paper's manufacturing tolerances, which
%   exclude the virtual robot's theta0_4 = -0.8 rad).
is_length = ~cellfun('isempty', regexp(robot.labels, '^(d|a)_\d+$|^(base|tool)_p[xyz]$'));
tol = angle_tol_rad * ones(size(robot.params));
tol(is_length) = length_tol_m;
lower = robot.params - tol;
upper = robot.params + tol;
end
