"""Closed-form theory helpers: known values and limits."""
import numpy as np
import pytest

from analysis import theory


def test_volumes_and_excluded_volume():
    assert theory.volume(0.0) == pytest.approx(np.pi / 6)
    assert theory.volume(4.0, diameter=2.0) == pytest.approx(np.pi * 4 * 8 / 4 + np.pi * 8 / 6)
    # spheres: the excluded volume is that of a sphere of radius D, 8 V
    assert theory.excluded_volume(0.0) == pytest.approx(8 * theory.volume(0.0))
    assert theory.area_2d(1.0, diameter=2.0) == pytest.approx(2 * 2 * 1 + np.pi)


def test_aligned_packing_limit():
    assert theory.aligned_phi_max(4.0) == pytest.approx(0.8787, abs=1e-4)
    assert theory.aligned_phi_max(0.0) == pytest.approx(np.pi / (3 * np.sqrt(2)))
    assert theory.aligned_phi_max(1e9) == pytest.approx(np.pi / (2 * np.sqrt(3)), rel=1e-6)


def test_random_contact_equation_and_thin_rod_limit():
    a = np.array([10.0, 100.0, 1000.0])
    phi = theory.rce_packing_fraction(10.0, a)
    thin = theory.thin_rod_limit(10.0, a)
    rel = np.abs(phi / thin - 1)
    assert np.all(np.diff(rel) < 0) and rel[-1] < 0.01  # converges to phi alpha = C/2
    np.testing.assert_allclose(theory.rce_contact_number(phi, a), 10.0)
    with pytest.raises(ValueError, match="alpha > 0"):
        theory.thin_rod_limit(10.0, 0.0)


def test_isostatic_counts_and_conventions():
    assert [theory.isostatic_z(3, False), theory.isostatic_z(3, True),
            theory.isostatic_z(2, True), theory.isostatic_z(2, False)] == [6, 10, 6, 4]
    assert theory.alpha_from(5.0, "d") == 4.0 and theory.alpha_from(2.0, "A/R") == 2.0
    with pytest.raises(ValueError, match="unknown convention"):
        theory.alpha_from(1.0, "x")
