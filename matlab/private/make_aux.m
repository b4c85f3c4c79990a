function aux = make_aux(opts, n, m)
%MAKE_AUX  The joint auxiliary inputs for the gateway from options 'approach' (N x M, each
%   -1, 0 or +1) and 'temp_c' (1 x M, degrees Celsius); [] when neither is given (private).
aux = [];
if ~isempty(opts.approach)
    aux.approach = check_matrix(opts.approach, 'approach', n, m);
end
if ~isempty(opts.temp_c)
    aux.temp_c = check_matrix(opts.temp_c, 'temp_c', 1, m);
end
end
