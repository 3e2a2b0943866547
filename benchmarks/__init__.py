"""Benchmarks: speed against anchors measured in the same run (``python -m benchmarks``)."""


def row(name: str, value: float, unit: str, target: str = "", context: str = "") -> dict:
    """One benchmark measurement as printed by ``python -m benchmarks``."""
    return {"name": name, "value": float(value), "unit": unit, "target": target, "context": context}
