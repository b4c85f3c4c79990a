function d = subset_data(data, keep)
%SUBSET_DATA  The rows KEEP (logical or indices) of a measurement struct from
%   KINCAL_READ_MEASUREMENTS (private to the workflows).
d = data;
d.q = data.q(:, keep);
d.T = data.T(:, :, keep);
d.line = data.line(keep);
d.n_poses = size(d.q, 2);
if ~isempty(data.pose_id)
    d.pose_id = data.pose_id(keep);
end
if ~isempty(data.approach)
    d.approach = data.approach(:, keep);
end
if ~isempty(data.temp_c)
    d.temp_c = data.temp_c(keep);
end
d.extra = data.extra(keep, :);
end
