function rot = kincal_biopsy_rotation(r_t_m, d_m, l_max_m)
%KINCAL_BIOPSY_ROTATION  Orientation error a biopsy allows, eq. (3) of the paper.
%   ROT = KINCAL_BIOPSY_ROTATION(R_T, D, L_MAX) is 2 asin((r_t - d) / (2 sqrt(2) l_max))
%   in radians: the largest needle orientation error that keeps the tip inside a tumour of
%   radius R_T (m) when the puncture point is off by D (m) and the insertion is at most
%   L_MAX (m) long. KINCAL_BIOPSY_ROTATION(5e-3, sqrt(3)*1e-3, 0.2) is 0.66 deg.
%
%   See also KINCAL_VALIDATE.
if nargin ~= 3
    error('kincal:badArgCount', 'kincal_biopsy_rotation takes R_T, D and L_MAX');
end
rot = kincal_mex('biopsy_rotation', check_matrix(r_t_m, 'r_t_m', 1, 1), ...
    check_matrix(d_m, 'd_m', 1, 1), check_matrix(l_max_m, 'l_max_m', 1, 1));
end
