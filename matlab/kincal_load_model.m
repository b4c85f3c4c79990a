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
%   The models (robot, initial, results.*.robot and .params) are read by kincal's one
%   model-file reader (kincal-io, through the MEX and the C ABI's kincal_model_read): a file
%   the CLI refuses (a missing or relabelled parameter, an unknown length parameter, a wrong
%   joint count, a newer schema) raises kincal:badFile with the CLI's message
%   (file:line:column: reason), and the parameters are bit for bit the CLI's. Only the report
%   fields (name, generator, calibration, std_errors, iterations, sigma2) are decoded here,
%   after the reader accepted the file; Octave 7's JSONDECODE may round their last bit.
%
%   Example:
%       system('kincal calibrate poses.csv --robot aria --algorithm all --out model.json');
%       m = kincal_load_model('model.json');
%       kincal_print_params({m.initial, m.results.ols.robot, m.results.opt2.robot}, ...
%                           {'NOM', 'OLS', 'OPT2'});
%
%   See also KINCAL_ROBOT, KINCAL_IDENTIFY.
check_string(file, 'file');
model.robot = kincal_robot(kincal_mex('model_read', file, ''));
model.initial = kincal_robot(kincal_mex('model_read', file, 'NOM'));
% The report fields: the reader has accepted the file, so it is a kincal model JSON object.
j = jsondecode(fileread(file));
model.robot.name = j.robot.name;
model.initial.name = j.robot.name;
model.name = j.robot.name;
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
        r = kincal_robot(kincal_mex('model_read', file, upper(run.algorithm)));
        r.name = j.robot.name;
        se = zeros(size(r.params));
        fitted = as_list(run.parameters);
        for p = 1:numel(fitted)
            if isfield(fitted{p}, 'std_error')
                se(strcmp(r.labels, fitted{p}.label)) = fitted{p}.std_error;
            end
        end
        model.results.(run.algorithm) = struct('robot', r, 'params', r.params, ...
            'std_errors', se, 'iterations', run.iterations, 'sigma2', run.sigma2);
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
