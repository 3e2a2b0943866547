"""railgym — Gymnasium environments for railway vehicle dynamics with surrogate elements."""

__version__ = "0.1.0"
