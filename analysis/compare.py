"""Engine-versus-engine comparison tables with verdicts.

For every ``(study, case, observable)``: the mean, standard deviation and number of
seeds per engine, and for every engine the difference of its mean from the
other engines' with a verdict: ``agree`` when ``|difference| <= tolerance``,
``DIFFER`` otherwise, ``n/a`` when either side is missing. Tolerances are absolute,
per observable (:data:`TOLERANCES`); observables without one get no verdict. A second
verdict compares the difference with two standard errors of the difference of the seed
means (``uncertainty``; needs two seeds or more on both sides).
"""
from __future__ import annotations

import numpy as np
import pandas as pd

#: absolute tolerance of the engine agreement, per observable (tapping: the settled
#: density within 0.02 as the tapping issue asks, angles in degrees; deposits: the
#: packing fraction, the mean angle to the horizontal, the stress ratio K)
TOLERANCES = {"phi_j": 0.01, "z_j": 0.3, "phi_settled": 0.02, "phi_tapped": 0.02,
              "angle_settled": 5.0, "angle_tapped": 5.0, "phi_late": 0.02, "angle_late": 5.0,
              "phi_deposit": 0.03,
              "angle_mean": 5.0, "k_ratio": 0.15}


def per_engine(summary: pd.DataFrame) -> pd.DataFrame:
    """Mean, standard deviation and count over seeds per study, case, observable, engine."""
    g = summary.groupby(["study", "case", "observable", "engine"], sort=True)["value"]
    out = g.agg(mean="mean", std="std", n="count").reset_index()
    return out


ENGINE_ORDER = ("pysim", "lammps", "liggghts", "lammps-body")


def _order(engine: str) -> tuple:
    return (ENGINE_ORDER.index(engine) if engine in ENGINE_ORDER else len(ENGINE_ORDER), engine)


def compare(summary: pd.DataFrame, tolerances: dict | None = None) -> pd.DataFrame:
    """Every pair of engines, per study, case and observable with a tolerance: the
    difference of their seed means and a verdict (see the module docstring). The first
    engine of a pair comes first in :data:`ENGINE_ORDER` (pysim is the reference)."""
    tol = TOLERANCES if tolerances is None else tolerances
    stats = per_engine(summary)
    rows = []
    for (study, case, obs), grp in stats.groupby(["study", "case", "observable"], sort=True):
        if obs not in tol:
            continue
        recs = sorted((r for _, r in grp.iterrows()), key=lambda r: _order(r.engine))
        for a in range(len(recs)):
            for b in range(a + 1, len(recs)):
                ra, rb = recs[a], recs[b]
                # two standard errors of the difference, from the seed-to-seed spread
                unc = 2.0 * np.sqrt(ra["std"] ** 2 / ra["n"] + rb["std"] ** 2 / rb["n"]) \
                    if ra["n"] >= 2 and rb["n"] >= 2 else np.nan
                if np.isfinite(ra["mean"]) and np.isfinite(rb["mean"]):
                    diff = float(rb["mean"] - ra["mean"])
                    verdict = "agree" if abs(diff) <= tol[obs] else "DIFFER"
                    v_unc = ("n/a" if not np.isfinite(unc)
                             else "agree" if abs(diff) <= unc else "DIFFER")
                else:
                    diff, verdict, v_unc = np.nan, "n/a", "n/a"
                rows.append({"study": study, "case": case, "observable": obs,
                             "engine_a": ra.engine, "mean_a": ra["mean"], "std_a": ra["std"],
                             "engine_b": rb.engine, "mean_b": rb["mean"], "std_b": rb["std"],
                             "difference": diff, "tolerance": tol[obs], "verdict": verdict,
                             "uncertainty": unc, "verdict_uncertainty": v_unc})
    return pd.DataFrame(rows, columns=["study", "case", "observable", "engine_a", "mean_a",
                                       "std_a", "engine_b", "mean_b", "std_b", "difference",
                                       "tolerance", "verdict", "uncertainty",
                                       "verdict_uncertainty"])
