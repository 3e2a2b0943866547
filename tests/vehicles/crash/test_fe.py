"""FE output → crash elements: synthetic crash → nodout/rcforc → readers → TrainCrash-v1."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import railgym  # noqa: F401  (registers the environments)
from agents.commands.crash_fe import main
from railgym.vehicles.crash.fe import (
    crash_result_from_fe,
    crash_surrogate_from_fe,
    load_crash_surrogate,
    save_crash_surrogate,
)
from railgym.vehicles.crash.reference import simulate_reference
from railgym.vehicles.crash.surrogate import build_crash_surrogate
from surrogates import io
from surrogates.lsdyna import write_nodout, write_rcforc

ENV_ID = "railgym/TrainCrash-v1"
NODES = (1001, 2001)  # lead car, car 2


@pytest.fixture(scope="module")
def fe_files(tmp_path_factory):
    """The paper-scenario reference crash written as LS-DYNA output in mm-ms-kg-kN, with the
    train travelling towards −x (as an FE model may be set up)."""
    ref = simulate_reference("paper")
    tmp = tmp_path_factory.mktemp("fe")
    t_ms = ref.t * 1e3
    nodes = {
        nid: {
            "x_disp": -ref.x[:, k] * 1e3,  # mm
            "x_vel": -ref.v[:, k],  # mm/ms = m/s
            "x_accl": -ref.a[:, k] * 1e-3,  # mm/ms²
            "y_coor": np.full(ref.t.size, 1500.0),
        }
        for k, nid in enumerate(NODES)
    }
    f_kn = ref.force / 1e3
    contacts = {}
    for cid, j in ((1, 0), (2, 1)):
        contacts[("master", cid)] = {"x_force": f_kn[:, j], "z_force": 0.01 * f_kn[:, j]}
        contacts[("slave", cid)] = {"x_force": -f_kn[:, j]}
    legend = {1: "wall", 2: "car 1 / car 2"}
    nodout = write_nodout(tmp / "nodout", t_ms, nodes, legend={n: "CoM" for n in NODES})
    rcforc = write_rcforc(tmp / "rcforc", t_ms, contacts, legend=legend)
    return ref, nodout, rcforc, tmp


def _from_files(nodout, rcforc, **kw):
    return crash_surrogate_from_fe(
        nodout,
        rcforc,
        units="mm-ms-kg-kN",
        car_nodes=NODES,
        wall_contact=1,
        interface_contacts=[2],
        scenario="paper",
        direction=-1.0,
        **kw,
    )


def test_fe_files_give_the_reference_time_histories(fe_files):
    ref, nodout, rcforc, _ = fe_files
    res = crash_result_from_fe(
        io.read_nodout(nodout, units="mm-ms-kg-kN"),
        io.read_rcforc(rcforc, units="mm-ms-kg-kN"),
        car_nodes=NODES,
        wall_contact=1,
        interface_contacts=[2],
        scenario="paper",
        direction=-1.0,
    )
    np.testing.assert_allclose(res.t, ref.t, rtol=1e-6, atol=1e-12)
    # 5 significant digits in the files (%12.4E): relative to each signal's range
    for got, want in ((res.x, ref.x), (res.v, ref.v), (res.force, ref.force)):
        scale = np.ptp(want, axis=0)
        assert np.max(np.abs(got - want) / scale) < 2e-4
    # the zones' own crush: the centre-of-mass distances less the carbodies' shortening (the
    # scenario's carbody driven by the contact forces), closer to the reference's crush between
    # the car ends than the distances themselves
    com = np.column_stack([res.x[:, 0], res.x[:, 1] - res.x[:, 0]])
    rms, rms_com = (np.sqrt(np.mean((c - ref.crush) ** 2, axis=0)) for c in (res.crush, com))
    assert np.all(rms < 0.1 * rms_com)
    assert res.body_names == ["lead", "car2"] and res.zone_names == ["wall", "interface_1"]


def _episode(surrogate):
    env = gym.make(ENV_ID, surrogate=surrogate)
    env.reset(seed=0)
    rows, total = [], 0.0
    while True:
        _, r, term, trunc, info = env.step(np.zeros(2, np.float32))
        rows.append(info)
        total += r
        if term or trunc:
            return rows, total


def test_elements_from_fe_output_run_traincrash_like_the_direct_ones(fe_files, tmp_path):
    ref, nodout, rcforc, _ = fe_files
    direct = build_crash_surrogate(ref)
    from_fe = _from_files(nodout, rcforc)
    assert from_fe.origin.startswith("FE: ")
    assert from_fe.source == direct.source == "paper"
    for name in ("wall", "interface"):
        a, b = direct.elements[name], from_fe.elements[name]
        u = np.linspace(0.0, a.loading.domain_[1][0], 200)[:, None]
        fa, fb = a.loading.predict(u), b.loading.predict(u)
        # the files keep 5 significant digits: measured 1.3 / 2.2 ‰ RMS, 1.6 / 1.1 % max
        # (at the end of the box) of the peak force; k_u (from differences) 4 / 2 %
        assert np.sqrt(np.mean((fa - fb) ** 2)) < 5e-3 * np.max(fa)
        assert np.max(np.abs(fa - fb)) < 0.025 * np.max(fa)
        assert b.unloading_stiffness == pytest.approx(a.unloading_stiffness, rel=0.06)
        # the zone's own k_u (the scenario's 200 kN/mm): measured −2.9 % (wall), −0.9 %
        assert b.zone_unloading_stiffness == pytest.approx(200e6, rel=0.05)
    rows_a, ret_a = _episode(direct)
    rows_b, ret_b = _episode(from_fe)
    assert len(rows_b) == pytest.approx(len(rows_a), rel=0.02)
    assert ret_b == pytest.approx(ret_a, rel=0.02)
    last_a, last_b = rows_a[-1], rows_b[-1]
    assert last_b["stroke_exceeded"] == last_a["stroke_exceeded"] and not last_b["diverged"]
    for key in ("max_crush_m", "peak_decel_g", "mean_decel_g", "absorbed_energy_J"):
        np.testing.assert_allclose(last_b[key], last_a[key], rtol=0.01, err_msg=key)
    # and the saved element set reproduces the episode exactly
    path = save_crash_surrogate(from_fe, tmp_path / "elements.json")
    loaded = load_crash_surrogate(path)
    rows_c, ret_c = _episode(loaded)
    assert ret_c == ret_b and len(rows_c) == len(rows_b)
    with pytest.raises(FileExistsError):
        save_crash_surrogate(from_fe, path)


def test_command_line_writes_loadable_elements(fe_files, capsys):
    _, nodout, rcforc, tmp = fe_files
    out = tmp / "cli.json"
    args = [
        "--nodout",
        str(nodout),
        "--rcforc",
        str(rcforc),
        "--unit-system",
        "mm-ms-kg-kN",
        "--car-nodes",
        *map(str, NODES),
        "--wall-contact",
        "1",
        "--interface-contacts",
        "2",
        "--direction",
        "-1",
        "--scenario",
        "paper",
        "-o",
        str(out),
    ]
    assert main([*args, "--fmu-dir", str(tmp / "fmus")]) == 0
    assert set(load_crash_surrogate(out).elements) == {"wall", "interface"}
    assert sorted(p.name for p in (tmp / "fmus").iterdir()) == ["interface.fmu", "wall.fmu"]
    assert main(args) == 2
    assert "--overwrite" in capsys.readouterr().err
    bad = [a if a != "2" else "7" for a in args] + ["--overwrite"]
    assert main(bad) == 2
    assert "contact 7 is not in the rcforc data" in capsys.readouterr().err


def test_bad_element_files_are_clear_errors(tmp_path):
    p = tmp_path / "e.json"
    p.write_text('{"format": "railgym-crash-surrogate", "schema_version": 1, "elements": {}}')
    with pytest.raises(ValueError, match="has no 'wall' element"):
        load_crash_surrogate(p)
    p.write_text("{not json")
    with pytest.raises(ValueError, match="not valid JSON"):
        load_crash_surrogate(p)


def _drive(fmu, u, rate):
    """FMPy as master: at each sample step the slave, set (u, rate), read (f, permanent set)."""
    import shutil
    import tempfile

    from fmpy import extract, read_model_description
    from fmpy.fmi2 import FMU2Slave

    md = read_model_description(str(fmu))
    vr = {v.name: v.valueReference for v in md.modelVariables}
    unzipped = extract(str(fmu), unzipdir=tempfile.mkdtemp())
    slave = FMU2Slave(
        guid=md.guid,
        unzipDirectory=unzipped,
        modelIdentifier=md.coSimulation.modelIdentifier,
        instanceName="e",
    )
    out = np.zeros((u.size, 2))
    try:
        slave.instantiate()
        slave.setupExperiment(startTime=0.0)
        slave.enterInitializationMode()
        slave.exitInitializationMode()
        for n in range(u.size):
            if n > 0:
                slave.doStep(currentCommunicationPoint=(n - 1) * 5e-4, communicationStepSize=5e-4)
            slave.setReal([vr["u"], vr["rate"]], [u[n], rate[n]])
            out[n] = slave.getReal([vr["f"], vr["permanent_set"]])
        slave.terminate()
    finally:
        slave.freeInstance()
        shutil.rmtree(unzipped, ignore_errors=True)
    return out[:, 0], out[:, 1]


@pytest.mark.parametrize("variant", ["hysteretic", "paper"])
def test_crash_element_fmu_with_memory_reproduces_the_native_kernel(fe_files, tmp_path, variant):
    """Each element's FMU, driven with the crush (and crush rate) of railgym's native surrogate
    simulation step by step, gives that simulation's forces and permanent sets."""
    pytest.importorskip("fmpy", reason="the 'fmi' extra (fmpy) is not installed")
    from fmpy.validation import validate_fmu

    from railgym.vehicles.crash.fe import export_crash_element_fmu
    from railgym.vehicles.crash.surrogate_model import simulate_surrogate

    ref = fe_files[0]
    sur = build_crash_surrogate(ref, variant=variant)
    dt = 5e-4
    res = simulate_surrogate("paper", sur, sample_dt=dt, dt=dt)  # one step per sample
    # the kernel's crush rate: from the predicted velocities v + a·dt of the previous step
    vp = np.vstack([res.v[:1], res.v[:-1] + res.a[:-1] * dt])
    rates = {"wall": vp[:, 0], "interface": vp[:, 1] - vp[:, 0]}
    for j, name in enumerate(("wall", "interface")):
        fmu = export_crash_element_fmu(sur.elements[name], tmp_path / f"{name}.fmu")
        assert validate_fmu(str(fmu)) == []
        f, up = _drive(fmu, res.crush[:, j], rates[name])
        scale = np.max(np.abs(res.force[:, j]))
        np.testing.assert_allclose(f, res.force[:, j], rtol=0, atol=1e-12 * scale)
        np.testing.assert_allclose(up, res.permanent_set[:, j], rtol=0, atol=1e-15)
        if variant == "hysteretic":
            assert up.max() > 0.1  # the memory is exercised: metres of permanent crush
