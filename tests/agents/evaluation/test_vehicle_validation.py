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
