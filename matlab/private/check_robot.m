function robot = check_robot(robot)
%CHECK_ROBOT  M-side check that ROBOT is a robot struct (private); the gateway checks every
%   field (class, size, finiteness) and the model itself on each call.
if ~isstruct(robot) || ~isscalar(robot) || ~isfield(robot, 'params') || ...
        ~isfield(robot, 'n_joints')
    error('kincal:badClass', ['argument ''robot'' must be a robot struct from kincal_robot, ' ...
        'got %s'], class(robot));
end
end
