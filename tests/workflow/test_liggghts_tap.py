"""LIGGGHTS' tapping deck (inputs/liggghts/in.rods.tap): multisphere rods inserted at random
settle in the cylinder, then the mesh base oscillates. The base really moves as
z_b = a sin(2 pi nu (t - t0)) (read back from the moved mesh), frames fall on the plan's
steps and phases, rods stay whole and inside the container, the settled packing rests on
the base (the wall rows carry its weight) and agrees with pysim's to the scatter of a loose
packing of 30 rods. Without the binary only the mapping of the case to the deck runs."""
import json
import math
import shutil
import subprocess
import sys
from dataclasses import replace

import numpy as np
import pytest
import yaml

from analysis.contacts import glued_bodies
from analysis.io import RunData, read_particle_frames
from analysis.summary import analyse_tapping
from pysim.initial import write_initial
from pysim.protocols.tapping import plan
from tests.conftest import needs_liggghts
from tests.runs import assert_resumed_like_uninterrupted, prepared
from tests.cases import TAP, TAP_D as D
from workflows import engines
from rodcase.case import validate_case


def with_(**changes):
    """TAP with ``section__key=value`` changes (a deep copy)."""
    case = yaml.safe_load(yaml.safe_dump(TAP))
    for key, value in changes.items():
        section, name = key.split("__")
        case[section][name] = value
    return case


#: the adapter of LIGGGHTS' tapping deck (workflows.engines.table)
TAP_KEY = ("liggghts", "rods", "tapping")


def with_base_dump(tap):
    """The tapping deck's -var values with the moved base written at every frame."""
    return lambda c: {**tap.variables(c), "base_dump": "1"}


def observables(case, run_dir):
    tp = plan(case["protocol"], case["gravity"])
    rows, _curves, _ = analyse_tapping(run_dir, start_step=tp.start, dt=tp.dt, period=tp.period,
                                       amplitude=tp.amplitude, frames_per_tap=tp.frames_per_tap,
                                       container_diameter=case["container"]["diameter"],
                                       layer_thickness=5 * D)
    return {name: value for name, value, _ in rows}


def base_heights(work):
    """``{step: z}`` of the moved base mesh (``base.<step>.stl``, every vertex at one z)."""
    out = {}
    for path in work.glob("base.*.stl"):
        z = [float(line.split()[3]) for line in path.read_text().splitlines()
             if line.strip().startswith("vertex")]
        assert len(z) == 6 and np.ptp(z) == 0.0, path  # two flat triangles
        out[int(path.name.split(".")[1])] = z[0]
    return out


@pytest.fixture(scope="module")
def tapped(tmp_path_factory):
    """One LIGGGHTS tapping run of TAP (30 rods of alpha 2, two taps) through
    :func:`workflows.engines.run`, with the moved base written at every frame and the
    sphere dump kept as ``work/spheres.dump``."""
    if shutil.which("liggghts") is None:
        pytest.skip("LIGGGHTS is not installed")
    case, d = prepared(tmp_path_factory, "ligtap", TAP)
    tap = engines.ADAPTERS[TAP_KEY]

    def keep_spheres(work, c, data):  # the sphere dump, before it becomes rods
        shutil.copy(work / "particles.dump", work / "spheres.dump")
        return tap.convert(work, c, data)

    with pytest.MonkeyPatch.context() as mp:
        mp.setitem(engines.ADAPTERS, TAP_KEY, replace(tap, variables=with_base_dump(tap),
                                                      convert=keep_spheres))
        summary = engines.run("liggghts", case, d / "init.data", d / "run", timeout=300)
    return case, d, summary


def test_case_maps_to_the_deck():
    case = validate_case(TAP)
    assert engines.supports("liggghts", case) is None
    assert engines.deck("liggghts", case).name == "in.rods.tap"
    v = engines.deck_vars(case, "liggghts")
    lmp = engines.tap_deck_vars(case)
    # the same step plan, base motion and contact law as the LAMMPS deck
    for key in ("settle_steps", "relax_steps", "freq", "amp", "taps", "frames_per_tap", "dt",
                "k_n", "gamma_n", "k_t", "mu", "mu_wall", "g", "radius_c", "drag", "spheres",
                "thermo_every", "skin"):
        assert v[key] == lmp[key], key
    assert float(v["gamma_t"]) == pytest.approx(float(lmp["x_gamma_t"]) * float(lmp["gamma_n"]))
    assert v["n_rods"] == "30" and v["spheres"] == "5"  # alpha 2 at spacing D/2
    assert float(v["radius"]) == pytest.approx(D / 2) and float(v["length"]) == pytest.approx(2 * D)
    # the column holds pysim's (packing fraction phi_init) and the rods' bounding spheres
    rod = math.pi * D**2 * 2 * D / 4 + math.pi * D**3 / 6
    column = 30 * rod / (0.15 * math.pi * (4 * D) ** 2)
    assert float(v["height"]) >= column + 3 * D
    assert engines.liggghts_tap_column(case) == pytest.approx(float(v["height"]))
    # what the deck cannot do is said
    hertz = validate_case({**TAP, "contact": {"law": "hertz", "k_n": 1e3, "k_t": 100.0,
                                              "friction": 0.5}})
    assert "linear law" in engines.supports("liggghts", hertz)
    poly = validate_case(with_(particles__diameter={"distribution": "bidisperse", "mean": D,
                                                    "ratio": 1.4, "fraction_big": 0.5}))
    assert "mono" in engines.supports("liggghts", poly)
    narrow = validate_case(TAP)  # validate_case itself wants 1.5 (L + D): a hand-made case
    narrow["container"]["diameter"] = 2.5 * D
    assert "bounding sphere" in engines.supports("liggghts", narrow)
    with pytest.raises(engines.EngineError, match="bounding sphere"):
        engines.liggghts_tap_vars(narrow)


@pytest.mark.engines
@needs_liggghts
def test_base_oscillates_as_planned(tapped):
    """The mesh base sits at a sin(2 pi nu (t - t0)) at every frame: at rest for frame 0,
    +a and -a a quarter and three quarters into each tap, back at 0 after whole taps."""
    case, d, _ = tapped
    tp = plan(case["protocol"], case["gravity"])
    z = base_heights(d / "run" / "work")
    assert sorted(z) == list(tp.frame_steps)
    steps = np.array(sorted(z))
    zb = np.array([z[s] for s in steps])
    # 6 digits in the STL file
    np.testing.assert_allclose(zb, tp.base_height(steps), rtol=0, atol=1e-5 * tp.amplitude)
    fpt = tp.frames_per_tap
    assert zb[0] == 0.0
    np.testing.assert_allclose(zb[1::fpt], tp.amplitude, rtol=1e-3)
    np.testing.assert_allclose(zb[3::fpt], -tp.amplitude, rtol=1e-3)
    np.testing.assert_allclose(zb[fpt::fpt], 0.0, atol=5e-3 * tp.amplitude)


@pytest.mark.engines
@needs_liggghts
def test_frames_hold_whole_rods_inside_the_container(tapped):
    case, d, summary = tapped
    tp = plan(case["protocol"], case["gravity"])
    assert summary["status"] == "ok" and summary["resumed_from"] is None
    run = RunData(d / "run")
    frames = run.frames()
    assert [f.step for f, _ in frames] == list(tp.frame_steps)
    rc = 0.5 * case["container"]["diameter"]
    for f, contacts in frames:
        assert f.n == 30 and sorted(f.ids) == list(range(1, 31))
        np.testing.assert_allclose(f.length, 2 * D, rtol=1e-6)
        np.testing.assert_allclose(f.radius, D / 2)
        ends = np.concatenate([f.x + 0.5 * f.length[:, None] * f.axis,
                               f.x - 0.5 * f.length[:, None] * f.axis])
        r = np.tile(f.radius, 2)
        assert np.all(np.hypot(ends[:, 0], ends[:, 1]) + r < rc + 0.05 * D)
        assert np.all(ends[:, 2] - r > tp.base_height(f.step) - 0.05 * D)
        assert np.all((contacts.overlap > 0) & (contacts.overlap < 0.05 * D))
        assert set(np.unique(contacts.j[contacts.j < 0])) <= {-1, -2}  # base, cylinder
    th = run.thermo
    assert th.step.is_unique and th.phi.isna().all() and np.isfinite(th.ke).all()

    # the rods stay rigid: the 5 spheres of every body on one line, D/2 apart (sphere
    # positions as LIGGGHTS wrote them)
    dump = d / "run" / "work" / "spheres.dump"
    for fr, table in zip(read_particle_frames(dump), _tables(dump)):
        body = table["id_multisphere"][np.argsort(table["id"])].astype(int)
        assert np.all(np.bincount(body)[1:] == 5)
        rods, row = glued_bodies(fr, body)
        along = np.einsum("ij,ij->i", fr.x - rods.x[row], rods.axis[row])
        off = fr.x - rods.x[row] - along[:, None] * rods.axis[row]
        assert np.abs(off).max() < 1e-9  # metres
        for b in range(30):
            np.testing.assert_allclose(np.sort(along[row == b]), np.linspace(-D, D, 5),
                                       atol=1e-9)


def _tables(path):
    """Every frame of a LIGGGHTS sphere dump as a structured array named by its columns."""
    lines = path.read_text().splitlines()
    k, out = 0, []
    while k < len(lines):
        if lines[k].startswith("ITEM: TIMESTEP"):
            n = int(lines[k + 3])
            cols = lines[k + 8].split()[2:]
            rows = np.array([r.split() for r in lines[k + 9:k + 9 + n]], dtype=float)
            out.append(np.rec.fromarrays(rows.T, names=[c.replace("[", "_").replace("]", "")
                                                        for c in cols]))
            k += 9 + n
        else:
            k += 1
    return out


@pytest.mark.engines
@needs_liggghts
def test_settled_packing_rests_on_the_base(tapped):
    """Frame 0 (before the first tap) is at rest: the walls carry the rods' weight (the
    base most of it, the cylinder the rest through friction), the lowest rods touch the
    base, and the kinetic energy has decayed by orders of magnitude since the fall."""
    case, d, _ = tapped
    f, contacts = RunData(d / "run").frames()[0]
    rod = math.pi * D**2 * 2 * D / 4 + math.pi * D**3 / 6
    weight = 30 * 2500.0 * rod * 9.81
    wall = contacts.j < 0
    assert contacts.force[wall, 2].sum() == pytest.approx(weight, rel=1e-3)
    assert contacts.force[contacts.j == -1, 2].sum() > 0.5 * weight
    low = f.x[:, 2] - 0.5 * f.length * np.abs(f.axis[:, 2]) - f.radius
    assert abs(low.min()) < 0.01 * D
    th = RunData(d / "run").thermo.set_index("step")
    tp = plan(case["protocol"], case["gravity"])
    assert th.loc[tp.start, "ke"] < 1e-4 * th.ke.loc[:tp.settle_steps].max()


@pytest.mark.engines
@needs_liggghts
def test_settled_packing_agrees_with_pysim(tapped, tmp_path):
    """Not the same start (LIGGGHTS inserts its own rods), so only the loose-packing scatter
    of 30 rods is expected: density within 0.06, mean angle to the base within 8 degrees."""
    case, d, _ = tapped
    (tmp_path / "case.yaml").write_text(yaml.safe_dump(case))
    r = subprocess.run([sys.executable, "-m", "pysim", "run", str(tmp_path / "case.yaml"),
                        "--data", str(d / "init.data"), "--out", str(tmp_path / "pysim"),
                        "--no-progress"], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    lig, ref = observables(case, d / "run"), observables(case, tmp_path / "pysim")
    assert lig["phi_settled"] == pytest.approx(ref["phi_settled"], abs=0.06)
    assert lig["angle_settled"] == pytest.approx(ref["angle_settled"], abs=8.0)
    assert lig["taps"] == pytest.approx(2.0, abs=1e-3)


@pytest.mark.engines
@needs_liggghts
def test_liggghts_tapping_resumes_mid_tap(tmp_path):
    """A run that stopped after a restart file written while tapping (made here by running
    the same deck for fewer taps, as a crash would leave it, with a newest restart file
    cut short) is resumed by :func:`workflows.engines.run`: outputs cut back, every frame
    of the plan written once, the base phase continued from the absolute step."""
    case = validate_case({**TAP, "protocol": {**TAP["protocol"], "taps": 3}})
    tp = plan(case["protocol"], case["gravity"])
    every = engines.restart_interval(case)
    assert tp.start < every * (tp.start // every + 1) < tp.end - 2 * tp.frames_per_tap
    write_initial(case, tmp_path / "init.data")

    out = tmp_path / "run"
    work = out / "work"
    work.mkdir(parents=True)
    stamp = engines.resume_stamp("liggghts", case, tmp_path / "init.data")
    (work / "resume.json").write_text(json.dumps(stamp))
    short = validate_case({**TAP, "protocol": {**TAP["protocol"], "taps": 2}})
    cut_at = plan(short["protocol"], short["gravity"]).end
    cmd = engines.command("liggghts", (tmp_path / "init.data").resolve(), work.resolve(), short,
                          extra_vars={"restart_every": every, "base_dump": 1})
    subprocess.run(cmd, cwd=work, check=True, capture_output=True)
    restarts = sorted(int(p.name.split(".")[1]) for p in work.glob("restart.*"))
    assert restarts and tp.start < restarts[-1] < cut_at
    # a kill while writing the next restart file leaves it short: it must be passed over
    newest = (work / f"restart.{restarts[-1]}").read_bytes()
    (work / f"restart.{cut_at}").write_bytes(newest[: len(newest) * 2 // 3])
    assert not engines.liggghts_restart_is_complete(work / f"restart.{cut_at}")

    tap = engines.ADAPTERS[TAP_KEY]
    with pytest.MonkeyPatch.context() as mp:
        mp.setitem(engines.ADAPTERS, TAP_KEY, replace(tap, variables=with_base_dump(tap)))
        summary = engines.run("liggghts", case, tmp_path / "init.data", out, timeout=300)
    assert summary["resumed_from"].endswith(f"restart.{restarts[-1]}")
    run = RunData(out)
    assert [f.step for f, _ in run.frames()] == list(tp.frame_steps)
    th = run.thermo
    assert th.step.is_monotonic_increasing and th.step.is_unique
    z = base_heights(work)  # the base after the restart continues the plan's oscillation
    steps = np.array(sorted(z))
    np.testing.assert_allclose([z[s] for s in steps], tp.base_height(steps), rtol=0,
                               atol=1e-5 * tp.amplitude)

    # the same case uninterrupted: identical up to the restart step, and the resumed
    # taps shake the packing the same way (base phase continued, not restarted)
    full = tmp_path / "full"
    engines.run("liggghts", case, tmp_path / "init.data", full, timeout=300)
    assert_resumed_like_uninterrupted(th, full, restarts[-1])
