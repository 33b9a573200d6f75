"""Model -> K and M: the sparsity pattern and scatter, element dispatch (properties turned into
the kernels' inputs), and the constraint transform and reduction to the independent set."""
