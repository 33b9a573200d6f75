"""Solutions of the assembled equations: sparse factorisation (CHOLMOD or SuperLU), block
shift-invert Lanczos, and the normal modes of a model (SOL 103)."""
