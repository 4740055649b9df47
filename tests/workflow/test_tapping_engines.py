"""The LAMMPS tapping deck (inputs/lammps/in.rods.tap): the same frame steps as pysim,
rods kept inside the cylinder, the settled packing close to pysim's from the same start,
and a run cut off after a restart file goes on to the same plan."""
import json
import subprocess

import numpy as np
import pytest
import yaml

from analysis.io import RunData
from analysis.summary import analyse_tapping
from pysim.protocols.tapping import plan
from tests.runs import (assert_in_the_tapped_container, assert_resumed_like_uninterrupted,
                        prepared)
from tests.cases import TAP, TAP_D as D
from workflows import engines
from rodcase.case import validate_case


def observables(case, run_dir):
    tp = plan(case["protocol"], case["gravity"])
    rows, curves, _ = analyse_tapping(run_dir, start_step=tp.start, dt=tp.dt, period=tp.period,
                                      amplitude=tp.amplitude, frames_per_tap=tp.frames_per_tap,
                                      container_diameter=case["container"]["diameter"],
                                      layer_thickness=5 * D)
    return {name: value for name, value, _ in rows}, curves


@pytest.fixture(scope="module")
def tap_case(tmp_path_factory):
    return prepared(tmp_path_factory, "taplmp", TAP)


@pytest.mark.engines
def test_lammps_tapping_deck(tap_case, tmp_path):
    case, d = tap_case
    engines.run("lammps", case, d / "init.data", tmp_path / "lammps", timeout=600)
    tp = plan(case["protocol"], case["gravity"])
    run = RunData(tmp_path / "lammps")
    frames = run.frames()
    assert [f.step for f, _ in frames] == list(tp.frame_steps)
    for f, _ in frames:
        np.testing.assert_allclose(f.length, 2 * D, rtol=1e-6)
    # glued spheres reach the spherocylinder's ends: the same wall tests as pysim
    assert_in_the_tapped_container(frames, case, tp, D)
    th = run.thermo
    assert th.step.is_unique and th.phi.isna().all() and np.isfinite(th.ke).all()

    # pysim from the same initial rods: the settled packing agrees to the loose-packing
    # scatter of 30 rods (the quick profile's 400 rods agree within 0.01)
    (tmp_path / "case.yaml").write_text(yaml.safe_dump(case))
    import sys

    r = subprocess.run([sys.executable, "-m", "pysim", "run", str(tmp_path / "case.yaml"),
                        "--data", str(d / "init.data"), "--out", str(tmp_path / "pysim"),
                        "--no-progress"], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    lmp, _ = observables(case, tmp_path / "lammps")
    ref, _ = observables(case, tmp_path / "pysim")
    assert lmp["phi_settled"] == pytest.approx(ref["phi_settled"], abs=0.06)
    assert lmp["angle_settled"] == pytest.approx(ref["angle_settled"], abs=6.0)


@pytest.mark.engines
def test_lammps_tapping_resumes_mid_tap(tap_case, tmp_path):
    """A run that stopped after a restart file written while tapping (made here by
    running the same deck for fewer taps, as a crash would leave it) is resumed by
    :func:`workflows.engines.run`: outputs cut back, the base phase continued from the
    absolute step, every frame of the plan written once."""
    case, d = tap_case
    case = validate_case({**TAP, "protocol": {**TAP["protocol"], "taps": 3}})
    tp = plan(case["protocol"], case["gravity"])
    every = engines.restart_interval(case)
    assert tp.start < every * (tp.start // every + 1) < tp.end - 2 * tp.frames_per_tap

    out = tmp_path / "run"
    work = out / "work"
    work.mkdir(parents=True)
    stamp = engines.resume_stamp("lammps", case, d / "init.data")
    (work / "resume.json").write_text(json.dumps(stamp))
    vrods = engines.write_glued_data(d / "init.data", work / "glued.data", case)
    (work / "vrods.txt").write_text(repr(float(vrods)))
    short = validate_case({**TAP, "protocol": {**TAP["protocol"], "taps": 2}})
    cut_at = plan(short["protocol"], short["gravity"]).end
    cmd = engines.command("lammps", (work / "glued.data").resolve(), work.resolve(), short,
                          extra_vars={"restart_every": every, "vrods": repr(float(vrods))})
    subprocess.run(cmd, cwd=work, check=True, capture_output=True)
    restarts = sorted(int(p.name.split(".")[1]) for p in work.glob("restart.*"))
    assert restarts and tp.start < restarts[-1] < cut_at
    # a kill while writing the next restart file leaves it short: it must be passed over
    newest = (work / f"restart.{restarts[-1]}").read_bytes()
    (work / f"restart.{cut_at}").write_bytes(newest[: len(newest) * 2 // 3])

    summary = engines.run("lammps", case, d / "init.data", out, timeout=600)
    assert summary["resumed_from"].endswith(f"restart.{restarts[-1]}")
    run = RunData(out)
    assert [f.step for f, _ in run.frames()] == list(tp.frame_steps)
    th = run.thermo
    assert th.step.is_monotonic_increasing and th.step.is_unique
    assert th.step.iloc[-1] == tp.end

    # the same case uninterrupted: identical up to the restart step, and the resumed
    # taps shake the packing the same way (base phase continued, not restarted)
    full = tmp_path / "full"
    engines.run("lammps", case, d / "init.data", full, timeout=600)
    assert_resumed_like_uninterrupted(th, full, restarts[-1])
