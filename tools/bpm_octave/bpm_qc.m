function bpm_qc(bpm_dir, obj_file, n_subd, with_linear, per_face_csv)
% The authors' BPM and linear QC figures (area-weighted average and max QC) for one mesh, as
% their RunBPM.m computes them, without the pictures and OBJ outputs:
%   [Vz, Vw, F] = ExtractMeshesFromUV(name)        (one UV per vertex: give a seam-cut OBJ)
%   BPMContinuousParam / LinearContinuousParam at n_subd subdivisions
%   ComputeQuasiConformalError on the subdivided meshes.
% bpm_dir: a checkout of github.com/shirrorbe/BPM (unmodified); the shims in ./shims are put
% first on the path. Prints one line per interpolant: name, avg_qc, max_qc (%.10g).
% with_linear (default true): also run their linear interpolation, whose per-point arrayfun
% takes minutes already on the 258-face wolf_head (false: BPM only).
% per_face_csv (optional): also write BPM's per-input-face figures, one line per face:
% area-weighted mean QC and max QC over the face's 4^n_subd sub-faces (their rows
% (f-1)*4^n+1 .. f*4^n of F_subd), comparable with columns 0 and 1 of
% `reparam bpm qc --unfold authors --per-face`.
  if nargin < 4
    with_linear = true;
  end
  if nargin < 5
    per_face_csv = '';
  end
  here = fileparts(mfilename('fullpath'));
  addpath(genpath(fullfile(bpm_dir, 'External')));
  addpath(genpath(fullfile(bpm_dir, 'Code')));
  addpath(fullfile(here, 'shims'));   % last added = first searched
  warning('off', 'Octave:shadowed-function');
  [folder, name, ~] = fileparts(obj_file);
  old = cd(folder);
  [Vz, Vw, F] = ExtractMeshesFromUV(name);
  cd(old);
  printf('%s: %d vertices, %d faces, n_subd = %d\n', name, size(Vz, 1), size(F, 1), n_subd);
  tic;
  [Mw, Mz] = BPMContinuousParam(Vz, Vw, F, n_subd);
  [qc, ~, max_qc, avg_qc] = ComputeQuasiConformalError(Mz.V, Mw.V, Mz.F);
  printf('bpm    avg_qc = %.10g  max_qc = %.10g  (%.1f s)\n', avg_qc, real(max_qc), toc);
  if ~isempty(per_face_csv)
    areas = calculate_face_vertex_areas(Mz.V, Mz.F);
    k = 4^n_subd;
    qc = reshape(real(qc), k, []);
    areas = reshape(areas, k, []);
    per_face = [(sum(qc .* areas, 1) ./ sum(areas, 1))', max(qc, [], 1)'];
    dlmwrite(per_face_csv, per_face, 'precision', '%.17g');
  end
  if ~with_linear
    return;
  end
  tic;
  [Mw, Mz] = LinearContinuousParam(Vz, Vw, F, n_subd);
  [~, ~, max_qc, avg_qc] = ComputeQuasiConformalError(Mz.V, Mw.V, Mz.F);
  printf('linear avg_qc = %.10g  max_qc = %.10g  (%.1f s)\n', avg_qc, real(max_qc), toc);
end
