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


def test_trace_in_elements_is_fitted_as_the_papers_fig6(rng, monkeypatch):
    """``analysis.summary._trace_rve``: rows of elements five slabs high across four
    columns, a Janssen-shaped trace with noise in every element; the row means sit at the
    slab in the middle of each row, rows reaching above the surface are left out, and
    the weighted fit gives back sigma_m and h_s / W."""
    import pandas as pd

    import analysis.stress
    from analysis.summary import _trace_rve

    width, slab, top = 20.0, 1.0, 52.0  # 52 slabs deep: 10 whole rows, the 11th sticks out
    edges = slab * np.arange(61)
    centers = 0.5 * (edges[1:] + edges[:-1])
    prof = pd.DataFrame({"depth": top - centers, "x": (top - centers) / width})
    seen = {}

    def fake(frame, contacts, row_edges, lo, hi, columns):
        seen.update(row_edges=np.asarray(row_edges), columns=columns, lo=lo, hi=hi)
        x = (top - 0.5 * (row_edges[1:] + row_edges[:-1])) / width
        mean = janssen(np.clip(x, 0, None), 300.0, 0.9)
        return mean[:, None] + rng.normal(0.0, 4.0, (len(mean), columns)), \
            np.full((len(mean), columns), 5)

    monkeypatch.setattr(analysis.stress, "element_trace", fake)
    rows = {n: (v, e) for n, v, e in _trace_rve(None, None, prof, edges, width, top, 1.0)}
    np.testing.assert_allclose(seen["row_edges"], 5.0 * np.arange(13))
    assert (seen["columns"], seen["lo"], seen["hi"]) == (4, 0.0, 20.0)
    at = np.flatnonzero(prof.trace_rve.notna())
    np.testing.assert_array_equal(at, 5 * np.arange(10) + 2)  # rows 0-9, their middle slab
    assert prof.trace_rve_err.notna().sum() == 10
    s, s_err = rows["sigma_m_trace_rve"]
    h, h_err = rows["h_s_trace_rve"]
    assert abs(s - 300.0) < 4 * s_err and abs(h - 0.9) < 4 * h_err
    # errors from four elements each are weights only: the parameter errors are those of
    # the absolute fit times sqrt(chi2 / dof)
    chi2_dof = rows["chi2_dof_trace_rve"][0]
    use = prof.trace_rve.notna()
    absolute = JanssenFit(width=width).compute(prof.depth[use], prof.trace_rve[use],
                                               prof.trace_rve_err[use])
    assert s == pytest.approx(absolute.sigma_m, rel=1e-9)
    assert s_err == pytest.approx(absolute.sigma_m_err * np.sqrt(chi2_dof), rel=1e-6)
    assert np.isfinite(prof.trace_rve_fit).all()
    # too shallow for a row of elements: NaN, and no profile
    shallow = prof.copy()
    rows = _trace_rve(None, None, shallow, edges[:4], width, 3.0, 1.0)
    assert all(np.isnan(v) for _, v, _ in rows) and shallow.trace_rve.isna().all()


@pytest.mark.parametrize("h_true, curved", [(2.2, True), (200.0, False)])
def test_trace_fit_past_the_data_stands_when_its_curvature_is_resolved(monkeypatch, h_true,
                                                                       curved):
    """The paper fits h_s / W = 2.2 to a deposit less deep than that: a profile 1.8 W deep
    that bends (h_s = 2.2 W) gives its fit back, a nearly straight one (h_s = 200 W) gives
    NaN, and both report the depth they reach."""
    import pandas as pd

    import analysis.stress
    from analysis.summary import _trace_rve

    width, top = 20.0, 36.0  # 36 slabs: 1.8 W
    edges = np.arange(41.0)
    centers = 0.5 * (edges[1:] + edges[:-1])
    prof = pd.DataFrame({"depth": top - centers, "x": (top - centers) / width})
    noise = np.random.default_rng(4).normal(0.0, 1.0, (8, 4))

    def fake(frame, contacts, row_edges, lo, hi, columns):
        x = (top - 0.5 * (row_edges[1:] + row_edges[:-1])) / width
        mean = janssen(np.clip(x, 0, None), 300.0 * h_true / 2.2, h_true)
        return mean[:, None] + noise[:len(mean)], np.full((len(mean), columns), 5)

    monkeypatch.setattr(analysis.stress, "element_trace", fake)
    listed = _trace_rve(None, None, prof, edges, width, top, 1.0)
    rows = {n: (v, e) for n, v, e in listed}
    assert len(rows) == len(listed) == 4  # each observable once, fitted or not
    assert rows["x_max_trace_rve"][0] == pytest.approx(33.5 / width)
    h, h_err = rows["h_s_trace_rve"]
    if curved:
        assert h > rows["x_max_trace_rve"][0] and abs(h - 2.2) < 4 * h_err < 2 * h
    else:
        assert np.isnan(h) and prof.trace_rve_fit.isna().all()
