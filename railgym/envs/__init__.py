"""Gymnasium environments of railgym."""
