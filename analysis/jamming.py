"""Jamming point from the first linear rise of the pressure.

During a compression the contact pressure stays near zero below jamming and rises
linearly above it (linear contacts). Fit ``p = a (phi - phi_J)`` to the first
stretch of ``p(phi)`` inside a pressure window ``[p_lo, p_hi]``, up to the first plastic
drop of the pressure (Marschall & Teitel 2018, Sec. III.B: the linear part "before there
occurs any plastic rearrangements"), and report the extrapolation ``phi_J`` with its
standard error (science.md section 5).
"""
from __future__ import annotations

import numpy as np
from scipy.optimize import curve_fit

from analysis.base import Observable


class JammingFitError(ValueError):
    """The pressure curve does not contain a usable linear rise."""


#: a fall of the pressure from one row to the next by more than this fraction ends the
#: first rise: a plastic rearrangement. Smaller dips are the rows' noise in a compression
#: at a finite rate (quasistatic steps have none, and their drops are 10-20 %)
DROP = 0.05


def first_rise(p: np.ndarray, p_lo: float, p_hi: float, drop: float = DROP) -> slice:
    """Rows of the first rise through ``[p_lo, p_hi]``.

    A rise starts below ``p_lo``: rows before the first one with ``p < p_lo`` (a
    pressure still relaxing from an earlier, faster stage) are skipped. It ends at the
    first later row with ``p >= p_hi`` and starts after the last row before it with
    ``p < p_lo``, so that pressure spikes of the unjammed, flowing state are ignored.
    A row whose pressure is below ``(1 - drop)`` times the row before it ends the rise
    earlier, at that row before it: the fit stops at the first plastic drop.
    """
    p = np.asarray(p, dtype=np.float64)
    low = np.flatnonzero(p < p_lo)
    if len(low) == 0:
        raise JammingFitError(f"pressure is never below the bottom of the fit window "
                              f"p_lo = {p_lo:.3g} (min {np.nanmin(p):.3g}): the run starts "
                              "jammed; start below jamming or raise the window")
    above = np.flatnonzero(p[low[0]:] >= p_hi) + low[0]
    if len(above) == 0:
        raise JammingFitError(f"pressure never reaches the top of the fit window "
                              f"p_hi = {p_hi:.3g} after falling below p_lo (max "
                              f"{np.nanmax(p[low[0]:]):.3g}); compress further or lower the "
                              "window")
    end = above[0]
    below = np.flatnonzero(p[:end] < p_lo)
    start = below[-1] + 1 if len(below) else 0
    falls = np.flatnonzero(p[start + 1:end + 1] < (1.0 - drop) * p[start:end])
    if len(falls):
        end = start + falls[0]
    return slice(start, end + 1)


def _line(phi, a, phi_j):
    return a * (phi - phi_j)


class JammingPoint(Observable):
    """``phi_J`` by linear extrapolation of the first pressure rise to ``p = 0``.

    ``window = (p_lo, p_hi)`` in units of ``p_scale`` (e.g. ``k_n / D``). Results:
    ``phi_j``, ``phi_j_err`` (standard error of the fit), ``slope`` (pressure per unit
    packing fraction), ``rows`` (slice of the fitted points), ``n_points``.
    """

    _results = ("phi_j", "phi_j_err", "slope", "rows", "n_points")

    def __init__(self, window=(1e-3, 1e-2), p_scale: float = 1.0):
        lo, hi = window
        if not 0 < lo < hi:
            raise ValueError(f"jamming window must satisfy 0 < p_lo < p_hi, got {window}")
        self.window = (float(lo), float(hi))
        self.p_scale = float(p_scale)

    def compute(self, phi, pressure):
        phi = np.asarray(phi, dtype=np.float64)
        p = np.asarray(pressure, dtype=np.float64) / self.p_scale
        rows = first_rise(p, *self.window)
        x, y = phi[rows], p[rows]
        if len(x) < 3:
            raise JammingFitError(
                f"only {len(x)} points in the first pressure rise through {self.window}; "
                "write thermo rows more often or compress more slowly")
        slope0 = (y[-1] - y[0]) / (x[-1] - x[0]) if x[-1] != x[0] else 1.0
        guess = (slope0, x[0] - y[0] / slope0 if slope0 else x[0])
        (a, phi_j), cov = curve_fit(_line, x, y, p0=guess)
        err = float(np.sqrt(cov[1, 1])) if np.isfinite(cov[1, 1]) else float("nan")
        self._set(phi_j=float(phi_j), phi_j_err=err, slope=float(a) * self.p_scale, rows=rows,
                  n_points=len(x))
        return self


def sample_mean(values, errors=None) -> tuple[float, float]:
    """Mean of per-sample values (e.g. ``phi_J,s`` of independent runs) and its standard
    error ``std / sqrt(n)`` (science.md: average ``phi_J`` over samples). With per-sample
    ``errors`` the error is the larger of that spread and the propagated fit errors
    ``sqrt(sum err^2) / n``."""
    v = np.asarray(values, dtype=np.float64)
    v = v[np.isfinite(v)]
    if len(v) == 0:
        raise JammingFitError("no finite samples to average")
    spread = float(v.std(ddof=1) / np.sqrt(len(v))) if len(v) > 1 else float("nan")
    if errors is not None:
        e = np.asarray(errors, dtype=np.float64)
        e = e[np.isfinite(e)]
        prop = float(np.sqrt(np.sum(e**2)) / len(v)) if len(e) else float("nan")
        spread = float(np.nanmax([spread, prop]))
    return float(v.mean()), spread
