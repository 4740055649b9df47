"""The hard-sphere protocols (ls, mls) end to end: the case checks, the command line,
the files, the closest-jamming search, and resume."""
import json

import numpy as np
import pandas as pd
import pytest

from analysis.io import read_contact_frames, read_particle_frames, read_thermo
from pysim.initial import write_initial
from pysim.io import read_particle_data
from pysim.protocols import ls as ls_driver
from rodcase.case import ConfigError, validate_case
from tests.runs import run_case, stopped_and_resumed

LS_CASE = {"particles": {"n": 200, "diameter": {"distribution": "mono", "mean": 1.0}},
           "protocol": {"name": "ls", "rate": 10.0,
                        "closest_jamming": {"final_rate": 0.02}},
           "output": {"dump_every": 25}, "seed": 3}


def read_blocks(path):
    return pd.read_csv(path, sep=r"\s+", comment="#", header=None,
                       names=["step", "time", "phi", "rate", "z", "temperature", "stage"])


def test_case_defaults_and_refusals():
    case = validate_case(LS_CASE)
    p = case["protocol"]
    assert (p["temperature"], p["pressure_max"], p["collisions_per_particle"]) == (0.2, 1e12, 20)
    cj = p["closest_jamming"]
    assert (cj["initial_rate"], cj["factor"], cj["max_equilibrations"]) == (10.0, 2.0, 50)
    mls = validate_case({**LS_CASE, "protocol": {"name": "mls"}})["protocol"]
    assert (mls["initial_rate"], mls["final_rate"]) == (10.0, 1e-4)
    bad = [({"protocol": {"name": "ls", "rate": 0.0}}, "protocol.rate = 0.0"),
           ({"particles": {"n": 200, "diameter": {"mean": 2.0}}},
            "particles.diameter.mean = 2.0"),
           ({"particles": {"n": 40, "diameter": {"mean": 1.0}}}, "particles.n = 40"),
           ({"contact": {"law": "hooke", "k_n": 1.0}}, "contact does not apply"),
           ({"protocol": {"name": "mls", "factor": 1.0}}, "protocol.factor = 1.0")]
    for change, message in bad:
        with pytest.raises(ConfigError, match=message.replace(".", r"\.")):
            validate_case({**LS_CASE, **change})
    # the other protocols still need a contact law
    with pytest.raises(ConfigError, match="missing key 'contact'"):
        validate_case({**LS_CASE, "protocol": {"name": "growth", "phi_init": 0.2, "rate": 1.0,
                                               "phi_grow": 0.5, "dt": 1e-3}})


def test_poisson_start(tmp_path):
    """Poisson points (overlapping) with diameters of mean 1 in the cube where they
    fill phi_nominal."""
    case = validate_case({**LS_CASE, "particles": {"n": 500, "diameter": {
        "distribution": "lognormal", "mean": 1.0, "sigma": 0.2}}})
    write_initial(case, tmp_path / "init.data")
    init = read_particle_data(tmp_path / "init.data")
    d = 2 * init["radius"]
    assert np.mean(d) == pytest.approx(1.0, rel=1e-12) and 0.15 < np.std(d) < 0.25
    assert np.sum(np.pi / 6 * d**3) / np.prod(init["box"]) == pytest.approx(0.64, rel=1e-9)
    x = init["x"]
    gaps = np.linalg.norm(x[:, None] - x[None], axis=-1) + np.eye(len(x)) * 1e9
    assert gaps.min() < 0.3  # overlapping at their nominal diameters


def test_ls_then_mls_from_the_command_line(tmp_path):
    """LS at rate 10 from a Poisson start ends unjammed at Z >= 1e12 below 0.63; the MLS
    search (here stopped at rate 0.02) densifies it; frames at the start, every 25
    blocks and at each stage's end, their diameters at the run's packing fraction and
    without overlaps; a thermo row per block."""
    out = run_case(tmp_path, LS_CASE)
    meta = json.loads((out / "run.json").read_text())
    assert 0.58 < meta["phi"] < 0.63 and meta["phi"] < meta["phi_j"] < 0.66
    assert meta["mls_reason"] == "final_rate"
    blocks = read_blocks(out / "blocks.dat")
    thermo = read_thermo(out / "thermo.dat")
    assert len(blocks) == len(thermo) == meta["blocks"]
    assert np.array_equal(blocks.step, thermo.step) and (np.diff(blocks.step) == 4000).all()
    ls, mls = blocks[blocks.stage == "ls"], blocks[blocks.stage == "mls"]
    assert (ls.z.iloc[:-1] < 1e12).all() and ls.z.iloc[-1] >= 1e12
    assert ls.phi.iloc[-1] == pytest.approx(meta["phi"], rel=1e-9)
    # one equilibration (rate 0) after each time the pressure reached 1e12 above the
    # final rate, then growth at half the rate before
    zero = (mls.rate == 0).to_numpy()
    assert np.sum(zero[1:] & ~zero[:-1]) == meta["mls_rate_decreases"]
    growth = mls.rate[~zero].unique()
    assert np.allclose(growth, 10.0 / 2.0 ** np.arange(len(growth)))
    assert mls.phi.iloc[-1] == pytest.approx(meta["phi_j"], rel=1e-9)
    frames = read_particle_frames(out / "particles.dump")
    steps = [f.step for f in frames]
    ends = [int(ls.step.iloc[-1]), int(mls.step.iloc[-1])]
    want = sorted({0, *ends, *blocks.step[np.arange(1, len(blocks) + 1) % 25 == 0]})
    assert steps == want
    assert [c.step for c in read_contact_frames(out / "contacts.dump")] == steps
    last = frames[-1]
    phi = np.sum(4 / 3 * np.pi * last.radius**3) / np.prod(last.box)
    assert phi == pytest.approx(meta["phi_j"], rel=1e-8)
    dr = last.x[:, None] - last.x[None]
    dr -= last.box * np.round(dr / last.box)
    gap = np.linalg.norm(dr, axis=-1) - (last.radius[:, None] + last.radius[None])
    assert gap[~np.eye(len(gap), dtype=bool)].min() > -1e-8  # 10 digits in the dump


def test_mls_of_a_poisson_start(tmp_path):
    out = run_case(tmp_path, {**LS_CASE, "protocol": {"name": "mls", "final_rate": 0.02}})
    meta = json.loads((out / "run.json").read_text())
    assert meta["phi_j"] == meta["phi"] and 0.6 < meta["phi_j"] < 0.66
    assert meta["phi_start"] < 1e-3


def test_resume_writes_what_the_uninterrupted_run_writes(tmp_path, monkeypatch):
    """A run stopped mid-stage and resumed from its last checkpoint ends with the same
    bytes in every file as the uninterrupted run."""
    case = validate_case({**LS_CASE, "protocol": {"name": "ls", "rate": 3.0, "closest_jamming": {
        "final_rate": 0.3}}, "output": {"dump_every": 7}})
    write_initial(case, tmp_path / "init.data")
    init = read_particle_data(tmp_path / "init.data")
    full = ls_driver.run(case, init, tmp_path / "full", progress=False)
    from pysim.hard.mls import MLS

    again = stopped_and_resumed(lambda out, **kw: ls_driver.run(case, init, out, **kw),
                                monkeypatch, MLS, 9, tmp_path / "full", tmp_path / "cut")
    assert again["phi_j"] == full["phi_j"] and again["collisions"] == full["collisions"]
