"""Figure of a deposition study against its paper: the trace of the mean stress versus
depth for every successful run, with our Janssen fits and, where the paper fits the same
case (references/), the paper's saturation curve."""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np
import pandas as pd

from analysis import plots
from rodcase.case import ConfigError, load_case
from workflows.runner import ok_runs
from analysis.vs_paper import unmet_conditions
from workflows.vs_paper import REFERENCES, case_terms, reference_rows


def paper_fit(case: dict, references=REFERENCES) -> dict | None:
    """The paper's Janssen fit of the trace at a case's point (``sigma_m_trace`` and
    ``h_s_p`` rows of ``references``), or ``None`` where it gives none; ``unmet``: the
    paper's conditions the case does not meet (width, N, feed, ...)."""
    refs = reference_rows(case, references)
    fit, unmet = {}, []
    for observable, key in (("sigma_m_trace", "sigma_m"), ("h_s_p", "h_s")):
        rows = refs[refs.observable == observable]
        if len(rows) != 1:
            return None
        ref = next(rows.itertuples())
        fit[key] = float(ref.value)
        fit["label"] = f"{ref.paper} ({ref.where.split(';')[0]})"
        unmet += [u for u in unmet_conditions(case_terms(case), ref) if u not in unmet]
    return {**fit, "unmet": unmet}


def run_profile(run: Path, dimension: int) -> dict:
    """One run's trace profile, its fit and fitted values, from ``curves.csv`` and
    ``observables.csv`` (:func:`analysis.summary.analyse_deposit`)."""
    prof = pd.read_csv(run / "curves.csv")
    obs = pd.read_csv(run / "observables.csv")
    val = dict(zip(obs.observable, obs.value))
    fit = prof.get("pressure_fit")
    return {"label": f"{run.parent.parent.name} {run.name} {run.parent.name}",
            "engine": run.name, "x": prof.x.to_numpy(float),
            "trace": dimension * prof.pressure.to_numpy(float),
            "fit": dimension * fit.to_numpy(float) if fit is not None and fit.notna().any()
            else None,
            "sigma_m": float(val.get("sigma_m_trace", np.nan)),
            "h_s": float(val.get("h_s_p", np.nan))}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--out", required=True, type=Path, help="figure (PNG)")
    ap.add_argument("run_dirs", nargs="+", type=Path,
                    help="run directories <study>/<variant>/seed<k>/<engine>")
    a = ap.parse_args(argv)
    panels = {}
    for run in ok_runs(a.run_dirs):
        variant = run.parent.parent.name
        try:
            case = load_case(run.parent / "case.yaml")
        except ConfigError as e:
            print(f"{run}: skipped, its case does not load ({e})", file=sys.stderr)
            continue
        if variant not in panels:
            panels[variant] = {"title": variant, "runs": [], "paper": paper_fit(case)}
        dimension = int(case["particles"].get("dimension", 3))
        panels[variant]["runs"].append(run_profile(run, dimension))
    plots.janssen_against_paper([panels[v] for v in sorted(panels)], a.out)
    return 0


if __name__ == "__main__":
    sys.exit(main())
