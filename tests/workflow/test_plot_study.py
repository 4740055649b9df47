"""The per-variant figure script: P(C) in the frame nearest to jamming."""
import numpy as np
import pytest

from analysis.contacts import ContactNumber
from analysis.io import RunData
from analysis.packing import packing_fraction
from tests.runs import run_case
from workflows.scripts.plot_study import contacts_at_jamming


def test_contact_distribution_at_jamming(tmp_path):
    out = run_case(tmp_path, {
        "particles": {"n": 150, "diameter": {"mean": 1.0}},
        "contact": {"law": "hooke", "k_n": 1e5, "gamma_n": 300.0, "gamma_bg": 1.0},
        "protocol": {"name": "compress", "phi_init": 0.3, "phi_fast": 0.55, "rate_fast": 0.2,
                     "rate": 0.05, "phi_final": 0.68, "dt": 1e-4},
        "output": {"thermo_every": 500, "dump_every": 1000}, "seed": 4})
    frames = RunData(out).frames()
    phis = np.array([packing_fraction(f) for f, _ in frames])
    target = phis[len(phis) // 2] + 1e-4  # nearest: the middle frame
    phi, dist, dist_rf = contacts_at_jamming(out, target)
    assert phi == pytest.approx(phis[len(phis) // 2])
    f, c = frames[len(phis) // 2]
    cn = ContactNumber().compute(f, c)
    np.testing.assert_array_equal(dist, cn.distribution)
    assert dist.sum() == pytest.approx(1.0)
    # the mean of P(C) is the mean contact number
    assert np.sum(np.arange(len(dist)) * dist) == pytest.approx(cn.z)
    assert contacts_at_jamming(out, float("nan")) is None
