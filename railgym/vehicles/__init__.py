"""Vehicle models: parameters and numba kernels (pure physics, no gymnasium)."""
