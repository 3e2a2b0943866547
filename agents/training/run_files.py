"""Files of a training run folder shared by :mod:`agents.training.train` and
:mod:`agents.training.train_rllib`: the ``config.yaml`` with its run record, the library versions it
records, and CSV tables."""

from __future__ import annotations

import csv
import platform
from pathlib import Path
from types import ModuleType
from typing import Any, Protocol

import gymnasium as gym
import numpy as np
import yaml

import railgym
from agents.training.train_config import RUN_KEY
from railgym import _checks as val
from railgym.report.output import write_text_atomic

__all__ = ["read_run", "run_folder", "speed_text", "versions", "write_config", "write_csv"]


class _YamlConfig(Protocol):
    def to_yaml_dict(self) -> dict[str, Any]: ...


def versions(*libraries: ModuleType) -> dict[str, str]:
    """Versions of Python, railgym, ``libraries`` (by module name), gymnasium and numpy."""
    return {
        "python": platform.python_version(),
        "railgym": railgym.__version__,
        **{lib.__name__: str(lib.__version__) for lib in libraries},
        "gymnasium": gym.__version__,
        "numpy": np.__version__,
    }


def write_config(out: Path, cfg: _YamlConfig, run: dict[str, Any]) -> None:
    """``out/config.yaml``: the config as it loads back, with the run record under ``run:``."""
    data = cfg.to_yaml_dict()
    data[RUN_KEY] = run
    write_text_atomic(out / "config.yaml", yaml.safe_dump(data, sort_keys=False))


def run_folder(config: Any, out: str | Path | None) -> Path:
    """The output folder of a run: ``out``, else ``runs/<config stem>/`` in the working
    folder (``out`` is required when the config is a dict)."""
    if out is not None:
        return Path(out)
    if isinstance(config, dict):
        raise ValueError("out is required when the config is given as a dict")
    return Path("runs") / Path(config).stem


def read_run(out: Path) -> dict[str, Any]:
    """The run record of the run folder ``out`` (the ``run:`` section of its config.yaml)."""
    path = out / "config.yaml"
    run: dict[str, Any] = val.load_yaml(path.read_text(encoding="utf-8"), str(path))[RUN_KEY]
    return run


def speed_text(run: dict[str, Any]) -> str:
    """``N steps in W s (S steps/s)`` of a run record, the first words of a trainer's summary."""
    return f"{run['timesteps']} steps in {run['wall_s']} s ({run['steps_per_s']} steps/s)"


def write_csv(path: Path, rows: list[dict[str, Any]]) -> None:
    """``rows`` (same keys, in order) as a CSV table with a header line."""
    with path.open("w", newline="") as fh:
        writer = csv.DictWriter(fh, list(rows[0]))
        writer.writeheader()
        writer.writerows(rows)
