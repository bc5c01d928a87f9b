function N = neighbors(TR)
% Shim for MATLAB's triangulation/neighbors: N(f, j) is the face across the edge opposite
% corner j of face f (the edge from corner j+1 to corner j+2), NaN on a boundary. The
% neighbour is the face that traverses that edge in the opposite direction (a consistently
% oriented manifold mesh, as the authors' inputs are).
  F = TR.ConnectivityList;
  nV = max(size(TR.Points, 1), max(F(:)));
  nF = size(F, 1);
  f = (1:nF)';
  % directed edge a -> b of face f, opposite corner j
  a = [F(:,2); F(:,3); F(:,1)];
  b = [F(:,3); F(:,1); F(:,2)];
  owner = sparse(a, b, [f; f; f], nV, nV);
  across = full(owner(sub2ind([nV nV], b, a)));
  across(across == 0) = NaN;
  N = reshape(across, nF, 3);
end
