#!/usr/bin/env bash
# CI step in its own virtual environment: ray[rllib] pins gymnasium==1.2.2, the main CI keeps
# the newest gymnasium. Installs the rllib extra, runs the env, sweep and RLlib tests on
# gymnasium 1.2.2, then a short RLlib training (2 env runners, 2 iterations) whose checkpoint
# is saved, reloaded and evaluated on the reference backend. RLLIB_VENV: venv folder.
set -euo pipefail
cd "$(dirname "$0")/.."
venv="${RLLIB_VENV:-.venv-rllib}"
python3 -m venv "$venv"
# shellcheck disable=SC1091
source "$venv/bin/activate"
python -m pip install --quiet --upgrade pip
# torch is pinned: 2.13.0 is a local CPU build here; an unpinned torch pulls a multi-GB CUDA build.
python -m pip install --quiet "torch==2.13.0"
python -m pip install --quiet -e ".[rllib,agents]" pytest hypothesis
python -c "import gymnasium, ray; print('gymnasium', gymnasium.__version__, 'ray', ray.__version__)"
echo "rllib.sh: environment ready after ${SECONDS} s"
# the env tests on gymnasium 1.2.2, the Ray backend of the task runner, the RLlib trainer
python -m pytest -q -p no:cacheprovider tests/envs/vertical/test_vertical.py tests/agents/training/test_rllib.py \
    "tests/test_parallel.py::test_ray_backend_equals_serial"
echo "rllib.sh: tests done after ${SECONDS} s"
out="$(mktemp -d)"
trap 'rm -rf "$out"' EXIT
railgym train-rllib railgym/configs/agents/ppo_vertical_rllib.yaml --iterations 2 \
    --out "$out/run"
test -s "$out/run/eval.csv" && test -s "$out/run/manifest.json"
echo "rllib.sh: training done after ${SECONDS} s"
