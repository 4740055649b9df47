"""Protocol drivers end to end through the CLI, on small systems."""
import subprocess
import sys

import numpy as np
import pandas as pd
import pytest
import yaml

from analysis.io import RunData
from pysim.initial import write_initial
from workflows.case import validate_case


def run_case(tmp_path, case, *extra):
    case = validate_case(case)
    cp = tmp_path / "case.yaml"
    cp.write_text(yaml.safe_dump(case))
    write_initial(case, tmp_path / "init.data")
    r = subprocess.run([sys.executable, "-m", "pysim", "run", str(cp), "--data",
                        str(tmp_path / "init.data"), "--out", str(tmp_path / "out"),
                        "--no-progress", *extra], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    return tmp_path / "out"


def test_growth_to_jamming_of_spheres(tmp_path):
    out = run_case(tmp_path, {
        "particles": {"n": 150, "diameter": {"mean": 1.0}},
        "contact": {"law": "hooke", "k_n": 1e5, "gamma_n": 10.0, "gamma_bg": 0.1},
        "protocol": {"name": "growth", "phi_init": 0.3, "rate": 0.1, "phi_grow": 0.58,
                     "dt": 1e-4, "increment": 0.01, "tolerance": 5e-4},
        "output": {"thermo_every": 1000, "dump_every": 5000}, "seed": 2})
    import json

    meta = json.loads((out / "run.json").read_text())
    cycles = pd.read_csv(out / "cycles.dat", sep=r"\s+", comment="#", header=None,
                         names=["step", "phi", "e", "p", "nc", "jammed"])
    assert 0.60 < meta["phi_j"] < 0.67
    assert meta["phi_j"] - meta["phi_j_low"] < 5e-4
    jammed = cycles[cycles.jammed == 1]
    free = cycles[cycles.jammed == 0]
    assert jammed.phi.min() == pytest.approx(meta["phi_j"])
    assert free.phi.max() == pytest.approx(meta["phi_j_low"])
    assert (jammed.e > 1e-12).all() and (free.e < 1e-12).all()
    # every relaxed packing is a frame of the dumps, with its contacts
    steps = {f.step for f, _ in RunData(out).frames()}
    assert set(cycles.step) <= steps


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


def test_converged_needs_the_energy_and_balanced_forces():
    """``is_converged``: U/L^d within a factor 2 of the target, and forces balanced by
    FIRE's absolute tolerance or to BALANCE_TOL of the mean contact force (the alpha 0.01,
    N = 1024 state: residuals 2e-4, FIRE short of 1e-13); the false jammed state of alpha 3
    (residuals 7 % and 85 %) and any state off the energy target are not converged."""
    from pysim.protocols.jammed import BALANCE_TOL, is_converged

    good = {"energy_density": 8.0e-16, "force_balanced": False, "force_residual_max": 2.2e-4,
            "torque_residual_max": 1.5e-5}
    assert is_converged(good, 1e-15)
    assert is_converged({**good, "force_balanced": True, "force_residual_max": 0.5}, 1e-15)
    assert not is_converged({**good, "force_residual_max": 0.85}, 1e-15)
    assert not is_converged({**good, "torque_residual_max": 2 * BALANCE_TOL}, 1e-15)
    assert not is_converged({**good, "force_residual_max": float("nan")}, 1e-15)
    assert not is_converged({**good, "energy_density": 2.0e-12, "force_balanced": True}, 1e-15)
    assert not is_converged({**good, "energy_density": 4.0e-16}, 1e-15)
    # records written before L-BFGS joined the relaxation call the flag fire_balanced
    old = {"energy_density": 8.0e-16, "fire_balanced": True, "force_residual_max": 0.5,
           "torque_residual_max": 0.5}
    assert is_converged(old, 1e-15)
    assert not is_converged({**old, "fire_balanced": False}, 1e-15)


def test_bisection_reopens_a_bracket_that_closes_far_above_the_target():
    """``next_trial``: a bracket narrower than PHI_TOL on a packing far above the target
    energy (the quick profile's alpha 0.12 seed 1: U/L^2 = 8.8e-6, whose lower bound came
    from an expansion of a denser packing that unjammed) is opened again below it and
    bisected from ``0.9 hi``; a closed bracket with an energy jump below REOPEN_ENERGY
    ends the bisection, as does an energy on target or ``max_bisections``."""
    from pysim.protocols.jammed import PHI_TOL, REOPEN_ENERGY, next_trial

    hi = 0.8682
    closed = {"lo": hi - PHI_TOL / 2, "hi": hi, "bisections": 20}
    drv = dict(closed)
    goal = next_trial(drv, 8.8e-6, 1e-15, 50)
    assert drv["lo"] is None and drv["reopened"] == 1
    assert goal == pytest.approx(0.95 * hi)  # the middle of [0.9 hi, hi]
    drv["lo"], drv["hi"] = goal, goal + PHI_TOL / 4  # closes again on another packing
    next_trial(drv, 1e-9, 1e-15, 50)
    assert drv["reopened"] == 2
    # an energy jump inside the bracket, below REOPEN_ENERGY: nothing better to find
    drv = dict(closed)
    assert next_trial(drv, 0.5 * REOPEN_ENERGY, 1e-15, 50) is None
    assert drv["lo"] == closed["lo"] and "reopened" not in drv
    # open bracket: its middle; on target or out of bisections: done
    drv = {"lo": 0.86, "hi": 0.87, "bisections": 3}
    assert next_trial(drv, 8.8e-6, 1e-15, 50) == pytest.approx(0.865)
    assert next_trial(drv, 1.5e-15, 1e-15, 50) is None
    assert next_trial({**drv, "bisections": 50}, 8.8e-6, 1e-15, 50) is None
    # no lower bound yet: the middle of [0.9 hi, hi]
    assert next_trial({"lo": None, "hi": 0.87, "bisections": 0}, 1e-6, 1e-15, 50) == \
        pytest.approx(0.95 * 0.87)


def test_relaxation_rounds_stop_once_balanced_to_balance_tol(tmp_path, monkeypatch):
    """With an absolute force tolerance no minimiser can reach (1e-30), each relaxation
    stops after its first FIRE round once every residual is below BALANCE_TOL of the
    mean contact force, instead of running all RELAX_ROUNDS rounds of FIRE and L-BFGS:
    L-BFGS is then never called, the state still jams on target and converges by its
    residuals (force_balanced false)."""
    from pysim import io
    from pysim.protocols import jammed

    calls = []
    real = jammed.lbfgs

    def counting(*args, **kwargs):
        calls.append(1)
        return real(*args, **kwargs)

    monkeypatch.setattr(jammed, "lbfgs", counting)
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
    assert calls == []
    assert not res["force_balanced"]
    assert max(res["force_residual_max"], res["torque_residual_max"]) < jammed.BALANCE_TOL
    assert res["converged"]
