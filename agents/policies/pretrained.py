"""Pretrained policies shipped in the package, loaded by name: ``ppo-vertical``
(trained on ``railgym/VerticalSuspension-v3``), ``ppo-vehicle`` (``railgym/VerticalVehicle-v3``)
and ``ppo-crash`` (``railgym/TrainCrash-v1``); each runs on any version of its env. The two
vertical ones are residuals of the LQG (:mod:`agents.controllers.residual`). ``ppo-preview`` (the
vehicle with ``preview=21.56``, a residual of ``lq-preview``) and ``ppo-semiactive`` (the vertical
env with ``actuator="semi-active"``, a residual of ``clipped-lqg``) carry those env settings with
them (issue 30)::

    railgym evaluate ppo-vertical --track-class 4 5 6
    railgym evaluate ppo-vehicle --env vehicle --track-class 5
    railgym evaluate ppo-crash --env crash --envelope
    railgym evaluate ppo-preview lq-preview lqg --env vehicle --track-class 4 5 --preview 21.56
    railgym evaluate ppo-semiactive clipped-lqg --actuator semi-active --track-class 4 5 6

Each is the folder ``agents/pretrained/<name>/`` as :mod:`agents.training.train` writes it: the
final ``model.zip`` (weights only in the newer ones: the optimizer's state left out), its
``config.yaml`` and a ``manifest.json`` with the zip's SHA-256 (loaded like
any trained policy, weights only: :func:`agents.policies.loading.load_policy`). They are the best
seed of a :mod:`agents.evaluation.benchmark` run (lowest held-out :data:`RANKING` metric), copied
by::

    railgym benchmark ppo_vertical_lqg --seeds 3 -o runs/bench_vertical
    railgym pretrained ppo-vertical runs/bench_vertical --overwrite

The budgets and held-out figures of the shipped policies are in ``docs/results.md``.
"""

from __future__ import annotations

import csv
import shutil
import zipfile
from importlib.resources import files
from pathlib import Path

import numpy as np

from agents.policies.policy_io import write_manifest
from railgym.registration import env_family

__all__ = ["PRETRAINED", "RANKING", "install", "pretrained_zip"]

#: name → env id of each pretrained policy
PRETRAINED = {
    "ppo-vertical": "railgym/VerticalSuspension-v3",
    "ppo-vehicle": "railgym/VerticalVehicle-v3",
    "ppo-crash": "railgym/TrainCrash-v1",
    "ppo-preview": "railgym/VerticalVehicle-v3",
    "ppo-semiactive": "railgym/VerticalSuspension-v3",
}
#: held-out metrics (``results.csv`` of :mod:`agents.evaluation.benchmark`) whose mean over the
#: cases ranks the seeds, per env (any version; lower is better)
RANKING = {
    "railgym/VerticalSuspension": ("a_w",),
    "railgym/VerticalVehicle": ("a_w_front", "a_w_centre", "a_w_rear"),
    "railgym/TrainCrash": ("peak_g",),
}


def _folder(name: str) -> Path:
    return Path(str(files("agents"))) / "pretrained" / name


def pretrained_zip(name: str, env_id: str) -> Path:
    """The ``model.zip`` of pretrained policy ``name`` for ``env_id`` (any registered version
    of the env it was trained on: the versions share spaces and reference model; ValueError
    for another env or a policy missing from this installation."""
    if env_family(PRETRAINED[name]) != env_family(env_id):
        raise ValueError(f"policy {name} is for {PRETRAINED[name]}, not {env_id}")
    path = _folder(name) / "model.zip"
    if not path.is_file():
        raise ValueError(f"pretrained policy {name}: {path} is missing from this installation")
    return path


def best_seed(benchmark_dir: Path, env_id: str) -> int:
    """The seed of ``benchmark_dir/results.csv`` with the lowest mean :data:`RANKING` metric."""
    with (benchmark_dir / "results.csv").open(newline="") as fh:
        rows = [
            r
            for r in csv.DictReader(fh)
            if r["seed"] and r["metric"] in RANKING[env_family(env_id)]
        ]
    if not rows:
        raise ValueError(f"{benchmark_dir}/results.csv has no trained-seed rows for {env_id}")
    seeds = sorted({int(r["seed"]) for r in rows})
    score = [np.mean([float(r["value"]) for r in rows if int(r["seed"]) == s]) for s in seeds]
    return seeds[int(np.argmin(score))]


def install(name: str, benchmark_dir: str | Path, overwrite: bool = False) -> Path:
    """Copy the best seed of an :mod:`agents.evaluation.benchmark` folder into the package as
    ``name`` (``model.zip``, ``config.yaml`` and a manifest listing the zip); returns the folder."""
    if name not in PRETRAINED:
        raise ValueError(f"name must be one of {sorted(PRETRAINED)}, got {name!r}")
    src = Path(benchmark_dir) / f"seed_{best_seed(Path(benchmark_dir), PRETRAINED[name])}"
    dst = _folder(name)
    if dst.exists() and any(dst.iterdir()) and not overwrite:
        raise ValueError(f"{dst} exists: give --overwrite to replace it")
    dst.mkdir(parents=True, exist_ok=True)
    for old in dst.iterdir():
        old.unlink()
    _copy_weights(src / "model.zip", dst / "model.zip")
    shutil.copyfile(src / "config.yaml", dst / "config.yaml")
    write_manifest(dst)
    return dst


#: entries of an SB3 zip that only a resumed training reads (the optimizer's moments: twice
#: the size of the weights); loading by name reads ``policy.pth`` only
TRAINING_STATE = ("policy.optimizer.pth",)


def _copy_weights(src: Path, dst: Path) -> None:
    """Copy the SB3 zip ``src`` to ``dst`` without its :data:`TRAINING_STATE` (the package
    ships what :func:`agents.policies.policy_io.load_policy_weights` reads, a third of the size)."""
    with zipfile.ZipFile(src) as zin, zipfile.ZipFile(dst, "w", zipfile.ZIP_DEFLATED) as zout:
        for item in zin.infolist():
            if item.filename not in TRAINING_STATE:
                zout.writestr(item, zin.read(item.filename))
