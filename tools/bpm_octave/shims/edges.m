function E = edges(TR)
% Shim for MATLAB's triangulation/edges: the undirected edges as sorted [low high] rows, in
% lexicographic order, each once.
  F = TR.ConnectivityList;
  E = unique(sort([F(:,[1 2]); F(:,[2 3]); F(:,[3 1])], 2), 'rows');
end
