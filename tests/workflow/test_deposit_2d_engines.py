"""The LAMMPS cross-check of pysim's 2-D fed deposit (inputs/lammps/in.2d.rods.deposit,
workflows/engines/feed.py): the feed file holds pysim's own entries (redraws included),
the glued-disk rod has the stadium's mass and moment of inertia, the deck creates each
grain at its step, place, angle and velocity, and its output is read by the analysis as
pysim's is; a run stopped after a restart file goes on to the same end."""
import json
import math
import subprocess

import numpy as np
import pytest

from analysis.contacts import glued_bodies
from analysis.io import RunData, read_particle_frames
from analysis.summary import analyse_deposit
from pysim.initial import write_initial
from pysim.io import read_particle_data
from pysim.state import area, inertia_2d
from rodcase.case import validate_case
from workflows import engines
from workflows.engines import lammps
from workflows.engines.common import INPUTS, glued_spheres, venv_bin
from workflows.engines.feed import entries, read_feed, write_feed

D, ALPHA, RHO = 0.05, 9.0, 5e-6  # the paper's grains (deposition_paper_2d.yaml)


def fed_case(n, rate, height, dt, max_time, k_n, seed=1, **protocol):
    """A fed deposit of ``n`` of the paper's rods in a box 5 rod lengths wide (2.5 m):
    a Hertz law softened by ``k_n`` (N/m^1.5) so that the time step ``dt`` resolves it."""
    return validate_case({
        "particles": {"n": n, "dimension": 2, "aspect_ratio": ALPHA,
                      "diameter": {"distribution": "mono", "mean": D}, "density": RHO},
        "contact": {"law": "hertz", "k_n": k_n, "gamma_n": 1.8e-5 * math.sqrt(k_n / 1e3),
                    "k_t": 0.1 * k_n, "gamma_t": 6e-6 * math.sqrt(k_n / 1e3),
                    "friction": 0.5},
        "container": {"shape": "box", "width": 2.5}, "gravity": 10.0,
        "protocol": {"name": "deposit", "dt": dt, "max_time": max_time, "ke_ratio": 1e-4,
                     "feed": {"rate": rate, "height": height, "speed": 1.0}, **protocol},
        "output": {"thermo_every": 200, "dump_every": 1000}, "seed": seed})


def test_feed_file_is_pysims_draws(tmp_path):
    """pysim's own run enters every grain where the feed file says, the grains it drew
    again included (20 grains at 8 per second: 6 first spots blocked by a grain still near
    the entry line; the line so high that nothing lands, a soft law so that a large step
    runs it fast). The file reads back to the same entries."""
    from pysim.protocols import deposit

    n, rate, dt = 20, 8.0, 1e-3
    per = round(1.0 / (rate * dt))
    case = fed_case(n, rate, 100.0, dt, (n - 1) / rate + 0.5 * per * dt, k_n=1e-2, seed=2)
    case["output"] = {"thermo_every": per, "dump_every": per}
    write_initial(case, tmp_path / "init.data")
    init = read_particle_data(tmp_path / "init.data")
    e = entries(case, init)
    assert e.redrawn.sum() == 6
    with pytest.raises(deposit.NotSettledError):  # stopped while the grains still fall
        deposit.run(case, init, tmp_path / "pysim", progress=False)
    frames = {f.step: f for f in read_particle_frames(tmp_path / "pysim" / "particles.dump.part")}
    for k in range(n):
        f = frames[int(e.step[k])]
        i = int(np.flatnonzero(f.ids == e.ids[k])[0])
        assert f.n == k + 1
        np.testing.assert_allclose(f.x[i, :2], e.x[k], atol=1e-8)  # the dump's 10 digits
        assert math.atan2(f.axis[i, 1], f.axis[i, 0]) % math.pi == pytest.approx(e.theta[k],
                                                                                   abs=1e-8)
    # the file lists pysim's draws of every grain in order; the one pysim took is among them
    write_feed(tmp_path / "init.data", tmp_path / "feed.csv", case)
    rows = read_feed(tmp_path / "feed.csv")
    assert list(dict.fromkeys(rows["id"])) == list(e.ids)
    for k, gid in enumerate(e.ids):
        mine = rows["id"] == gid
        assert list(rows["try"][mine]) == list(range(mine.sum())) and mine.sum() >= 16
        assert set(rows["step"][mine]) == {e.step[k]}
        at = np.flatnonzero(mine & (rows["x"] == e.x[k, 0]) & (rows["y"] == e.x[k, 1]))
        assert len(at) == 1 and (rows["try"][at[0]] > 0) == e.redrawn[k]
        assert math.radians(rows["theta_deg"][at[0]]) == pytest.approx(e.theta[k], rel=1e-15)
        assert [rows["vx"][at[0]], rows["vy"][at[0]]] == list(e.v[k])


def test_feed_refuses_cases_it_cannot_replay():
    case = fed_case(4, 5.0, 10.0, 1e-4, 2.0, k_n=5.0)
    case["contact"]["gamma_bg"] = 0.1
    with pytest.raises(engines.EngineError, match="gamma_bg = 0.1.*use gamma_bg 0"):
        entries(case, {})
    assert "gamma_bg" in engines.supports("lammps", case)
    assert engines.supports("lammps", fed_case(4, 5.0, 10.0, 1e-4, 2.0, k_n=5.0)) is None


@pytest.mark.parametrize("alpha, spacing", [(9.0, 0.25), (9.0, 0.5), (4.0, 0.25)])
def test_disk_masses_give_the_stadiums_mass_and_inertia(alpha, spacing):
    """End and inner disk masses: total mass rho A and moment m_end L^2/2 + m_in sum s^2
    + 0.4 R^2 M equal to pysim's stadium (pysim.state.inertia_2d), summed disk by disk."""
    length = alpha * D
    n = glued_spheres(length, D, spacing)
    m_end, m_in = lammps.disk_masses(D, length, n, RHO)
    masses = np.full(n, m_in)
    masses[[0, -1]] = m_end
    s = np.linspace(-length / 2, length / 2, n)
    assert masses.sum() == pytest.approx(RHO * float(area(D / 2, length)), rel=1e-12)
    inertia = float(np.sum(masses * (s * s + 0.4 * (D / 2) ** 2)))
    assert inertia == pytest.approx(float(inertia_2d(D / 2, length, RHO)), rel=1e-12)
    assert lammps.disk_masses(D, length, 2, RHO) is None  # two disks: no freedom left


def lmp_deck(tmp_path, feed_rows, grains, **extra):
    """Run in.2d.rods.deposit on a hand-written feed (paper's grains, W = 2.5 m, entry
    line at 2 m); its screen text."""
    (tmp_path / "feed.csv").write_text("# id,step,try,x,y,theta_deg,vx,vy\n" + "\n".join(
        ",".join(str(v) for v in row) for row in [*feed_rows, (0,) * 8]) + "\n")
    args = {"feed": "feed.csv", "grains": grains, "width": 2.5, "height": 2.0,
            "thermo_every": 500, "check_every": 500, "dump_every": 1000, **extra}
    cmd = [venv_bin("lmp"), "-in", str(INPUTS / "lammps/in.2d.rods.deposit"),
           "-log", "log.lammps"]
    for k, v in args.items():
        cmd += ["-var", k, str(v)]
    r = subprocess.run(cmd, cwd=tmp_path, capture_output=True, text=True)
    assert r.returncode == 0 and "ERROR" not in r.stdout, r.stdout[-2000:]
    return r.stdout


@pytest.mark.engines
def test_deck_creates_each_grain_at_its_step_place_angle_and_velocity(tmp_path):
    """Three grains entering at steps 0, 1000 and 2000 (two of them rotated) are in the
    frames of their steps, whole, where and as the feed file puts them; the kinetic
    energy of each thermo row is that of the grains in free fall; the rigid bodies have
    the stadium's mass and moment of inertia (compute rigid/local)."""
    # grain 12's first draw would cross grain 11 (blocked: the deck takes its second draw);
    # grain 13's first draw is free, its second is never read
    rows = [(11, 0, 0, 1.25, 2.0, 30.0, 0.5, -0.25),
            (12, 1000, 0, 1.3, 2.0, 150.0, 0.0, 0.0), (12, 1000, 1, 0.6, 2.0, 120.0, -0.1, 0.35),
            (13, 2000, 0, 1.9, 1.5, 0.0, 0.0, 0.0), (13, 2000, 1, 0.3, 1.0, 90.0, 0.0, 0.0)]
    out = lmp_deck(tmp_path, rows, 3, max_steps=3000)
    m = RHO * float(area(D / 2, ALPHA * D))
    i_z = float(inertia_2d(D / 2, ALPHA * D, RHO))
    got = [ln for ln in out.splitlines() if "(compute rigid/local)" in ln][0].split()
    assert float(got[5]) == pytest.approx(m, rel=1e-8)
    assert float(got[7]) == pytest.approx(i_z, rel=1e-8)
    frames = {f.step: f for f in read_particle_frames(tmp_path / "particles.dump")}
    assert sorted(frames) == [0, 1000, 2000, 3000]
    mol = {}
    with open(tmp_path / "particles.dump") as fh:  # the molecule ids, frame by frame
        step = None
        for line in fh:
            if line.startswith("ITEM: TIMESTEP"):
                step = int(next(fh))
                mol[step] = []
            elif line[0].isdigit() and len(line.split()) > 5:
                mol[step].append(int(line.split()[1]))
    assert "rodpack: grain 12 draw 0 blocked" in out and out.count("blocked") == 1
    rows = [rows[0], rows[2], rows[3]]  # the draws taken
    dt = 5e-6
    for k, (gid, step, _, x, y, th, vx, vy) in enumerate(rows):
        fr = frames[step]
        rods, _ = glued_bodies(fr, np.array(mol[step]))
        assert rods.n == k + 1 and list(rods.ids) == [r[0] for r in rows[:k + 1]]
        np.testing.assert_allclose(rods.x[k, :2], [x, y], atol=1e-9)
        assert math.degrees(math.atan2(rods.axis[k, 1], rods.axis[k, 0])) % 180 == \
            pytest.approx(th, abs=1e-6)
        np.testing.assert_allclose(rods.length, ALPHA * D, rtol=1e-9)
    th = np.loadtxt(tmp_path / "thermo.dat")
    for step, ke in th[:, [0, 4]]:
        v2 = sum(vx**2 + (vy - 10.0 * (step - s0) * dt) ** 2
                 for _, s0, _, _, _, _, vx, vy in rows if s0 <= step)
        assert ke == pytest.approx(0.5 * m * v2, rel=1e-9)


@pytest.fixture(scope="module")
def small_fed(tmp_path_factory):
    """Eight grains fed at 10 per second from 0.8 m above the base, a Hertz law soft
    enough for a step of 1e-4 s: settles in a second or two."""
    d = tmp_path_factory.mktemp("fed2d")
    case = fed_case(8, 10.0, 0.8, 1e-4, 6.0, k_n=5.0)
    write_initial(case, d / "init.data")
    return case, d


@pytest.mark.engines
@pytest.mark.slow
def test_pipeline_runs_the_fed_case_on_both_engines(small_fed, tmp_path):
    """engines.run takes the case to LAMMPS (feed file from init.data, deck, conversion):
    a settled deposit of rods inside the box, its wall rows in pysim's numbering (x = 0,
    x = W, base = -1, -2, -3) carrying the weight; the analysis reads it as pysim's run of
    the same case (the same observables, finite)."""
    from pysim.protocols import deposit

    case, d = small_fed
    summary = engines.run("lammps", case, d / "init.data", tmp_path / "lammps", timeout=600)
    assert summary["settled"]
    run = RunData(tmp_path / "lammps")
    frame, contacts = run.frames()[-1]
    assert frame.n == 8
    np.testing.assert_allclose(frame.length, ALPHA * D, rtol=1e-6)
    ends = np.concatenate([frame.x + 0.5 * ALPHA * D * frame.axis,
                           frame.x - 0.5 * ALPHA * D * frame.axis])
    assert np.all(ends[:, 0] > 0.5 * D - 0.005) and np.all(ends[:, 0] < 2.5 - 0.5 * D + 0.005)
    assert np.all(ends[:, 1] > 0.5 * D - 0.005)
    walls = contacts.j < 0
    assert set(contacts.j[walls]) <= {-1, -2, -3} and np.any(contacts.j == -3)
    # the walls carry the weight (settled to 1e-4 of the peak kinetic energy: the soft
    # contacts still ring a little)
    weight = RHO * float(np.sum(frame.particle_measures())) * 10.0
    assert float(np.sum(contacts.force[walls, 1])) == pytest.approx(weight, rel=0.25)

    init = read_particle_data(d / "init.data")
    deposit.run(case, init, tmp_path / "pysim", progress=False)
    got = {}
    for engine in ("lammps", "pysim"):
        rows, _ = analyse_deposit(tmp_path / engine, width=2.5, gravity=10.0, slab=0.5,
                                  density=RHO, base_wall_id=-3)
        got[engine] = {name: value for name, value, _ in rows}
    assert got["lammps"].keys() == got["pysim"].keys()
    for engine in got:
        assert 0.1 < got[engine]["phi_deposit"] < 1.0
        assert 0.0 <= got[engine]["angle_mean"] <= 90.0
        assert np.isfinite(got[engine]["apparent_mass_fraction"])
    # eight grains lie flat on the base in both (measured: phi 0.62 and 0.64, mean angles
    # 4.2 and 4.5 degrees)
    assert got["lammps"]["phi_deposit"] == pytest.approx(got["pysim"]["phi_deposit"], abs=0.1)
    assert got["lammps"]["angle_mean"] == pytest.approx(got["pysim"]["angle_mean"], abs=10.0)


@pytest.mark.engines
@pytest.mark.slow
def test_fed_deposit_resumes(small_fed, tmp_path):
    """Stopped after a restart file, with some grains still to enter, the run goes on: the
    deck counts the grains in the restart, skips their feed rows, enters the grain due at
    the restart step, and follows the unbroken run (kinetic energy within 1e-6 over the
    1800 steps after the restart, three more grains entering; later the two drift apart
    as any granular pair of runs whose chunks differ: the settling step differed by 400
    steps when measured)."""
    case, d = small_fed
    out = tmp_path / "run"
    work = out / "work"
    work.mkdir(parents=True)
    (work / "resume.json").write_text(json.dumps(engines.resume_stamp("lammps", case,
                                                                      d / "init.data")))
    area_ = write_feed(d / "init.data", work / "feed.csv", case)
    (work / "measure.txt").write_text(repr(area_))
    every = engines.restart_interval(case)
    stop = 2 * every + 100
    assert stop < int(entries(case, read_particle_data(d / "init.data")).step[-1])
    cmd = engines.command("lammps", (work / "feed.csv").resolve(), work.resolve(), case,
                          extra_vars={"restart_every": every, "max_steps": stop})
    with open(work / "screen.txt", "w") as screen:
        subprocess.run(cmd, cwd=work, check=True, stdout=screen, stderr=subprocess.STDOUT)
    assert max(int(p.name.split(".")[1]) for p in work.glob("restart.*")) == 2 * every

    summary = engines.run("lammps", case, d / "init.data", out, timeout=600)
    assert summary["resumed_from"].endswith(f"restart.{2 * every}") and summary["settled"]
    ref = engines.run("lammps", case, d / "init.data", tmp_path / "full", timeout=600)
    a, b = RunData(out).thermo, RunData(tmp_path / "full").thermo
    assert list(a.step[:30]) == list(b.step[:30])
    np.testing.assert_allclose(a.ke[:30], b.ke[:30], rtol=1e-6)
