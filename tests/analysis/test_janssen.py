"""Janssen fits: synthetic profiles with noise are fitted back within their uncertainty,
and the uncertainties mean what they say (coverage over many noisy profiles)."""
import numpy as np
import pytest

from analysis.janssen import JanssenFit, JanssenFitError, janssen


def noisy_profile(rng, sigma_m=120.0, h_s=0.8, noise=3.0, width=10.0, n=40):
    depth = np.linspace(0.25, 40.0, n)  # 4 widths deep
    y = janssen(depth / width, sigma_m, h_s) + rng.normal(0, noise, n)
    return depth, y


def test_synthetic_profile_is_fitted_back_within_its_uncertainty(rng):
    depth, y = noisy_profile(rng)
    fit = JanssenFit(width=10.0).compute(depth, y, sigma_err=3.0)
    assert abs(fit.sigma_m - 120.0) < 3 * fit.sigma_m_err
    assert abs(fit.h_s - 0.8) < 3 * fit.h_s_err
    assert fit.sigma_m_err < 3.0 and fit.h_s_err < 0.1  # the data constrain both
    assert fit.dof == 38 and fit.chi2 / fit.dof == pytest.approx(1.0, abs=0.5)
    # without known errors the covariance is scaled by the residuals: similar errors
    fit2 = JanssenFit(width=10.0).compute(depth, y)
    assert fit2.sigma_m_err == pytest.approx(fit.sigma_m_err, rel=0.4)


def test_uncertainties_cover_the_truth_two_times_in_three(rng):
    inside = 0
    trials = 200
    for _ in range(trials):
        depth, y = noisy_profile(rng, noise=5.0)
        fit = JanssenFit(width=10.0).compute(depth, y, sigma_err=5.0)
        inside += abs(fit.h_s - 0.8) < fit.h_s_err
    # binomial: 0.683 +- 0.033
    assert 0.58 < inside / trials < 0.78


def test_classical_form_gives_k_from_wall_friction(rng):
    """sigma_zz = sigma_inf (1 - exp(-z / lambda)), lambda = W / (4 mu_w K)."""
    w, mu_w, k = 8.0, 0.5, 0.6
    lam = w / (4 * mu_w * k)
    z = np.linspace(0.5, 30, 50)
    y = janssen(z, 200.0, lam) + rng.normal(0, 1.0, z.size)
    fit = JanssenFit(form="classical", width=w, mu_w=mu_w).compute(z, y, sigma_err=1.0)
    assert fit.h_s == pytest.approx(lam, abs=3 * fit.h_s_err)
    assert fit.K == pytest.approx(k, abs=3 * fit.K_err)
    fit2 = JanssenFit(form="classical", width=w, K=k).compute(z, y, sigma_err=1.0)
    assert fit2.mu_w == pytest.approx(mu_w, abs=3 * fit2.mu_w_err)
    assert np.isnan(fit2.K)
    slot = JanssenFit(form="classical", width=w, mu_w=mu_w, walls="slot").compute(z, y, 1.0)
    assert slot.K == pytest.approx(2 * fit.K)


def test_bad_inputs_are_named():
    with pytest.raises(JanssenFitError, match="compressive positive"):
        JanssenFit().compute([1, 2, 3], [-1, -2, -3])
    with pytest.raises(JanssenFitError, match="at least 3"):
        JanssenFit().compute([1, 2], [1, 2])
    with pytest.raises(ValueError, match="not both"):
        JanssenFit(form="classical", mu_w=0.5, K=0.5)
