"""Characteristic densities of hard-sphere packings from their closest jamming densities.

Baranau & Tallarek (2014) compress Poisson starts at many compression rates ``gamma``
with the Lubachevsky-Stillinger (LS) or force-biased (FB) algorithm, which gives a
packing of density ``phi``, then search each packing's closest jammed configuration,
of density ``phi_J`` (their Fig. 2). From those points, per size distribution:

* fast compressions (``1/gamma < 5`` for LS, ``< 1e3`` for FB, Sec. IV.A) put ``phi_J``
  in a narrow band; its lowest value is ``phi_min^fast`` (the lowest typical density
  ``phi_LT``), its highest ``phi_max^fast`` (the random close packing limit
  ``phi_RCP``); Table 4 gives the mean of the two algorithms' values (Sec. IV.C, D);
* slow compressions (``1/gamma > 60`` for LS, ``> 2e3`` for FB) are extrapolated to
  zero rate with ``phi = sum_{i=0}^{3} c_i gamma^(i/2)`` fitted by least squares;
  ``c_0`` estimates the glass close packing ``phi_GCP`` (Table 2: fits of ``phi``,
  "initial", and of ``phi_J``, "densified"; Table 4: the mean of the four).

The band's ends are extremes of a sample: they move outwards with more packings and
inwards with larger ones, so they are reported with the number of packings behind them.
"""
from __future__ import annotations

import math

import numpy as np
import pandas as pd
from scipy import stats

#: compressions faster than this inverse rate are "fast" (paper Sec. IV.A)
FAST_INVERSE_RATE = {"ls": 5.0, "fb": 1e3}
#: compressions slower than this inverse rate are "slow" (paper Sec. IV.A)
SLOW_INVERSE_RATE = {"ls": 60.0, "fb": 2e3}
#: terms of the zero-rate expansion (c_0 ... c_3 in powers of sqrt(gamma))
GCP_TERMS = 4
#: columns of :func:`limits`
LIMIT_COLUMNS = ["n", "sigma", "protocol", "observable", "value", "uncertainty", "rate", "packings"]


def speed(protocol: str, rate: float) -> str:
    """``"fast"``, ``"slow"`` or ``"between"``: the paper's class of a compression of
    algorithm ``protocol`` (``ls`` or ``fb``) at rate ``gamma``."""
    if protocol not in FAST_INVERSE_RATE:
        raise ValueError(f"protocol {protocol!r} has no fast/slow classes; valid: "
                         f"{sorted(FAST_INVERSE_RATE)}")
    if not rate > 0:
        raise ValueError(f"compression rate must be > 0, got {rate}")
    inv = 1.0 / rate
    if inv < FAST_INVERSE_RATE[protocol]:
        return "fast"
    return "slow" if inv > SLOW_INVERSE_RATE[protocol] else "between"


def zero_rate_extrapolation(rate, phi, terms: int = GCP_TERMS) -> dict:
    """Least-squares fit ``phi = sum_{i<terms} c_i gamma^(i/2)`` (``gamma``: compression
    rate, ``phi``: packing fractions) and its value at ``gamma = 0``: ``c0``, its
    standard error ``se``, the 95 % confidence half-width ``ci95`` (Student t with
    ``n - terms`` degrees of freedom, as the paper's Table 2 quotes) and ``n``; ``nan``
    values with fewer than ``terms + 1`` points."""
    g = np.asarray(rate, float)
    y = np.asarray(phi, float)
    ok = np.isfinite(g) & np.isfinite(y) & (g > 0)
    g, y = g[ok], y[ok]
    n = len(y)
    if n < terms + 1:
        return {"c0": math.nan, "se": math.nan, "ci95": math.nan, "n": n}
    x = np.sqrt(g)[:, None] ** np.arange(terms)[None, :]
    coef, _res, rank, _sv = np.linalg.lstsq(x, y, rcond=None)
    if rank < terms:
        return {"c0": math.nan, "se": math.nan, "ci95": math.nan, "n": n}
    dof = n - terms
    s2 = float(np.sum((y - x @ coef) ** 2)) / dof
    cov = s2 * np.linalg.inv(x.T @ x)
    se = math.sqrt(cov[0, 0])
    return {"c0": float(coef[0]), "se": se, "ci95": float(stats.t.ppf(0.975, dof)) * se,
            "n": n}


def _row(n, sigma, protocol, observable, value, uncertainty, rate, packings) -> dict:
    return dict(zip(LIMIT_COLUMNS, (int(n), float(sigma), protocol, observable, float(value),
                                    float(uncertainty), float(rate), int(packings))))


def limits(points: pd.DataFrame) -> pd.DataFrame:
    """The characteristic densities of a set of packings.

    ``points``: one row per packing with ``n`` (spheres), ``sigma`` (relative spread of
    diameters),
    ``protocol`` (``ls`` or ``fb``), ``rate`` (compression rate ``gamma``), ``phi``
    (density after the compression) and ``phi_j`` (closest jamming density).

    Returns :data:`LIMIT_COLUMNS` rows, per ``sigma`` and algorithm: ``phi_min_fast``,
    ``phi_max_fast_<alg>``, ``phi_mean_fast_<alg>`` (uncertainty: standard error) and
    ``phi_sd_fast_<alg>`` of ``phi_J`` over the fast packings (``rate``: the slowest of
    them); with enough slow packings ``phi_gcp_<alg>_initial`` and
    ``phi_gcp_<alg>_densified`` (zero-rate fits of ``phi`` and ``phi_J``, uncertainty:
    standard error, ``rate`` 0). Per ``n`` and ``sigma`` over the algorithms present (protocol
    ``"fb+ls"`` when both are): ``phi_lt`` and ``phi_rcp`` (means of the algorithms'
    lowest and highest fast ``phi_J``), ``phi_gcp`` (mean of the fits) and
    ``phi_gcp_minus_rcp``. ``packings`` counts the packings behind each row.
    """
    rows = []
    for (n, sigma), by_sigma in points.groupby(["n", "sigma"], sort=True):
        mins, maxs, gcps, rates, counts, n_slow = [], [], [], [], 0, 0
        for alg, g in by_sigma.groupby("protocol", sort=True):
            cls = np.array([speed(alg, r) for r in g["rate"]])
            fast = g[(cls == "fast") & np.isfinite(g["phi_j"])]
            slow = g[cls == "slow"]
            if len(fast):
                pj = fast["phi_j"].to_numpy(float)
                slowest = float(fast["rate"].min())
                sem = pj.std(ddof=1) / math.sqrt(len(pj)) if len(pj) > 1 else math.nan
                sd = pj.std(ddof=1) if len(pj) > 1 else math.nan
                rows += [_row(n, sigma, alg, "phi_min_fast", pj.min(), math.nan, slowest, len(pj)),
                         _row(n, sigma, alg, f"phi_max_fast_{alg}", pj.max(), math.nan, slowest,
                              len(pj)),
                         _row(n, sigma, alg, f"phi_mean_fast_{alg}", pj.mean(), sem, slowest,
                              len(pj)),
                         _row(n, sigma, alg, f"phi_sd_fast_{alg}", sd, math.nan, slowest, len(pj))]
                mins.append(pj.min())
                maxs.append(pj.max())
                rates.append(slowest)
                counts += len(pj)
            n_slow += len(slow)
            for kind, col in (("initial", "phi"), ("densified", "phi_j")):
                fit = zero_rate_extrapolation(slow["rate"], slow[col])
                if np.isfinite(fit["c0"]):
                    rows.append(_row(n, sigma, alg, f"phi_gcp_{alg}_{kind}", fit["c0"], fit["se"],
                                     0.0, fit["n"]))
                    gcps.append((fit["c0"], fit["se"], fit["n"]))
        algs = "+".join(sorted(by_sigma["protocol"].unique()))
        if mins:
            rows += [_row(n, sigma, algs, "phi_lt", np.mean(mins), math.nan, min(rates), counts),
                     _row(n, sigma, algs, "phi_rcp", np.mean(maxs), math.nan, min(rates), counts)]
        if gcps:
            c0 = np.mean([c for c, _, _ in gcps])
            se = math.sqrt(sum(s * s for _, s, _ in gcps)) / len(gcps)
            rows.append(_row(n, sigma, algs, "phi_gcp", c0, se, 0.0, n_slow))
            if mins:
                rows.append(_row(n, sigma, algs, "phi_gcp_minus_rcp", c0 - np.mean(maxs), se,
                                 0.0, counts + n_slow))
    return pd.DataFrame(rows, columns=LIMIT_COLUMNS)
