"""Characteristic densities of hard-sphere packings (analysis/closest_jamming.py): the
paper's fast and slow classes, the zero-rate extrapolation against numpy's polynomial
fit, and the table of limits on a hand-made set of packings."""
import math

import numpy as np
import pandas as pd
import pytest
from scipy import stats

from analysis.closest_jamming import limits, speed, zero_rate_extrapolation


def test_speed_classes_are_the_papers():
    # LS: fast below 1/rate = 5, slow above 60; FB: fast below 1e3, slow above 2e3
    assert [speed("ls", r) for r in (10.0, 0.21, 0.19, 1 / 61, 0.01)] == [
        "fast", "fast", "between", "slow", "slow"]
    assert [speed("fb", r) for r in (2e-3, 9e-4, 4e-4)] == ["fast", "between", "slow"]
    with pytest.raises(ValueError, match="'growth'"):
        speed("growth", 1.0)
    with pytest.raises(ValueError, match="rate must be > 0, got 0"):
        speed("ls", 0.0)


def test_zero_rate_extrapolation_matches_polyfit():
    rng = np.random.default_rng(4)
    rate = np.geomspace(1e-4, 1e-2, 30)
    x = np.sqrt(rate)
    phi = 0.66 - 0.4 * x + 3.0 * x**2 - 20.0 * x**3 + rng.normal(0, 2e-4, len(x))
    fit = zero_rate_extrapolation(rate, phi)
    coef, cov = np.polyfit(x, phi, 3, cov=True)  # highest power first
    assert fit["c0"] == pytest.approx(coef[-1], rel=1e-10)
    assert fit["se"] == pytest.approx(math.sqrt(cov[-1, -1]), rel=1e-8)
    assert fit["ci95"] == pytest.approx(stats.t.ppf(0.975, 26) * fit["se"], rel=1e-12)
    assert fit["n"] == 30 and abs(fit["c0"] - 0.66) < 4 * fit["se"]
    # exact data are recovered exactly; too few points give nan
    exact = zero_rate_extrapolation(rate, 0.65 + 0.1 * x - x**3)
    assert exact["c0"] == pytest.approx(0.65, abs=1e-12)
    few = zero_rate_extrapolation(rate[:4], phi[:4])
    assert math.isnan(few["c0"]) and few["n"] == 4


def test_limits_of_a_set_of_packings():
    rows = [  # n, sigma, protocol, rate, phi, phi_j
        (2048, 0.0, "ls", 10.0, 0.61, 0.6351), (2048, 0.0, "ls", 10.0, 0.62, 0.6362),
        (2048, 0.0, "ls", 1.0, 0.63, 0.6390), (2048, 0.0, "ls", 0.1, 0.64, 0.6420),
        (2048, 0.0, "fb", 0.01, 0.60, 0.6370), (2048, 0.0, "fb", 0.01, 0.60, 0.6380),
        (10000, 0.0, "ls", 10.0, 0.62, 0.6356),
    ]
    rate = np.geomspace(1e-4, 1e-2, 6)  # slow LS compressions of sigma 0.3
    rows += [(2048, 0.3, "ls", g, 0.67 - np.sqrt(g), 0.68 - np.sqrt(g)) for g in rate]
    pts = pd.DataFrame(rows, columns=["n", "sigma", "protocol", "rate", "phi", "phi_j"])
    t = limits(pts)
    get = t.set_index(["n", "sigma", "protocol", "observable"])["value"]
    assert get[2048, 0.0, "ls", "phi_min_fast"] == 0.6351
    assert get[2048, 0.0, "ls", "phi_max_fast_ls"] == 0.6390  # rate 0.1 is not fast
    assert get[2048, 0.0, "ls", "phi_mean_fast_ls"] == pytest.approx((0.6351 + 0.6362 + 0.639) / 3)
    assert get[2048, 0.0, "fb", "phi_max_fast_fb"] == 0.6380
    assert get[2048, 0.0, "fb+ls", "phi_lt"] == pytest.approx((0.6351 + 0.6370) / 2)
    assert get[2048, 0.0, "fb+ls", "phi_rcp"] == pytest.approx((0.6390 + 0.6380) / 2)
    assert get[10000, 0.0, "ls", "phi_rcp"] == 0.6356  # sizes are never pooled
    row = t[(t.n == 2048) & (t.sigma == 0.0) & (t.observable == "phi_max_fast_ls")].iloc[0]
    assert row.rate == 1.0 and row.packings == 3  # the slowest fast compression behind it
    # sigma 0.3: only slow compressions, so the zero-rate fits and no band
    assert get[2048, 0.3, "ls", "phi_gcp_ls_initial"] == pytest.approx(0.67, abs=1e-9)
    assert get[2048, 0.3, "ls", "phi_gcp_ls_densified"] == pytest.approx(0.68, abs=1e-9)
    assert get[2048, 0.3, "ls", "phi_gcp"] == pytest.approx(0.675, abs=1e-9)
    assert not t[(t.sigma == 0.3) & t.observable.isin(["phi_lt", "phi_rcp"])].size
    assert (t[t.observable.str.startswith("phi_gcp")].rate == 0).all()
