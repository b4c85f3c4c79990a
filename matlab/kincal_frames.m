function F = kincal_frames(robot, q, varargin)
%KINCAL_FRAMES  Every frame of one forward-kinematics evaluation.
%   F = KINCAL_FRAMES(ROBOT, Q) is 4 x 4 x (N+2) for one configuration Q (N x 1, rad):
%   F(:,:,1) is the base frame T_0^b (before joint 1), F(:,:,i+1) is frame i
%   (T_0^b A_1 ... A_i), F(:,:,N+2) is the tool T_e^b. All in the base frame, metres.
%   Options 'approach' and 'temp_c' as KINCAL_FK.
%
%   Example (draw the arm):
%       F = kincal_frames(kincal_robot('aria'), [0; 0.5; -0.5; 0; 0.8; 0]);
%       p = squeeze(F(1:3, 4, :)); plot3(p(1,:), p(2,:), p(3,:), 'o-')
%
%   See also KINCAL_FK.
if nargin < 2
    error('kincal:badArgCount', 'kincal_frames takes at least two arguments');
end
check_robot(robot);
q = check_matrix(q, 'q', robot.n_joints, 1);
opts = parse_options(varargin, struct('approach', [], 'temp_c', []));
F = kincal_mex('frames', robot, q, make_aux(opts, robot.n_joints, 1));
end
