"""Ceilings of constant absorber settings (agents.evaluation.crash_limits): nested optimisations."""

import pytest

from agents.commands.crash_limits import main
from agents.evaluation.crash_limits import ceilings


def test_ceilings_are_nested_and_knowing_the_speed_pays():
    c = ceilings(0.3, levels=3, speeds_kmh=(25.0, 45.0), payloads_t=((0.0, 0.0), (2.0, 8.0)))
    # each is the minimum over a larger set of policies (one ⊂ per speed ⊂ per case), and
    # passive (all zeros) is a candidate of every one of them
    assert c["per_case"] <= c["per_speed"] <= c["one"] <= c["passive"]
    assert c["per_speed"] < 0.95 * c["passive"], c


def test_bad_arguments(capsys):
    with pytest.raises(SystemExit):
        main(["--range", "1.5"])
    assert "--range: must be in (0, 1)" in capsys.readouterr().err
