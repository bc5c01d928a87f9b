function Y = normalize(X, dim, method)
% Shim for MATLAB's normalize(X, dim, 'norm') (Octave 7's normalize has no 'norm' method):
% each vector along dimension dim divided by its Euclidean norm. Only that form is provided.
  if nargin ~= 3 || ~strcmp(method, 'norm')
    error('normalize shim: only normalize(X, dim, ''norm'') is provided');
  end
  Y = X ./ sqrt(sum(X.^2, dim));
end
