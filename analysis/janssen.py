"""Janssen fits of stress versus depth, with uncertainties (science.md section 5).

* saturation form in the dimensionless depth ``x = depth / W``:
  ``sigma(x) = sigma_m (1 - exp(-x / h_s))``;
* classical form for the vertical stress at depth ``z``:
  ``sigma_zz(z) = sigma_inf (1 - exp(-z / lambda))`` with
  ``lambda = W / (4 mu_w K)`` in a cylinder of diameter ``W`` (a 2-D slot of width
  ``W`` has two walls: ``lambda = W / (2 mu_w K)``), ``K = sigma_xx / sigma_zz``.
  Given the wall friction ``mu_w`` the fit yields ``K``; given ``K``, ``mu_w``.

Stresses enter **compressive positive** (pass ``-sigma_zz`` of the tension-positive
:class:`analysis.stress.StressProfile`). Parameters come from
:func:`scipy.optimize.curve_fit`; with per-point errors ``sigma_err`` the covariance
is absolute, otherwise scaled by the residual variance; ``absolute_errors=False`` takes
the errors as relative weights only and scales the covariance by the reduced chi-square
(for errors estimated from a few samples each, which scatter too much to be taken at
their word). Uncertainties are one standard
error; derived quantities propagate the covariance to first order.
"""
from __future__ import annotations

import numpy as np
from scipy.optimize import curve_fit

from analysis.base import Observable


def janssen(x, sigma_m, h_s):
    """``sigma_m (1 - exp(-x / h_s))``."""
    return sigma_m * -np.expm1(-np.asarray(x, dtype=np.float64) / h_s)


class JanssenFitError(ValueError):
    """The profile cannot be fitted (too few points, no saturation, ...)."""


class JanssenFit(Observable):
    """Fit of ``sigma_m (1 - exp(-x / h_s))`` to a stress profile.

    Parameters: ``form`` ``"saturation"`` (``x = depth / width``; results ``sigma_m``,
    ``h_s``) or ``"classical"`` (``x = depth``; results ``sigma_m`` = ``sigma_inf`` and
    ``h_s`` = ``lambda``, plus ``K`` from ``mu_w`` or ``mu_w`` from ``K``);
    ``width`` ``W`` (needed by both forms), ``mu_w`` or ``K`` (classical only),
    ``walls`` ``"cylinder"`` (factor 4) or ``"slot"`` (factor 2), ``absolute_errors``
    (default true: ``sigma_err`` are standard errors; false: relative weights).

    ``compute(depth, sigma, sigma_err=None)``. Results: ``sigma_m``, ``sigma_m_err``,
    ``h_s``, ``h_s_err``, ``cov`` (2, 2), ``K``, ``K_err``, ``mu_w``, ``mu_w_err``
    (nan when not applicable), ``chi2`` (weighted when ``sigma_err`` is given),
    ``dof``, ``residuals``.
    """

    _results = ("sigma_m", "sigma_m_err", "h_s", "h_s_err", "cov", "K", "K_err", "mu_w",
                "mu_w_err", "chi2", "dof", "residuals")

    def __init__(self, form: str = "saturation", width: float = 1.0, mu_w: float | None = None,
                 K: float | None = None, walls: str = "cylinder", absolute_errors: bool = True):
        if form not in ("saturation", "classical"):
            raise ValueError(f"form must be 'saturation' or 'classical', got {form!r}")
        if not width > 0:
            raise ValueError(f"width must be > 0, got {width}")
        if walls not in ("cylinder", "slot"):
            raise ValueError(f"walls must be 'cylinder' or 'slot', got {walls!r}")
        if mu_w is not None and K is not None:
            raise ValueError("give mu_w (to get K) or K (to get mu_w), not both")
        self.form, self.width, self.walls = form, float(width), walls
        self.friction, self.k_ratio = mu_w, K
        self.absolute_errors = bool(absolute_errors)

    def compute(self, depth, sigma, sigma_err=None):
        depth = np.asarray(depth, dtype=np.float64)
        sigma = np.asarray(sigma, dtype=np.float64)
        ok = np.isfinite(depth) & np.isfinite(sigma)
        if sigma_err is not None:
            sigma_err = np.broadcast_to(np.asarray(sigma_err, dtype=np.float64), sigma.shape)
            ok &= np.isfinite(sigma_err) & (sigma_err > 0)
        x = depth[ok] / (self.width if self.form == "saturation" else 1.0)
        y = sigma[ok]
        err = None if sigma_err is None else sigma_err[ok]
        if len(x) < 3:
            raise JanssenFitError(f"need at least 3 finite points, got {len(x)}")
        if np.nanmax(y) <= 0:
            raise JanssenFitError("stresses must be compressive positive (pass -sigma_zz of a "
                                  "tension-positive profile)")
        # start: saturation at the largest stress, scale at the depth of 63 % of it
        s0 = float(np.max(y))
        reach = x[np.argmax(y >= 0.632 * s0)] if np.any(y >= 0.632 * s0) else float(np.max(x))
        p0 = (s0, max(float(reach), 1e-3 * float(np.ptp(x)) or 1.0))
        try:
            popt, cov = curve_fit(janssen, x, y, p0=p0, sigma=err,
                                  absolute_sigma=err is not None and self.absolute_errors,
                                  maxfev=20000)
        except RuntimeError as exc:
            raise JanssenFitError(f"Janssen fit did not converge: {exc}") from None
        res = y - janssen(x, *popt)
        chi2 = float(np.sum((res / err) ** 2)) if err is not None else float(np.sum(res**2))
        perr = np.sqrt(np.diag(cov))
        k = k_err = mu = mu_err = np.nan
        if self.form == "classical":
            factor = 4.0 if self.walls == "cylinder" else 2.0
            lam, lam_err = popt[1], perr[1]
            if self.friction is not None:  # K = W / (factor mu_w lambda)
                k = self.width / (factor * self.friction * lam)
                k_err = k * lam_err / lam
            if self.k_ratio is not None:
                mu = self.width / (factor * self.k_ratio * lam)
                mu_err = mu * lam_err / lam
        self._set(sigma_m=float(popt[0]), sigma_m_err=float(perr[0]), h_s=float(popt[1]),
                  h_s_err=float(perr[1]), cov=cov, K=float(k), K_err=float(k_err),
                  mu_w=float(mu), mu_w_err=float(mu_err), chi2=chi2, dof=len(x) - 2,
                  residuals=res)
        return self
