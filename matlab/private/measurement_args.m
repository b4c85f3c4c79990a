function [q, T, components, aux, rest] = measurement_args(robot, args, name)
%MEASUREMENT_ARGS  The measurements of an identification or validation call (private):
%   either (Q, T, options...) with Q N x M and T 4 x 4 x M, or (DATA, options...) with DATA a
%   struct from KINCAL_READ_MEASUREMENTS. Returns the components mask (1 x M, [] = full
%   poses), the auxiliary inputs for the gateway and the remaining name-value options.
if ~isempty(args) && isstruct(args{1})
    data = args{1};
    if ~isfield(data, 'q') || ~isfield(data, 'T')
        error('kincal:badClass', '%s: a data struct needs fields q and T', name);
    end
    q = data.q;
    T = data.T;
    rest = args(2:end);
    if isempty(T)
        error('kincal:badValue', '%s: the data have no measured poses (columns x, y, z)', name);
    end
    components = [];
    if isfield(data, 'components') && strcmp(data.components, 'position')
        components = 7 * ones(1, size(q, 2));   % bits of x, y, z
    end
    from_data = struct('approach', [], 'temp_c', []);
    if isfield(data, 'approach')
        from_data.approach = data.approach;
    end
    if isfield(data, 'temp_c')
        from_data.temp_c = data.temp_c;
    end
elseif numel(args) >= 2
    q = args{1};
    T = args{2};
    rest = args(3:end);
    components = [];
    from_data = struct('approach', [], 'temp_c', []);
else
    error('kincal:badArgCount', '%s: give Q and T, or a data struct', name);
end
q = check_matrix(q, 'q', robot.n_joints, NaN);
T = check_poses(T, 'T');
if size(T, 3) ~= size(q, 2)
    error('kincal:badSize', '%s: T must be 4x4x%d (one pose per column of q), got 4x4x%d', ...
        name, size(q, 2), size(T, 3));
end
% approach / temp_c / components given as options override those of the data struct.
k = 1;
keep = true(1, numel(rest));
while k < numel(rest)
    if ischar(rest{k}) && any(strcmp(rest{k}, {'approach', 'temp_c', 'components'}))
        switch rest{k}
            case 'components'
                components = rest{k + 1};
                if ischar(components)
                    check_string(components, 'components', {'pose', 'position'});
                    if strcmp(components, 'position')
                        components = 7 * ones(1, size(q, 2));
                    else
                        components = [];
                    end
                end
            otherwise
                from_data.(rest{k}) = rest{k + 1};
        end
        keep([k, k + 1]) = false;
    end
    k = k + 2;
end
rest = rest(keep);
aux = make_aux(from_data, robot.n_joints, size(q, 2));
end
