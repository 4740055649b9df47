"""Protocol drivers end to end through the CLI, on small systems."""
import json
import subprocess
import sys

import numpy as np
import pandas as pd
import pytest
import yaml

from analysis.io import RunData
from pysim.initial import write_initial
from rodcase.case import validate_case
from tests.cases import growth_case
from tests.runs import run_case


def read_cycles(path):
    """A growth run's ``cycles.dat`` (or ``.part``) as a table."""
    return pd.read_csv(path, sep=r"\s+", comment="#", header=None,
                       names=["step", "phi", "e", "p", "nc", "jammed", "iterations",
                              "residual", "settled"])


def test_growth_to_jamming_of_spheres(tmp_path):
    out = run_case(tmp_path, growth_case(150, 2, phi_grow=0.58, increment=0.01,
                                         tolerance=5e-4))
    import json

    meta = json.loads((out / "run.json").read_text())
    cycles = read_cycles(out / "cycles.dat")
    assert 0.60 < meta["phi_j"] < 0.67
    assert meta["phi_j"] - meta["phi_j_low"] < 5e-4
    jammed = cycles[cycles.jammed == 1]
    free = cycles[cycles.jammed == 0]
    assert jammed.phi.min() == pytest.approx(meta["phi_j"])
    assert free.phi.max() == pytest.approx(meta["phi_j_low"])
    assert (jammed.e > 1e-12).all() and (free.e < 1e-12).all()
    # every relaxation settled (at a minimum, or unjammed) inside its rounds; the jammed
    # sphere packing at phi_J is force-balanced (residual: largest force over the mean
    # contact force)
    assert (cycles.settled == 1).all() and (cycles.residual >= 0).all()
    assert (cycles.iterations > 0).all()
    at_j = jammed.loc[jammed.phi.idxmin()]
    assert at_j.residual < 1e-3
    from analysis.summary import analyse_growth

    rows, curves, _thermo = analyse_growth(out)
    obs = {k: v for k, v, _ in rows}
    assert obs["phi_j"] == pytest.approx(meta["phi_j"])
    assert obs["residual_j"] == pytest.approx(at_j.residual) and obs["settled_j"] == 1
    # Wouterse et al.'s per-frame caging: nothing touches at the start, so nothing is
    # caged; at phi_J (z about 6, rattlers aside) most spheres are; spheres have no jump
    assert curves.noncaged_fraction.iloc[0] == 1.0
    assert 0.0 <= obs["noncaged_fraction_j"] < 0.3
    assert np.isnan(obs["c_mean_before_jump"]) and np.isnan(obs["phi_before_jump"])
    # every relaxed packing is a frame of the dumps, with its contacts
    steps = {f.step for f, _ in RunData(out).frames()}
    assert set(cycles.step) <= steps


@pytest.mark.slow
def test_growth_of_rods_decides_every_relaxation(tmp_path):
    """3-D rods of alpha 1: every relaxation of the cycles settles (at a minimum, or at
    zero energy) inside its rounds, which FIRE alone did not do for rods
    (docs/studies/random_packings.md, growth's "jammed"); the rods jam denser than spheres (about 0.64) and hypostatic, with fewer
    than the isostatic 10 contacts per rod (measured: 100 rods, phi_J 0.6925, z 9.6, 18 s)."""
    out = run_case(tmp_path, growth_case(100, 3, alpha=1.0, phi_grow=0.62, increment=0.01,
                                         tolerance=1e-3))
    import json

    meta = json.loads((out / "run.json").read_text())
    cycles = read_cycles(out / "cycles.dat")
    assert (cycles.settled == 1).all()
    assert (cycles.jammed == 1).any() and (cycles.jammed == 0).any()
    assert 0.66 < meta["phi_j"] < 0.75
    at_j = cycles[cycles.jammed == 1].sort_values("phi").iloc[0]
    assert 8.0 < 2 * at_j.nc / 100 < 10.0


def test_growth_stops_at_phi_max(tmp_path):
    """Cycles that would grow the packing past protocol.phi_max without jamming stop with
    an error that names the bound (spheres jam near 0.64, far above 0.52)."""
    case = validate_case(growth_case(150, 2, phi_grow=0.5, phi_max=0.52, increment=0.01))
    cp = tmp_path / "case.yaml"
    cp.write_text(yaml.safe_dump(case))
    write_initial(case, tmp_path / "init.data")
    r = subprocess.run([sys.executable, "-m", "pysim", "run", str(cp), "--data",
                        str(tmp_path / "init.data"), "--out", str(tmp_path / "out"),
                        "--no-progress"], capture_output=True, text=True)
    assert r.returncode == 3
    assert "passes protocol.phi_max = 0.52" in r.stderr and "raise phi_max" in r.stderr
    cycles = read_cycles(tmp_path / "out" / "cycles.dat.part")
    assert (cycles.jammed == 0).all() and cycles.phi.max() <= 0.52 + 1e-9


def test_rods_compress_writes_axes_and_lengths(tmp_path):
    out = run_case(tmp_path, {
        "particles": {"n": 120, "aspect_ratio": 1.5, "diameter": {"mean": 1.0}},
        "contact": {"law": "hooke", "k_n": 1e5, "gamma_n": 300.0, "gamma_bg": 1.0,
                    "gamma_rot": 0.1},
        "protocol": {"name": "compress", "phi_init": 0.25, "phi_fast": 0.5, "rate_fast": 0.2,
                     "rate": 0.05, "phi_final": 0.7, "dt": 1e-4},
        "output": {"thermo_every": 500, "dump_every": 2000}, "seed": 3})
    frames = RunData(out).frames()
    f, c = frames[-1]
    assert np.allclose(f.length, 1.5) and np.allclose(np.linalg.norm(f.axis, axis=1), 1.0)
    assert c.n > 200  # jammed rods: z well above 4
    # the last thermo row is the last multiple of thermo_every (500 steps, phi grows by
    # 3 rate dt 500 = 0.75 % per row): within one row of the target
    th = RunData(out).thermo
    assert 0.7 * (1 - 3 * 0.05 * 1e-4 * 500) <= th.phi.iloc[-1] <= 0.7


@pytest.mark.slow
def test_two_dimensional_compress(tmp_path):
    out = run_case(tmp_path, {
        "particles": {"n": 150, "dimension": 2, "aspect_ratio": 0.5,
                      "diameter": {"distribution": "bidisperse", "mean": 1.0, "ratio": 1.4}},
        "contact": {"law": "hooke", "k_n": 1e5, "gamma_n": 200.0, "gamma_bg": 1.0,
                    "gamma_rot": 0.1},
        "protocol": {"name": "compress", "phi_init": 0.4, "rate": 0.05, "phi_final": 0.85,
                     "dt": 1e-4},
        "output": {"thermo_every": 500, "dump_every": 2000}, "seed": 4})
    f, c = RunData(out).frames()[-1]
    assert np.all(f.x[:, 2] == 0) and np.all(f.axis[:, 2] == 0)
    assert c.n > 150


@pytest.mark.slow
def test_jammed_disks_by_box_bisection(tmp_path):
    """Bidisperse disks: overdamped compression, then FIRE with box bisection to
    U/L^2 = 1e-15 (within a factor 2); a jammed, force-balanced, isostatic packing."""
    import json

    from analysis.contacts import ContactNumber

    out = run_case(tmp_path, {
        "particles": {"n": 64, "dimension": 2,
                      "diameter": {"distribution": "bidisperse", "mean": 1.0, "ratio": 1.4}},
        "contact": {"law": "harmonic", "k_n": 1.0},
        "protocol": {"name": "jammed", "phi_init": 0.4, "rate": 2e-3, "dt": 0.01},
        "output": {"thermo_every": 500, "dump_every": 100000}, "seed": 5})
    res = json.loads((out / "jammed.json").read_text())
    assert res["converged"] and 5e-16 <= res["energy_density"] <= 2e-15
    assert res["energy_settled"]
    assert 0.80 < res["phi_j"] < 0.87
    # disks: true force balance, to the protocol's BALANCE_TOL of the mean contact force
    # (relaxations stop there rather than at the absolute force_tol)
    assert res["force_residual_max"] < 1e-3
    f, c = RunData(out).frames()[-1]
    cn = ContactNumber().compute(f, c)
    assert 3.6 < cn.z_rattler_free < 4.4  # isostatic 2 d = 4, up to finite-size terms
    # the same state at full precision beside the 10-digit dumps
    from pysim import checkpoint
    from pysim.protocols.jammed import STABLE_STATE

    exact = checkpoint.load(out / STABLE_STATE)[0]
    assert exact.state.packing_fraction() == res["phi_j"]
    np.testing.assert_allclose(exact.state.x, f.x - f.box_lo, rtol=1e-9, atol=1e-8)


@pytest.mark.slow
@pytest.mark.parametrize("alpha, seed", [(0.12, 1), (0.5, 2)])
def test_jammed_rods_end_at_a_minimum(tmp_path, alpha, seed):
    """2-D rods (end bonds): the stable state is a minimum of the energy, not a packing
    still sliding with small residuals: relaxed further (4000 L-BFGS iterations, FIRE
    back to the balance tolerance), it loses less than 1e-4 of its energy. Taken where
    the residuals first fell below BALANCE_TOL, 18 of the 20 quick-profile states lost
    0.4-100 % of their energy that way."""
    import json

    from pysim import checkpoint
    from pysim.minimize import lbfgs
    from pysim.protocols.jammed import STABLE_STATE, balanced_to_tol, energy_density

    out = run_case(tmp_path, {
        "particles": {"n": 64, "dimension": 2, "aspect_ratio": alpha,
                      "diameter": {"distribution": "bidisperse", "mean": 1.0, "ratio": 1.4}},
        "contact": {"law": "harmonic", "k_n": 1.0, "spine_contact": "end_bonds"},
        "protocol": {"name": "jammed", "phi_init": 0.4, "rate": 2e-3, "dt": 0.01},
        "output": {"thermo_every": 500, "dump_every": 100000}, "seed": seed})
    res = json.loads((out / "jammed.json").read_text())
    assert res["converged"] and res["energy_settled"], res
    sim = checkpoint.load(out / STABLE_STATE)[0]
    sim.compute_forces()
    e0 = energy_density(sim, 1.0)
    assert e0 == pytest.approx(res["energy_density"], rel=1e-12)
    lbfgs(sim, 1e-30, 4000)
    sim.minimize(f_tol=1e-30, max_iter=20_000, until=balanced_to_tol)
    assert energy_density(sim, 1.0) > (1 - 1e-4) * e0


@pytest.mark.slow
def test_jammed_reports_unbalanced_forces_as_not_converged(tmp_path):
    """With far too few FIRE iterations per relaxation the forces never balance: the run
    says so (``force_balanced`` false) and does not call the state converged, whatever
    its energy."""
    import json

    out = run_case(tmp_path, {
        "particles": {"n": 64, "dimension": 2,
                      "diameter": {"distribution": "bidisperse", "mean": 1.0, "ratio": 1.4}},
        "contact": {"law": "harmonic", "k_n": 1.0},
        "protocol": {"name": "jammed", "phi_init": 0.4, "rate": 2e-3, "dt": 0.01,
                     "max_relax": 100, "max_bisections": 8},
        "output": {"thermo_every": 500, "dump_every": 100000}, "seed": 5})
    res = json.loads((out / "jammed.json").read_text())
    assert not res["force_balanced"]
    assert not res["converged"]
    assert res["force_residual_max"] > 1e-3


def test_converged_needs_the_energy_settled_and_balanced_forces():
    """``is_converged``: U/L^d within a factor 2 of the target, the energy settled at a
    minimum, and forces balanced by FIRE's absolute tolerance or to BALANCE_TOL of the
    mean contact force (the alpha 0.01, N = 1024 state: residuals 2e-4, FIRE short of
    1e-13); the false jammed state of alpha 3 (residuals 7 % and 85 %), any state off the
    energy target, and any whose energy was still falling are not converged; nor are
    records written before the energy rule (they do not say)."""
    from pysim.protocols.jammed import BALANCE_TOL, is_converged

    good = {"energy_density": 8.0e-16, "force_balanced": False, "energy_settled": True,
            "force_residual_max": 2.2e-4, "torque_residual_max": 1.5e-5}
    assert is_converged(good, 1e-15)
    assert is_converged({**good, "force_balanced": True, "force_residual_max": 0.5}, 1e-15)
    assert not is_converged({**good, "energy_settled": False}, 1e-15)
    assert not is_converged({**good, "force_residual_max": 0.85}, 1e-15)
    assert not is_converged({**good, "torque_residual_max": 2 * BALANCE_TOL}, 1e-15)
    assert not is_converged({**good, "force_residual_max": float("nan")}, 1e-15)
    assert not is_converged({**good, "energy_density": 2.0e-12, "force_balanced": True}, 1e-15)
    assert not is_converged({**good, "energy_density": 4.0e-16}, 1e-15)
    old = {k: v for k, v in good.items() if k != "energy_settled"}
    assert not is_converged({**old, "fire_balanced": True}, 1e-15)


def test_bisection_reopens_a_bracket_that_closes_far_above_the_target():
    """``next_trial``: a bracket narrower than PHI_TOL on a packing far above the target
    energy, or on a jammed packing still sliding, is opened again on the side where the
    search can go on. Lower end from a trial (64 rods, alpha 0.5, seed 2: U/L^2 = 4e-6,
    the jammed packing unjams on the smallest expansion): opened above, and the trials
    compress the unjammed packing in steps of PHI_TOL, 2 PHI_TOL, 4 PHI_TOL... until one
    jams, then bisect below it. Lower
    end from the compression, another packing (the quick profile's alpha 0.12 seed 1:
    U/L^2 = 8.8e-6): opened below and bisected from ``0.9 hi``. A closed bracket with an
    energy jump below REOPEN_ENERGY ends the bisection, as does an energy on target or
    ``max_bisections``."""
    from pysim.protocols.jammed import PHI_TOL, REOPEN_ENERGY, next_trial

    hi = 0.8682
    lo = hi - PHI_TOL / 2
    closed = {"lo": lo, "hi": hi, "bisections": 20}
    drv = {**closed, "lo_trial": True}
    assert next_trial(drv, 4e-6, 1e-15, 50) == pytest.approx(lo + PHI_TOL, abs=1e-15)
    assert drv["hi"] is None and drv["reopened"] == 1
    drv["lo"] = lo + PHI_TOL  # unjammed: the next step is twice as long
    assert next_trial(drv, 4e-6, 1e-15, 50) == pytest.approx(lo + 3 * PHI_TOL, abs=1e-15)
    drv["hi"] = lo + 3 * PHI_TOL  # jammed, above the target: bisect again
    assert next_trial(drv, 1e-14, 1e-15, 50) == pytest.approx(lo + 2 * PHI_TOL, abs=1e-15)
    # the lower end from the compression: opened below
    drv = dict(closed)
    assert next_trial(drv, 8.8e-6, 1e-15, 50) == pytest.approx(0.95 * hi)
    assert drv["lo"] is None and drv["hi"] == hi and drv["reopened"] == 1
    # an energy jump inside the bracket, below REOPEN_ENERGY: nothing better to find
    drv = {**closed, "lo_trial": True, "settled": True}
    assert next_trial(drv, 0.5 * REOPEN_ENERGY, 1e-15, 50) is None
    assert drv["hi"] == closed["hi"] and "reopened" not in drv
    # ... unless the jammed packing was still sliding (alpha 0.01, end_bonds_distinct,
    # seed 1: U/L^2 = 5.4e-15, relaxed longer it came apart): opened above
    drv = {**closed, "lo_trial": True, "settled": False}
    assert next_trial(drv, 5.4e-15, 1e-15, 50) == pytest.approx(lo + PHI_TOL, abs=1e-15)
    assert drv["hi"] is None and drv["reopened"] == 1
    # a sliding packing above a lower end from the compression: nothing to open
    assert next_trial({**closed, "settled": False}, 5.4e-15, 1e-15, 50) is None
    # open bracket: its middle; on target or out of bisections: done
    drv = {"lo": 0.86, "hi": 0.87, "bisections": 3}
    assert next_trial(drv, 8.8e-6, 1e-15, 50) == pytest.approx(0.865)
    assert next_trial(drv, 1.5e-15, 1e-15, 50) is None
    assert next_trial({**drv, "bisections": 50}, 8.8e-6, 1e-15, 50) is None
    # no lower bound yet: the middle of [0.9 hi, hi]
    assert next_trial({"lo": None, "hi": 0.87, "bisections": 0}, 1e-6, 1e-15, 50) == \
        pytest.approx(0.95 * 0.87)


def test_relaxation_rounds_stop_once_the_energy_settles(tmp_path, monkeypatch):
    """With an absolute force tolerance no minimiser can reach (1e-30), each relaxation
    of the disks stops once the energy has stopped falling (SETTLE_ROUNDS rounds in a
    row of L-BFGS and FIRE back to BALANCE_TOL, a few more while it still falls) instead
    of running all RELAX_ROUNDS rounds; the state jams on target, settled, and converges
    by its residuals (force_balanced false)."""
    from pysim import io
    from pysim.protocols import jammed

    calls = []
    real_lbfgs, real_relax = jammed.lbfgs, jammed.relax

    def counting_lbfgs(*args, **kwargs):
        calls[-1] += 1
        return real_lbfgs(*args, **kwargs)

    def counting_relax(*args, **kwargs):
        calls.append(0)
        assert kwargs["max_rounds"] == jammed.TRIAL_ROUNDS  # trials get the long budget
        return real_relax(*args, **kwargs)

    monkeypatch.setattr(jammed, "lbfgs", counting_lbfgs)
    monkeypatch.setattr(jammed, "relax", counting_relax)
    case = validate_case({
        "particles": {"n": 64, "dimension": 2,
                      "diameter": {"distribution": "bidisperse", "mean": 1.0, "ratio": 1.4}},
        "contact": {"law": "harmonic", "k_n": 1.0},
        "protocol": {"name": "jammed", "phi_init": 0.4, "rate": 2e-3, "dt": 0.01,
                     "force_tol": 1e-30, "max_bisections": 40},
        "output": {"thermo_every": 500, "dump_every": 100000}, "seed": 5})
    write_initial(case, tmp_path / "init.data")
    res = jammed.run(case, io.read_particle_data(tmp_path / "init.data"), tmp_path / "out",
                     progress=False)
    assert len(calls) > 10
    assert max(calls) >= jammed.SETTLE_ROUNDS  # jammed trials: settled by the energy rule
    assert max(calls) <= jammed.SETTLE_ROUNDS + 5 < jammed.RELAX_ROUNDS
    assert not res["force_balanced"] and res["energy_settled"]
    assert max(res["force_residual_max"], res["torque_residual_max"]) < jammed.BALANCE_TOL
    assert res["converged"]


@pytest.mark.slow
def test_threads_option_sets_the_kernels_threads_and_keeps_the_bits(tmp_path):
    """``--threads`` (default 1, as the pipeline) is the number the run used, recorded in
    run.json; 1 and 2 threads write the same bits."""
    import json
    import os

    case = validate_case({
        "particles": {"n": 120, "aspect_ratio": 1.0, "diameter": {"mean": 1.0}},
        "contact": {"law": "hooke", "k_n": 1e5, "gamma_n": 300.0, "gamma_bg": 1.0},
        "protocol": {"name": "compress", "phi_init": 0.25, "rate": 0.2, "phi_final": 0.45,
                     "dt": 1e-4},
        "output": {"thermo_every": 500, "dump_every": 1000}, "seed": 5})
    cp = tmp_path / "case.yaml"
    cp.write_text(yaml.safe_dump(case))
    write_initial(case, tmp_path / "init.data")
    env = dict(os.environ, NUMBA_NUM_THREADS="2")
    outs = {}
    for extra in ([], ["--threads", "2"]):
        out = tmp_path / f"out{len(extra)}"
        r = subprocess.run([sys.executable, "-m", "pysim", "run", str(cp), "--data",
                            str(tmp_path / "init.data"), "--out", str(out), "--no-progress",
                            *extra], capture_output=True, text=True, env=env)
        assert r.returncode == 0, r.stderr
        outs[json.loads((out / "run.json").read_text())["threads"]] = out
    assert sorted(outs) == [1, 2]
    for name in ("particles.dump", "contacts.dump", "thermo.dat"):
        assert (outs[1] / name).read_bytes() == (outs[2] / name).read_bytes(), name


def _contraction_sim(tmp_path, n, seed, alpha=0.0, phi_init=0.2):
    from pysim.io import read_particle_data
    from pysim.protocols.compress import max_overlap, model_from_case, state_from_init
    from pysim.simulation import Simulation

    case = validate_case(growth_case(n, seed, alpha=alpha, phi_init=phi_init, phi_grow=0.6))
    write_initial(case, tmp_path / "init.data")
    state = state_from_init(case, read_particle_data(tmp_path / "init.data"))
    return Simulation(state, model_from_case(case), dt=1e-4,
                      skin=0.2 * 2.0 * float(np.max(state.radius)),
                      max_overlap=max_overlap(case))


@pytest.mark.parametrize("alpha", [0.0, 1.5])
def test_contraction_ends_overlap_free_at_rest_on_its_target(tmp_path, alpha):
    """The mechanical contraction lands exactly on its packing fraction, with no overlap
    left (energy below the criterion) and every particle at rest; each step is reported."""
    from pysim.protocols.contraction import contract

    sim = _contraction_sim(tmp_path, 120, 4, alpha)
    steps = []
    contract(sim, 0.49, 0.02, 1e5, 1e-9, 1e-12, 20000,
             on_step=lambda t, it: steps.append(t.state.packing_fraction()))
    s = sim.state
    assert s.packing_fraction() == pytest.approx(0.49, rel=1e-12)
    assert len(steps) == 15 and steps[0] == pytest.approx(0.22)  # 0.20 -> 0.49 by 0.02
    assert sim.thermo().pe / (s.n * 1e5) < 1e-12
    assert np.all(s.v == 0) and np.all(s.omega == 0)


def test_contraction_past_jamming_stops_with_the_density_it_reached(tmp_path):
    """Spheres cannot be contracted overlap-free to 0.70 (above random close packing):
    the error names where the contraction jammed and the target."""
    from pysim.protocols.contraction import ContractionJammedError, contract

    sim = _contraction_sim(tmp_path, 60, 5, phi_init=0.3)
    with pytest.raises(ContractionJammedError, match=r"jammed at phi = 0\.6[3-9].*"
                                                     r"contraction\.phi = 0\.7"):
        contract(sim, 0.70, 0.02, 1e5, 1e-9, 1e-12, 2000)


def test_growth_from_a_contracted_start(tmp_path):
    """With ``contraction`` the growth starts from rest at the contracted density: the
    first frames are the random start and the contracted packing, and the continuous
    growth then runs its planned steps from there."""
    out = run_case(tmp_path, growth_case(100, 6, phi_init=0.2, rate=0.5, phi_grow=0.56,
                                         increment=0.02, tolerance=5e-3,
                                         contraction={"phi": 0.45, "increment": 0.05}))
    frames = RunData(out).frames()
    th = RunData(out).thermo
    contracted = th[th.phi.round(9) == 0.45]
    assert len(contracted) == 1 and contracted.ke.iloc[0] == 0
    assert frames[0][0].step == 0 and frames[1][0].step == contracted.step.iloc[0]
    assert 0.60 < json.loads((out / "run.json").read_text())["phi_j"] < 0.67


def test_contraction_above_phi_grow_is_refused():
    with pytest.raises(Exception, match=r"contraction\.phi = 0\.6 must lie between "
                                        r"phi_init = 0\.3 and phi_grow = 0\.55"):
        validate_case(growth_case(50, 1, phi_grow=0.55, contraction={"phi": 0.6}))


@pytest.mark.slow
def test_growth_relaxed_by_damped_dynamics(tmp_path):
    """relaxation md (Wouterse et al.'s relaxation): each cycle runs the equations of
    motion with the case's damping at relaxation.dt until the total energy is zero
    (unjammed) or stops falling (settled); the steps it ran count as the row's
    iterations and advance the clock by relaxation.dt each; the spheres still jam near
    0.64, every relaxation settled, and unjammed rows end at zero elastic energy."""
    case = growth_case(100, 2, phi_grow=0.62, increment=0.01, tolerance=2e-3,
                       energy_tol=1e-10,
                       relaxation={"method": "md", "dt": 5e-5, "check_time": 0.05})
    # a stronger background viscosity than the paper's 0.1: the free flight of an
    # unjammed packing's spheres then dies out in a few time units, not tens
    case["contact"]["gamma_bg"] = 2.0
    out = run_case(tmp_path, case)
    meta = json.loads((out / "run.json").read_text())
    cycles = read_cycles(out / "cycles.dat")
    assert 0.60 < meta["phi_j"] < 0.67 and meta["phi_j"] - meta["phi_j_low"] < 2e-3
    assert (cycles.settled == 1).all() and (cycles.iterations % 1000 == 0).all()
    jammed, free = cycles[cycles.jammed == 1], cycles[cycles.jammed == 0]
    assert (jammed.e > 1e-10).all() and (free.e < 1e-10 / 4).all()
    th = RunData(out).thermo.set_index("step")
    # the first cycle follows the growth directly: its steps are the relaxation's
    first = cycles.iloc[0]
    grown_at = (first.step - first.iterations) * 1e-4  # the growth's dt from step 0
    assert th.loc[first.step, "time"] == pytest.approx(grown_at + first.iterations * 5e-5)


@pytest.mark.slow
def test_jammed_compresses_and_relaxes_under_their_own_rules(tmp_path, monkeypatch):
    """``protocol.compress_spine_contact``: every compression step runs under that rule
    and every relaxation under ``contact.spine_contact`` (Marschall & Teitel compress
    with the closest points and minimise with end bonds); the stable state keeps the
    relaxations' rule."""
    from pysim import checkpoint, io
    from pysim.protocols import jammed
    from pysim.simulation import Simulation

    laws = {"compress": set(), "relax": set()}
    real_overdamped, real_relax = Simulation.run_overdamped, jammed.relax

    def overdamped(self, *args, **kwargs):
        laws["compress"].add(self.model.spine_contact)
        return real_overdamped(self, *args, **kwargs)

    def relax(sim, *args, **kwargs):
        laws["relax"].add(sim.model.spine_contact)
        return real_relax(sim, *args, **kwargs)

    monkeypatch.setattr(Simulation, "run_overdamped", overdamped)
    monkeypatch.setattr(jammed, "relax", relax)
    case = validate_case({
        "particles": {"n": 64, "dimension": 2, "aspect_ratio": 0.5,
                      "diameter": {"distribution": "bidisperse", "mean": 1.0, "ratio": 1.4}},
        "contact": {"law": "harmonic", "k_n": 1.0, "spine_contact": "end_bonds_distinct"},
        "protocol": {"name": "jammed", "phi_init": 0.4, "rate": 2e-3, "dt": 0.01,
                     "compress_spine_contact": "closest", "max_bisections": 1},
        "output": {"thermo_every": 500, "dump_every": 100000}, "seed": 2})
    write_initial(case, tmp_path / "init.data")
    jammed.run(case, io.read_particle_data(tmp_path / "init.data"), tmp_path / "out",
               progress=False)
    assert laws == {"compress": {"closest"}, "relax": {"end_bonds_distinct"}}
    state = checkpoint.load(tmp_path / "out" / jammed.STABLE_STATE)[0]
    assert state.model.spine_contact == "end_bonds_distinct"
