function TR = triangulation(F, V)
% Shim for MATLAB's triangulation class (absent from GNU Octave 7): a struct holding the
% connectivity and the points, read by the shims neighbors.m and edges.m. Only what the
% authors' BPM code calls is provided.
  TR = struct('ConnectivityList', F, 'Points', V);
end
