"""Finite-size scaling of the 2-D orientational order: ``sqrt(N) S_2`` and
``sqrt(N) S_4`` versus packing fraction for every particle number N of a study's
compressions (figure), and per aspect ratio and N their mean and rms over the dense
frames (table, :func:`analysis.order.finite_size_order`)."""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

import pandas as pd

from analysis.order import finite_size_order
from analysis.plots import order_scaling
from rodcase.files import atomic_write_text
from rodcase.case import load_case
from workflows.runner import ok_runs

#: frames below this packing fraction are left out of the table (the dilute start)
PHI_MIN = 0.7


def run_curves(runs) -> pd.DataFrame:
    """The frame curves (``curves.csv``) of the successful runs among ``runs``
    (``<study>/<variant>/seed<k>/<engine>`` directories) with ``alpha`` (the case's
    aspect ratio), ``seed`` and ``engine`` columns added."""
    parts = []
    for run in ok_runs(runs):
        case = load_case(run.parent / "case.yaml")
        cv = pd.read_csv(run / "curves.csv")
        cv["alpha"] = float(case["particles"]["aspect_ratio"])
        cv["seed"] = int(case["seed"])
        cv["engine"] = run.name
        parts.append(cv)
    if not parts:
        raise SystemExit("no successful run to draw")
    return pd.concat(parts, ignore_index=True)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--runs", nargs="+", type=Path, required=True)
    ap.add_argument("--phi-min", type=float, default=PHI_MIN,
                    help=f"table: frames at or above this packing fraction (default {PHI_MIN})")
    ap.add_argument("--out", type=Path, required=True, help="figure (PNG)")
    ap.add_argument("--table", type=Path, required=True, help="table (CSV)")
    a = ap.parse_args(argv)
    curves = run_curves(a.runs)
    curves = curves[curves.sqrt_n_s2.notna()]
    if curves.empty:
        raise SystemExit("no rods among the runs: the order parameters are undefined")
    table = finite_size_order(curves, a.phi_min)
    atomic_write_text(a.table, table.to_csv(index=False, float_format="%.6g"))
    order_scaling(curves, table, a.out)
    return 0


if __name__ == "__main__":
    sys.exit(main())
