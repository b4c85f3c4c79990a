function [q, T] = reach(robot, targets, seed)
%REACH  Joint readings with which ROBOT reaches each target pose (inverse kinematics from
%   SEED), dropping the targets no configuration within the joint limits reaches (private
%   to the workflows). Returns the readings and the poses actually reached (4 x 4 x M).
m = size(targets, 3);
q = zeros(robot.n_joints, 0);
keep = false(1, m);
for k = 1:m
    try
        q(:, end + 1) = kincal_ik(robot, targets(:, :, k), seed); %#ok<AGROW>
        keep(k) = true;
    catch err
        if ~strcmp(err.identifier, 'kincal:unreachable')
            rethrow(err);
        end
    end
end
if ~all(keep)
    fprintf('  %d of %d target poses are out of reach and were skipped\n', nnz(~keep), m);
end
T = kincal_fk(robot, q);
end
