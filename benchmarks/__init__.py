"""Benchmarks: speed against anchors measured in the same run."""
