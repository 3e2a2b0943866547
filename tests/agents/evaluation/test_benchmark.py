"""Benchmark protocol: several seeds, held-out evaluation, CSV + learning curve + table."""

import csv

import numpy as np
import pytest
import yaml

from agents.commands.benchmark import main
from agents.controllers.registry import PREVIEW_BASELINES, VEHICLE_ID, baselines_of
from agents.evaluation.benchmark import _baseline_kwargs, curve_figure, summary_table

TINY = """\
railgym/VerticalSuspension-v1:
  algo: ppo
  n_timesteps: 1024
  n_envs: 4
  seed: 0
  env_kwargs: {backend: surrogate, duration: 1.0}
  envelope: {track_class: [4, 5, 6]}
  eval_env_kwargs: {backend: reference, duration: 1.0}
  eval_freq: 512
  n_eval_episodes: 1
  n_steps: 64
  batch_size: 64
  n_epochs: 2
  policy_kwargs: {net_arch: [16, 16]}
"""


def read(path):
    with path.open(newline="") as fh:
        return list(csv.DictReader(fh))


@pytest.mark.slow
def test_benchmark_writes_csv_png_table_and_does_not_depend_on_workers(tmp_path):
    cfg = tmp_path / "tiny.yaml"
    cfg.write_text(TINY)
    runs = {}
    for workers in (1, 2):
        out = tmp_path / f"w{workers}"
        argv = [str(cfg), "--seeds", "2", "--episodes", "1", "--workers", str(workers)]
        assert main([*argv, "--out", str(out)]) == 0
        runs[workers] = read(out / "results.csv")
        assert (out / "learning_curve.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
        table = (out / "table.md").read_text()
        for tc in (4, 5, 6):
            assert f"| class {tc} | a_w (m/s²) |" in table
        assert "| passive | skyhook | lqg | lqr |" in table
    one, two = runs[1], runs[2]
    assert [(r["policy"], r["seed"], r["case"], r["metric"]) for r in one] == [
        (r["policy"], r["seed"], r["case"], r["metric"]) for r in two
    ]
    assert {r["seed"] for r in one if r["policy"] == "ppo"} == {"0", "1"}
    v1, v2 = (np.array([float(r["value"]) for r in rows]) for rows in (one, two))
    assert np.allclose(v1, v2, rtol=1e-9, atol=0.0)
    # the two seeds learnt different policies
    a_w = [float(r["value"]) for r in one if r["policy"] == "ppo" and r["metric"] == "a_w"]
    assert len(set(a_w)) == len(a_w)
    # a second run into the same folder needs --overwrite
    assert main([*argv, "--out", str(tmp_path / "w1")]) == 2


def test_summary_table_statistics():
    rows = [
        {"policy": "ppo", "seed": s, "case": "c", "metric": "a_w", "value": v, "unit": "m/s²"}
        for s, v in ((0, 1.0), (1, 2.0), (2, 3.0))
    ]
    rows.append(
        {"policy": "lqg", "seed": "", "case": "c", "metric": "a_w", "value": 1.5, "unit": "m/s²"}
    )
    table = summary_table(rows, "ppo")
    # mean 2, sample std 1, t(0.975, 2) = 4.303: half-width 4.303/√3 = 2.484
    assert "| c | a_w (m/s²) | 2 ± 1 (-0.4841…4.484) | 1.5 |" in table


def _eval_csvs(out, n, seeds=(0, 1, 2)):
    """``seed_<s>/eval.csv`` of ``n`` evaluations each (512 decisions apart)."""
    for s in seeds:
        (out / f"seed_{s}").mkdir(parents=True)
        rows = ["timesteps,mean_rms_carbody_acc"]
        rows += [f"{512 * (k + 1)},{0.5 - 0.05 * k + 0.02 * s}" for k in range(n)]
        (out / f"seed_{s}" / "eval.csv").write_text("\n".join(rows) + "\n")


@pytest.mark.parametrize("n", [1, 4])
def test_the_learning_curve_shows_the_agent_with_one_evaluation_too(tmp_path, n):
    """One evaluation (eval_freq >= n_timesteps) is one point: the agent's line carries a
    visible marker there and the seeds' range is an error bar, the legend beside the axes."""
    pytest.importorskip("matplotlib")
    import matplotlib.pyplot as plt
    from matplotlib.collections import LineCollection

    from agents.training.train_config import load_config

    cfg = load_config(yaml.safe_load(TINY))
    _eval_csvs(tmp_path, n)
    fig = curve_figure(tmp_path, cfg, [0, 1, 2], {"passive": 0.55, "lqg": 0.38})
    ax = fig.axes[0]
    (agent,) = [line for line in ax.get_lines() if line.get_label().startswith("ppo")]
    assert agent.get_visible() and agent.get_marker() not in ("None", "", None, " ")
    assert agent.get_markersize() > 0 and len(agent.get_xdata()) == n
    np.testing.assert_allclose(agent.get_xdata(), 512 * np.arange(1, n + 1) * cfg.action_hold)
    np.testing.assert_allclose(agent.get_ydata(), 0.52 - 0.05 * np.arange(n))
    x0, x1 = ax.get_xlim()
    assert x0 < agent.get_xdata()[0] < x1  # inside the axes, not on their edge
    if n == 1:  # the min–max range of the seeds as a vertical bar at the point
        (bar,) = [c for c in ax.collections if isinstance(c, LineCollection)]
        (segment,) = bar.get_segments()
        np.testing.assert_allclose(segment[:, 1], [0.5, 0.54])
    fig.canvas.draw()
    legend = ax.get_legend().get_window_extent()
    assert legend.x0 >= ax.get_window_extent().x1  # beside the curves, covering nothing
    plt.close(fig)


def test_a_preview_config_is_benchmarked_against_the_lqg_and_the_lq_preview():
    """A vehicle config with ``preview``: the LQG (no preview) and ``lq-preview`` beside it,
    run with the config's preview; without it the vehicle baselines as before."""
    kwargs = {"backend": "surrogate", "preview": 21.56, "duration": 10.0}
    assert baselines_of(VEHICLE_ID, kwargs) == PREVIEW_BASELINES
    assert {"lqg", "lq-preview"} <= set(PREVIEW_BASELINES)
    assert _baseline_kwargs(VEHICLE_ID, kwargs) == {"preview": 21.56}
    assert "lq-preview" not in baselines_of(VEHICLE_ID, {"backend": "surrogate"})


def test_a_config_of_the_newest_version_is_benchmarked_on_it():
    """The packaged configs name -v3: the baselines and shared settings of its env (any
    version), and the held-out rows of that version's tracks (not -v1's)."""
    from agents.controllers.registry import ENV_ID
    from agents.evaluation.benchmark import held_out
    from agents.evaluation.sweeps import evaluate_sweep
    from railgym.registration import newest

    vertical, vehicle = newest(ENV_ID), newest(VEHICLE_ID)
    assert (vertical, vehicle) == (ENV_ID, VEHICLE_ID)  # the registry's ids are the newest
    old = "railgym/VerticalSuspension-v1"
    assert vertical != old
    kwargs = {"backend": "surrogate", "preview": 21.56}
    assert baselines_of(vehicle, kwargs) == PREVIEW_BASELINES
    assert _baseline_kwargs(vehicle, kwargs) == {"preview": 21.56}
    semi = {"actuator": "semi-active"}
    assert baselines_of(vertical, semi) == baselines_of(old, semi) != baselines_of(vertical, {})
    rows = held_out(vertical, ["passive"], 1, None)
    a_w = {r["case"]: float(r["value"]) for r in rows if r["metric"] == "a_w"}
    direct = evaluate_sweep(["passive"], "reference", (4, 5, 6), 1, env_id=vertical)
    assert a_w == {f"class {r['track_class']}": pytest.approx(r["a_w"], rel=1e-12) for r in direct}
    rows_v1 = held_out(old, ["passive"], 1, None)
    assert a_w["class 4"] != next(float(r["value"]) for r in rows_v1 if r["metric"] == "a_w")
