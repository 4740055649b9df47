"""Figure of a deposition study against its paper: the trace of the mean stress in
elements five particle lengths square versus depth (the paper's Fig. 6) for every
successful run, with our Janssen fits and, where the paper fits the same case
(references/), the paper's saturation curve."""
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
    """The paper's Janssen fit of the trace at a case's point (``sigma_m_trace_rve`` and
    ``h_s_trace_rve`` rows of ``references``), or ``None`` where it gives none;
    ``unmet``: the paper's conditions of its ``h_s`` the case does not meet (width, N,
    feed, ...): the figure compares the shape of the profile, ``tr sigma / sigma_m``
    against ``x``, not the paper's stresses (their grain density is unstated)."""
    refs = reference_rows(case, references)
    fit, unmet = {}, []
    for observable, key in (("sigma_m_trace_rve", "sigma_m"), ("h_s_trace_rve", "h_s")):
        rows = refs[refs.observable == observable]
        if len(rows) != 1:
            return None
        ref = next(rows.itertuples())
        fit[key] = float(ref.value)
        fit["label"] = f"{ref.paper} ({ref.where.split(';')[0]})"
        if key == "h_s":
            unmet = unmet_conditions(case_terms(case), ref)
    return {**fit, "unmet": unmet}


def run_profile(run: Path) -> dict:
    """One run's element profile of the trace (the rows where ``trace_rve`` is set), its
    fit and fitted values, from ``curves.csv`` and ``observables.csv``
    (:func:`analysis.summary.analyse_deposit`)."""
    prof = pd.read_csv(run / "curves.csv")
    obs = pd.read_csv(run / "observables.csv")
    val = dict(zip(obs.observable, obs.value))
    rows = prof[prof.trace_rve.notna()]
    fit = prof.trace_rve_fit
    return {"label": f"{run.parent.parent.name} {run.name} {run.parent.name}",
            "engine": run.name, "x": rows.x.to_numpy(float),
            "trace": rows.trace_rve.to_numpy(float), "err": rows.trace_rve_err.to_numpy(float),
            "fit": (prof.x.to_numpy(float), fit.to_numpy(float)) if fit.notna().any()
            else None,
            "sigma_m": float(val.get("sigma_m_trace_rve", np.nan)),
            "h_s": float(val.get("h_s_trace_rve", np.nan))}


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
        panels[variant]["runs"].append(run_profile(run))
    plots.janssen_against_paper([panels[v] for v in sorted(panels)], a.out)
    return 0


if __name__ == "__main__":
    sys.exit(main())
