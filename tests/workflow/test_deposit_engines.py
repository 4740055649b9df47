"""The LAMMPS deposition deck (inputs/lammps/in.rods.deposit): settled rods inside the box
in the common format, the deposit close to pysim's from the same column, and a run cut
off after a restart file goes on to the same end (the peak kinetic energy passed back)."""
import json
import subprocess
import sys

import numpy as np
import pytest
import yaml

from analysis.io import RunData
from analysis.summary import analyse_deposit
from pysim.initial import write_initial
from tests.runs import prepared
from tests.cases import DEP_SMALL, deposit_with
from workflows import engines
from rodcase.case import validate_case


@pytest.fixture(scope="module")
def dep_case(tmp_path_factory):
    return prepared(tmp_path_factory, "deplmp", DEP_SMALL)


def phi_deposit(run_dir):
    rows, _ = analyse_deposit(run_dir, width=6.0, gravity=1.0, slab=3.0)
    return {n: x for n, x, _ in rows}["phi_deposit"]


@pytest.mark.engines
def test_lammps_deposit_deck(dep_case, tmp_path):
    case, d = dep_case
    summary = engines.run("lammps", case, d / "init.data", tmp_path / "lammps", timeout=600)
    assert summary["settled"]
    run = RunData(tmp_path / "lammps")
    frames = run.frames()
    frame, contacts = frames[-1]
    assert frame.n == 40 and frame.step == run.thermo.step.iloc[-1]
    assert [f.step for f, _ in frames] == sorted({f.step for f, _ in frames})
    np.testing.assert_allclose(frame.length, 2.0, rtol=1e-6)
    w = case["container"]["width"]
    ends = np.concatenate([frame.x + frame.axis, frame.x - frame.axis])  # half length 1
    assert np.all(ends[:, :2] > 0.5 - 0.01) and np.all(ends[:, :2] < w - 0.5 + 0.01)
    assert np.all(ends[:, 2] > 0.5 - 0.01)
    assert np.all(contacts.overlap < 0.02)
    # the wall fixes' contacts become wall rows in pysim's numbering (x = 0, x = W, y = 0,
    # y = W, base = -1 ... -5), at the walls, and at rest they carry the deposit's weight
    walls = contacts.j <= 0
    assert set(contacts.j[walls]) <= {-1, -2, -3, -4, -5} and np.any(contacts.j == -5)
    for wid, axis, at in ((-1, 0, 0.0), (-2, 0, w), (-3, 1, 0.0), (-4, 1, w), (-5, 2, 0.0)):
        on = contacts.j == wid
        np.testing.assert_allclose(contacts.point[on, axis], at, atol=0.02)
        assert np.all(contacts.normal[on, axis] == (1.0 if at > 0 else -1.0))
    weight = case["particles"]["density"] * float(np.sum(frame.particle_measures()))
    assert float(np.sum(contacts.force[walls, 2])) == pytest.approx(weight, rel=0.01)
    rows, _ = analyse_deposit(tmp_path / "lammps", width=w, gravity=1.0, slab=3.0,
                              base_wall_id=-5)
    # LAMMPS now gives the apparent mass at the base (this column falls freely, so its
    # walls may push down: above 1 is possible, docs/studies/deposition.md)
    assert 0.5 < {n: x for n, x, _ in rows}["apparent_mass_fraction"] < 1.5

    (tmp_path / "case.yaml").write_text(yaml.safe_dump(case))
    r = subprocess.run([sys.executable, "-m", "pysim", "run", str(tmp_path / "case.yaml"),
                        "--data", str(d / "init.data"), "--out", str(tmp_path / "pysim"),
                        "--no-progress"], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    # 40 rods: the loose-packing scatter of a few grain layers
    assert phi_deposit(tmp_path / "lammps") == pytest.approx(phi_deposit(tmp_path / "pysim"),
                                                             abs=0.08)


@pytest.mark.engines
def test_lammps_deposit_resumes(dep_case, tmp_path):
    """Stopped after a restart file (made by running the deck to an earlier max_steps,
    as a crash would leave it), the run goes on: the outputs are cut back, the running
    peak of the kinetic energy is read back from the log, and the deposit settles at the
    same step as an unbroken run."""
    case, d = dep_case
    out = tmp_path / "run"
    work = out / "work"
    work.mkdir(parents=True)
    stamp = engines.resume_stamp("lammps", case, d / "init.data")
    (work / "resume.json").write_text(json.dumps(stamp))
    vrods = engines.write_glued_data(d / "init.data", work / "glued.data", case)
    (work / "vrods.txt").write_text(repr(float(vrods)))
    every = engines.restart_interval(case)
    cmd = engines.command("lammps", (work / "glued.data").resolve(), work.resolve(), case,
                          extra_vars={"restart_every": every, "vrods": repr(float(vrods)),
                                      "max_steps": 3 * every + 500})
    with open(work / "screen.txt", "w") as screen:
        subprocess.run(cmd, cwd=work, check=True, stdout=screen, stderr=subprocess.STDOUT)
    restarts = sorted(int(p.name.split(".")[1]) for p in work.glob("restart.*"))
    assert restarts[-1] == 3 * every

    summary = engines.run("lammps", case, d / "init.data", out, timeout=600)
    assert summary["resumed_from"].endswith(f"restart.{3 * every}") and summary["settled"]
    full = tmp_path / "full"
    ref = engines.run("lammps", case, d / "init.data", full, timeout=600)
    assert summary["steps"] == ref["steps"]
    a, b = RunData(out), RunData(full)
    assert list(a.thermo.step) == list(b.thermo.step)
    assert [f.step for f, _ in a.frames()] == [f.step for f, _ in b.frames()]
    np.testing.assert_allclose(a.frames()[-1][0].x, b.frames()[-1][0].x, atol=1e-6)


@pytest.mark.engines
def test_lammps_deposit_rain_drag(dep_case, tmp_path):
    """protocol.rain_speed on LAMMPS: fix viscous on the spheres caps the rods' fall speed
    until rain_time, as in pysim (kinetic energy below that of every rod at rain_speed;
    free fall from this column: far above), then it is removed and the deposit settles."""
    from pysim.protocols.deposit import grain_mass

    _, d = dep_case
    case = validate_case(deposit_with(particles__n=40, protocol__v_init=0.0,
                                      protocol__rain_speed=1.0, protocol__rain_time=15.0))
    v = engines.deposit_deck_vars(case)
    assert int(v["rain_steps"]) == 150_000 and int(v["min_steps"]) >= 150_000
    assert float(v["drag"]) == pytest.approx(grain_mass(case) * 1.0 / 1.0)
    write_initial(case, tmp_path / "init.data")
    summary = engines.run("lammps", case, tmp_path / "init.data", tmp_path / "run", timeout=600)
    assert summary["settled"]
    screen = (tmp_path / "run" / "work" / "screen.txt").read_text()
    assert "rodpack: rain drag off at step 150000" in screen
    th = RunData(tmp_path / "run").thermo
    bound = 0.5 * 40 * grain_mass(case) * 1.0**2
    assert 0.1 * bound < th.ke.max() < bound
    assert th.step.iloc[-1] >= 150_000
