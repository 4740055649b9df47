"""Jamming point from the first linear pressure rise."""
import numpy as np
import pytest

from analysis.jamming import JammingFitError, JammingPoint, first_rise


def test_recovers_known_jamming_point(rng):
    phi = np.linspace(0.55, 0.70, 300)
    p = np.where(phi > 0.642, 0.35 * (phi - 0.642), 0.0) + rng.uniform(0, 2e-5, phi.size)
    # a dynamic pressure spike well below jamming must not be taken as the rise
    p[50] = 5e-3
    jp = JammingPoint(window=(1e-3, 1e-2)).compute(phi, p)
    assert jp.phi_j == pytest.approx(0.642, abs=5e-4)
    assert jp.phi_j_err < 1e-3
    assert jp.slope == pytest.approx(0.35, rel=0.05)
    assert jp.rows.start > 50


def test_pressure_scale_is_applied():
    phi = np.linspace(0.6, 0.75, 151)
    p = 1e5 * np.clip(0.2 * (phi - 0.65), 0, None)
    jp = JammingPoint(window=(1e-3, 1e-2), p_scale=1e5).compute(phi, p)
    assert jp.phi_j == pytest.approx(0.65, abs=1e-9)
    assert jp.slope == pytest.approx(0.2 * 1e5)


def test_no_rise_is_a_clear_error():
    with pytest.raises(JammingFitError, match="never reaches"):
        first_rise(np.zeros(10), 1e-3, 1e-2)
    with pytest.raises(ValueError, match="0 < p_lo < p_hi"):
        JammingPoint(window=(1e-2, 1e-3))
