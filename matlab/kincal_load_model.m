function model = kincal_load_model(file)
%KINCAL_LOAD_MODEL  Load a model file written by the kincal CLI (kincal calibrate).
%   MODEL = KINCAL_LOAD_MODEL(FILE) reads the JSON model file (format "kincal-model",
%   schema 1.x) and returns
%       robot        the model the file stores (robot struct, as KINCAL_ROBOT)
%       initial      the model the calibration started from (every parameter's "nominal")
%       name, schema_version, generator
%       results      for a calibrated model, one field per algorithm run (ols, opt1, opt2),
%                    each with robot (the initial model with that algorithm's identified
%                    values), params (P x 1), std_errors (P x 1, SI; 0 where not fitted),
%                    iterations, sigma2
%       calibration  the file's "calibration" object as decoded (data, options,
%                    identifiability, residuals, consensus)
%   Numbers: Matlab's JSONDECODE reads them exactly; GNU Octave 7's may round the last bit
%   (about 2e-16 relative), which is far below any calibration tolerance.
%
%   Example:
%       system('kincal calibrate poses.csv --robot aria --algorithm all --out model.json');
%       m = kincal_load_model('model.json');
%       kincal_print_params({m.initial, m.results.ols.robot, m.results.opt2.robot}, ...
%                           {'NOM', 'OLS', 'OPT2'});
%
%   See also KINCAL_ROBOT, KINCAL_IDENTIFY.
check_string(file, 'file');
try
    j = jsondecode(fileread(file));
catch err
    error('kincal:modelFile', '%s: not a JSON model file: %s', file, err.message);
end
if ~isstruct(j) || ~isfield(j, 'format') || ~strcmp(j.format, 'kincal-model') || ...
        ~isfield(j, 'robot')
    error('kincal:modelFile', '%s: not a kincal model file (format "kincal-model")', file);
end
major = sscanf(j.schema_version, '%d', 1);
if isempty(major) || major ~= 1
    error('kincal:modelFile', '%s: schema version %s is not supported (this reader: 1.x)', ...
        file, j.schema_version);
end
rj = j.robot;
n = rj.n_joints;
links = as_rows(rj.nominal.links, {'theta0', 'd', 'a', 'alpha', 'beta'});
limits = as_rows(rj.joint_limits, {'lower', 'upper'});
table = struct('links', links, 'limits', limits, 'base', rj.nominal.base(:)', ...
    'tool', rj.nominal.tool(:)', 'link_masses_kg', rj.mass.link_masses_kg(:), ...
    'tool_mass_kg', rj.mass.tool_mass_kg, 'gravity', rj.mass.gravity_m_s2(:), ...
    'name', rj.name);
base = kincal_robot(table);
choices = cellstr(rj.length_params);
for i = 1:n
    base = kincal_mex('robot_set', base, 'length_param', [i, double(strcmp(choices{i}, 'beta'))]);
end
% joint_types: written only for models with a prismatic joint (absent: all revolute).
if isfield(rj, 'joint_types') && ~isempty(rj.joint_types)
    kinds = cellstr(rj.joint_types);
    for i = 1:n
        base.joint_kind(i) = double(strcmp(kinds{i}, 'prismatic'));
    end
    base = kincal_robot(base);
end
params = as_list(rj.parameters);
initial = base;
model.robot = base;
for k = 1:numel(params)
    idx = label_index(base, params{k}.label, file);
    initial.params(idx) = params{k}.nominal;
    model.robot.params(idx) = params{k}.value;
end
model.initial = kincal_robot(initial);
model.robot = kincal_robot(model.robot);
model.name = rj.name;
model.schema_version = j.schema_version;
model.generator = '';
if isfield(j, 'generator')
    model.generator = j.generator;
end
model.results = struct();
model.calibration = [];
if isfield(j, 'calibration') && ~isempty(j.calibration)
    model.calibration = j.calibration;
    runs = as_list(j.calibration.results);
    for k = 1:numel(runs)
        run = runs{k};
        r = model.initial;
        se = zeros(size(r.params));
        fitted = as_list(run.parameters);
        for p = 1:numel(fitted)
            idx = label_index(r, fitted{p}.label, file);
            r.params(idx) = fitted{p}.value;
            se(idx) = fitted{p}.std_error;
        end
        res = struct('robot', kincal_robot(r), 'params', r.params, 'std_errors', se, ...
            'iterations', run.iterations, 'sigma2', run.sigma2);
        model.results.(run.algorithm) = res;
    end
end
end

function m = as_rows(list, fields)
list = as_list(list);
m = zeros(numel(list), numel(fields));
for i = 1:numel(list)
    for k = 1:numel(fields)
        m(i, k) = list{i}.(fields{k});
    end
end
end

function c = as_list(x)
% JSON arrays of objects decode to struct arrays (same fields) or cells (different fields).
if iscell(x)
    c = x;
elseif isempty(x)
    c = {};
else
    c = num2cell(x);
end
end

function idx = label_index(robot, label, file)
idx = find(strcmp(robot.labels, label), 1);
if isempty(idx)
    error('kincal:modelFile', '%s: unknown parameter label ''%s''', file, label);
end
end
