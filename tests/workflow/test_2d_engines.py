"""The LAMMPS 2-D decks (inputs/lammps/in.2d.compress: glued-disk rods;
in.2d.body.compress: body rounded/polygon rods) compressed with strong drag give 2-D rod
frames in the common format, and their pressure rises where pysim's overdamped
compression of the same start does."""
import subprocess
import sys

import numpy as np
import pytest
import yaml

from analysis.io import RunData
from pysim.initial import write_initial
from workflows import engines
from rodcase.case import validate_case

CASE = {
    "particles": {"n": 64, "dimension": 2, "aspect_ratio": 0.5,
                  "diameter": {"distribution": "bidisperse", "mean": 1.0, "ratio": 1.4}},
    "contact": {"law": "harmonic", "k_n": 1.0},
    "protocol": {"name": "compress", "integrator": "overdamped", "k_d": 1.0, "phi_init": 0.4,
                 "phi_fast": 0.7, "rate_fast": 1e-3, "rate": 1e-4, "phi_final": 0.9,
                 "dt": 0.01},
    "output": {"thermo_every": 200, "dump_every": 10000},
    "seed": 2,
}


def onset(thermo, p_star=2e-3):
    """Packing fraction where the contact pressure first exceeds ``p_star`` in the slow
    stage (above phi_fast)."""
    slow = thermo[thermo.phi > CASE["protocol"]["phi_fast"] + 0.01]
    return float(slow.phi[slow.pressure > p_star].iloc[0])


@pytest.fixture(scope="module")
def pysim_reference(tmp_path_factory):
    """The case, its initial data and pysim's overdamped compression thermo table."""
    tmp = tmp_path_factory.mktemp("ref2d")
    case = validate_case(CASE)
    write_initial(case, tmp / "init.data")
    (tmp / "case.yaml").write_text(yaml.safe_dump(case))
    r = subprocess.run([sys.executable, "-m", "pysim", "run", str(tmp / "case.yaml"),
                        "--data", str(tmp / "init.data"), "--out", str(tmp / "pysim"),
                        "--no-progress"], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    return case, tmp / "init.data", RunData(tmp / "pysim").thermo


def check_rod_frames(run: RunData):
    frame, contacts = run.frames()[-1]
    assert frame.dim == 2 and frame.n == 64
    assert np.all(frame.x[:, 2] == 0) and np.all(np.abs(frame.axis[:, 2]) < 1e-9)
    # spine length alpha D for both sizes
    expected = np.where(frame.radius > 0.6, 0.7, 0.5)
    np.testing.assert_allclose(frame.length, expected, atol=1e-5)
    assert run.thermo.phi.iloc[-1] == pytest.approx(0.9, abs=2e-3)
    assert contacts.n > 64 and np.all(contacts.overlap < 0.2)


@pytest.mark.engines
def test_lammps_2d_glued_rods_against_pysim(tmp_path, pysim_reference):
    case, data, ref = pysim_reference
    assert engines.supports("lammps", case) is None
    engines.run("lammps", case, data, tmp_path / "lammps", timeout=600)
    run = RunData(tmp_path / "lammps")
    check_rod_frames(run)  # spine lengths from the disk centres
    # same start, same law and drag: the pressure rises at nearly the same density (the
    # glued rods' bumpy sides and their smaller rotational drag shift it a little)
    assert onset(run.thermo) == pytest.approx(onset(ref), abs=0.03)


@pytest.mark.engines
def test_lammps_2d_body_rods_against_pysim(tmp_path, pysim_reference):
    case, data, ref = pysim_reference
    assert engines.supports("lammps-body", case) is None
    rec = engines.run("lammps-body", case, data, tmp_path / "body", timeout=600)
    assert "reconstructed" in rec["contact_forces"]
    run = RunData(tmp_path / "body")
    check_rod_frames(run)  # spine lengths from compute body/local's vertices
    # reconstructed forces: the harmonic law k_e delta / (R_i + R_j)^2 on the overlap
    frame, contacts = run.frames()[-1]
    index = {int(t): k for k, t in enumerate(frame.ids)}
    r_i = frame.radius[[index[int(t)] for t in contacts.i]]
    r_j = frame.radius[[index[int(t)] for t in contacts.j]]
    fn = -np.einsum("ij,ij->i", contacts.force, contacts.normal)
    np.testing.assert_allclose(fn, contacts.overlap / (r_i + r_j) ** 2, rtol=1e-6, atol=1e-9)
    assert np.all(contacts.overlap > 0)
    # LAMMPS' own virial pressure rises where pysim's does (measured: 0.830 vs 0.828)
    assert onset(run.thermo) == pytest.approx(onset(ref), abs=0.03)


def test_lammps_body_refuses_what_it_has_no_deck_for():
    disks = engines.supports("lammps-body", validate_case(
        {**CASE, "particles": {**CASE["particles"], "aspect_ratio": 0.0}}))
    assert "lammps-body has no deck for disks 2-D under protocol 'compress'" in disks
    assert "engines that run disks 2-D under 'compress': pysim, lammps)" in disks
    jammed = {**CASE, "protocol": {"name": "jammed", "phi_init": 0.4, "rate": 1e-3,
                                   "dt": 0.01}}
    assert ("no deck for rods 2-D under protocol 'jammed' (it runs compress (rods, rods 2-D);"
            in engines.supports("lammps-body", validate_case(jammed)))


def test_lammps_2d_deck_refuses_other_laws():
    case = validate_case({**CASE, "contact": {"law": "hooke", "k_n": 1.0}})
    assert "soft harmonic law only" in engines.supports("lammps", case)
    assert "liggghts has no deck for rods 2-D" in engines.supports("liggghts", validate_case(CASE))
