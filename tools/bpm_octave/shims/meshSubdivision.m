function [W, G] = meshSubdivision(V, F)
% Vectorised External/meshSubdivision.m (same output, row for row): the original finds each
% face's edges by a linear search over all edges (findaRow), too slow at 4 levels. Vertices:
% V, then one midpoint per edge of edges(triangulation(F, V)) in that order; faces: the four
% children of face n at rows 4n-3 .. 4n, (v1, m12, m31), (m12, v2, m23), (m23, v3, m31),
% (m12, m23, m31).
  nV = size(V, 1);
  nF = size(F, 1);
  Edges = edges(triangulation(F, V));
  MidPoints = (V(Edges(:,1),:) + V(Edges(:,2),:)) / 2;
  W = [V; MidPoints];
  [~, k1] = ismember(sort(F(:,[1 2]), 2), Edges, 'rows');
  [~, k2] = ismember(sort(F(:,[2 3]), 2), Edges, 'rows');
  [~, k3] = ismember(sort(F(:,[1 3]), 2), Edges, 'rows');
  G = zeros(4 * nF, 3);
  r = 4 * ((1:nF)' - 1);
  G(r + 1, :) = [F(:,1), nV + k1, nV + k3];
  G(r + 2, :) = [nV + k1, F(:,2), nV + k2];
  G(r + 3, :) = [nV + k2, F(:,3), nV + k3];
  G(r + 4, :) = [nV + k1, nV + k2, nV + k3];
end
