"""``railgym validate`` reports a surrogate that diverges as diverged: a count of the
tracks per row and a legend of the columns, never ``inf / nan / inf``."""

import numpy as np

from agents.commands.validate import main
from agents.evaluation.vehicle_validation import LEGEND
from railgym.vehicles.collect import save_vertical_surrogate
from surrogates.models.lpr import LegendreRegression


def test_a_diverging_element_is_counted_not_printed_as_inf(tmp_path, capsys):
    # a secondary of negative stiffness −2 MN/m: the carbody runs away on every track
    rng = np.random.default_rng(0)
    U = rng.uniform([-0.05, -0.5], [0.05, 0.5], (200, 2))
    model = LegendreRegression(degree=1).fit(U, -2.0e6 * U[:, 0])
    model.features_ = {"form": "static", "tau": None, "known_physics": []}
    path = save_vertical_surrogate(model, None, tmp_path / "unstable.json", "test")
    argv = ["--env", "vertical", "--element", str(path), "maxwell", "--seeds", "3"]
    assert main([*argv, "--track-class", "5", "--duration", "2", "--quiet"]) == 0
    out = capsys.readouterr().out
    assert "inf" not in out and "nan" not in out
    rows = {r.split("|")[1].strip(): r.split("|") for r in out.splitlines() if r.startswith("| ")}
    assert rows["element"][-2].strip() == "diverged"
    unstable, packaged = rows[str(path)], rows["maxwell"]
    assert unstable[4].strip() == "—" and unstable[5].strip() == "3 of 3"
    assert packaged[5].strip() == "0 of 3" and float(packaged[4].split("/")[0]) < 10.0
    assert out.strip().endswith(LEGEND)


def test_a_comparison_against_an_fmu_runs_a_version_that_draws_its_tracks_whole():
    """The FMU backend draws the track whole on every version; the newest versions stream it
    (another track of the same seed), so ``floor_errors`` against an FMU runs the newest
    version that draws it whole, and against the reference the newest."""
    from agents.controllers.registry import ENV_ID, VEHICLE_ID
    from agents.evaluation.vehicle_validation import whole_track_version

    assert whole_track_version(ENV_ID) == "railgym/VerticalSuspension-v2" != ENV_ID
    assert whole_track_version(VEHICLE_ID) == "railgym/VerticalVehicle-v2" != VEHICLE_ID
    assert whole_track_version("railgym/VerticalSuspension-v1") == whole_track_version(ENV_ID)
