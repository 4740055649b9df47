"""p(phi) of every run of a compression study on one log-scale figure, coloured by
variant: how the pressure curve changes with the study's varying parameter."""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

import pandas as pd

from analysis.plots import pressure_by_variant
from workflows.scripts.plot_study import pressure_curve
from workflows.runner import ok_runs


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--runs", nargs="+", type=Path, required=True,
                    help="run directories <study>/<variant>/seed<k>/<engine>")
    ap.add_argument("--parameter", default="", help="the varying parameter (legend)")
    ap.add_argument("--p-scale", type=float, default=1.0)
    ap.add_argument("--out", type=Path, required=True)
    a = ap.parse_args(argv)
    runs = []
    for run in ok_runs(a.runs):
        obs = pd.read_csv(run / "observables.csv")
        val = dict(zip(obs.observable, obs.value))
        value = obs[a.parameter].iloc[0] if a.parameter in obs.columns else run.parent.parent.name
        curves = pd.read_csv(run / "curves.csv")
        runs.append({"variant": run.parent.parent.name, "value": value, "engine": run.name,
                     "seed": run.parent.name, "thermo": pressure_curve(run, curves),
                     "points": "bulk" in curves,
                     "phi_j": val.get("phi_j", float("nan"))})
    pressure_by_variant(runs, a.out, p_scale=a.p_scale, parameter=a.parameter or None)
    return 0


if __name__ == "__main__":
    sys.exit(main())
