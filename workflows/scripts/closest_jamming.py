"""The hard-sphere packings of one study side by side (Baranau & Tallarek): a figure of
the density after each compression and its closest jamming density against the inverse
compression rate (their Fig. 2), and a table of the characteristic densities
(:func:`analysis.closest_jamming.limits`: phi_LT, phi_RCP, the GCP extrapolations).

  python -m workflows.scripts.closest_jamming --figure F.png --table T.csv RUN_DIR...

Each ``RUN_DIR`` is ``<results>/<study>/<case>/seed<k>/<engine>`` of a finished ``ls`` or
``fb`` run with the closest-jamming search (``observables.csv``); the case is read from
the ``case.yaml`` beside it. The table has the rows of
:func:`~analysis.closest_jamming.limits`, each filed under a case of its own
(``case``: ``n<N>_sigma<s>_<protocol>_fast`` or ``..._zero_rate``, seed 0), with ``like``
and ``like_seed``, a run whose case gives the other terms ``vs_paper`` matches to the
paper (workflows/vs_paper.py). Failed runs and runs without the search are left out."""
from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pandas as pd

from analysis.closest_jamming import limits
from analysis.plots import closest_jamming
from analysis.vs_paper import read_references
from rodcase.case import read_yaml
from rodcase.files import atomic_write_text
from workflows.scripts import study_figure_args
from workflows.vs_paper import REFERENCES


def load(run_dir: Path) -> dict | None:
    """One packing: its case's terms, ``phi`` and ``phi_j`` (``None`` without the
    closest-jamming search)."""
    case = read_yaml(run_dir.parent / "case.yaml")
    pr = case["protocol"]
    if pr["name"] not in ("ls", "fb") or "closest_jamming" not in pr:
        return None
    obs = pd.read_csv(run_dir / "observables.csv").set_index("observable")["value"]
    d = case["particles"]["diameter"]
    return {"case": run_dir.parent.parent.name,
            "seed": int(run_dir.parent.name.removeprefix("seed")),
            "n": int(case["particles"]["n"]),
            "sigma": float(d.get("sigma", 0.0)) if d.get("distribution") == "lognormal" else 0.0,
            "protocol": pr["name"], "rate": float(pr["rate"]),
            "phi": float(obs.get("phi", np.nan)), "phi_j": float(obs.get("phi_j", np.nan))}


def pseudo_cases(table: pd.DataFrame, points: pd.DataFrame) -> pd.DataFrame:
    """The limits ``table`` filed under cases of their own, each with a packing of its
    size, spread and algorithm(s) as ``like``."""
    out = table.copy()
    kind = np.where(out["rate"] > 0, "fast", "zero_rate")
    out["case"] = [f"n{n}_sigma{s:g}_{p}_{k}"
                   for n, s, p, k in zip(out["n"], out["sigma"], out["protocol"], kind)]
    out["seed"] = 0
    likes = []
    for n, s, p in zip(out["n"], out["sigma"], out["protocol"]):
        pick = points[(points["n"] == n) & np.isclose(points["sigma"], s)
                      & points["protocol"].isin(p.split("+"))].iloc[0]
        likes.append((pick["case"], int(pick["seed"])))
    out["like"] = [c for c, _ in likes]
    out["like_seed"] = [k for _, k in likes]
    return out


def main(argv=None) -> int:
    a = study_figure_args(__doc__, argv)
    loaded = [p for p in map(load, a.done) if p is not None]
    if not loaded:  # the failures are listed in failures.csv
        print(f"error: none of the {len(a.runs)} runs finished a closest-jamming search",
              file=sys.stderr)
        return 2
    points = pd.DataFrame(loaded)
    refs = read_references(REFERENCES)
    # the limits of Table 4 (the abstract's rounded ones repeat them)
    refs = refs[(refs["paper"] == "baranau2014") & (refs["kind"] == "value")
                & refs["observable"].isin(["phi_lt", "phi_rcp", "phi_gcp"])
                & refs["where"].str.contains("Table 4")]
    refs = refs.assign(sigma=pd.to_numeric(refs["sigma"], errors="coerce")).dropna(
        subset=["sigma"])
    closest_jamming(points, a.figure, references=refs,
                    title=f"{len(points)} packings; N = "
                          f"{', '.join(map(str, sorted(points['n'].unique())))}")
    table = pseudo_cases(limits(points), points)
    atomic_write_text(a.table, table.to_csv(index=False))
    return 0


if __name__ == "__main__":
    sys.exit(main())
