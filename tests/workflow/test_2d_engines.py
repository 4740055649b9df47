"""The LAMMPS 2-D deck (inputs/lammps/in.2d.compress): glued-disk rods compressed with strong
drag give 2-D rod frames in the common format, and their pressure rises where pysim's
overdamped compression of the same start does."""
import subprocess
import sys

import numpy as np
import pytest
import yaml

from analysis.io import RunData
from pysim.initial import write_initial
from workflows import engines
from workflows.case import validate_case

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


@pytest.mark.engines
def test_lammps_2d_glued_rods_against_pysim(tmp_path):
    case = validate_case(CASE)
    write_initial(case, tmp_path / "init.data")
    assert engines.supports("lammps", case) is None
    engines.run("lammps", case, tmp_path / "init.data", tmp_path / "lammps", timeout=600)
    run = RunData(tmp_path / "lammps")
    frame, contacts = run.frames()[-1]
    assert frame.dim == 2 and frame.n == 64
    assert np.all(frame.x[:, 2] == 0) and np.all(np.abs(frame.axis[:, 2]) < 1e-9)
    # spine length alpha D for both sizes, from the disk centres
    expected = np.where(frame.radius > 0.6, 0.7, 0.5)
    np.testing.assert_allclose(frame.length, expected, atol=1e-5)
    assert run.thermo.phi.iloc[-1] == pytest.approx(0.9, abs=2e-3)
    assert contacts.n > 64 and np.all(contacts.overlap < 0.2)

    (tmp_path / "case.yaml").write_text(yaml.safe_dump(case))
    r = subprocess.run([sys.executable, "-m", "pysim", "run", str(tmp_path / "case.yaml"),
                        "--data", str(tmp_path / "init.data"), "--out", str(tmp_path / "pysim"),
                        "--no-progress"], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    ref = RunData(tmp_path / "pysim").thermo
    # same start, same law and drag: the pressure rises at nearly the same density (the
    # glued rods' bumpy sides and their smaller rotational drag shift it a little)
    assert onset(run.thermo) == pytest.approx(onset(ref), abs=0.03)


def test_lammps_2d_deck_refuses_other_laws():
    case = validate_case({**CASE, "contact": {"law": "hooke", "k_n": 1.0}})
    assert "soft harmonic law only" in engines.supports("lammps", case)
    assert "no 2-D deck" in engines.supports("liggghts", validate_case(CASE))
