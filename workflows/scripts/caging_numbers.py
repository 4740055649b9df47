"""Caging numbers of spherocylinders (Wouterse, Luding and Philipse, Sec. 3.2 and
Fig. 10a): the mean number of random point contacts that block a particle's
translations and, for rods, the rotations perpendicular to its axis
(:class:`analysis.caging.CagingNumber`), at the aspect ratios of a study's
``analysis.caging`` block, in 3-D and 2-D (``inf``: the infinite rod).

  python -m workflows.scripts.caging_numbers --table T.csv --figure F.png \\
      --trials 1000 --alphas-3d 0 0.1 1 inf --alphas-2d 0 inf

The table has one row per dimension and aspect ratio (``dimension``, ``alpha``,
``mean``, ``stderr``, ``trials``, ``seed``); the pipeline files them as rows of
``vs_paper`` (workflows/vs_paper.py), the largest mean over the rods of each dimension
also as ``caging_number_max``."""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np
import pandas as pd
from tqdm import tqdm

from analysis.caging import CagingNumber
from analysis.plots import caging_numbers
from analysis.vs_paper import parse_conditions, read_references
from rodcase.files import atomic_write_text
from workflows.vs_paper import REFERENCES


def table(alphas: dict, trials: int, seed: int) -> pd.DataFrame:
    """The caging numbers at ``alphas`` (``{dimension: [alpha, ...]}``), ``trials`` each,
    seeded alike for every point."""
    points = [(d, float(a)) for d, values in sorted(alphas.items()) for a in values]
    rows = []
    for dim, alpha in tqdm(points, desc="caging numbers", unit="point", file=sys.stderr):
        c = CagingNumber(radius=0.5, length=alpha, dim=dim, trials=trials, seed=seed).compute()
        rows.append({"dimension": dim, "alpha": alpha, "mean": c.mean, "stderr": c.stderr,
                     "trials": trials, "seed": seed})
    return pd.DataFrame(rows)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--table", required=True, type=Path)
    ap.add_argument("--figure", required=True, type=Path)
    ap.add_argument("--trials", type=int, default=1000)
    ap.add_argument("--seed", type=int, default=2024)
    ap.add_argument("--alphas-3d", nargs="*", type=float, default=[])
    ap.add_argument("--alphas-2d", nargs="*", type=float, default=[])
    a = ap.parse_args(argv)
    if a.trials < 2:
        ap.error(f"--trials must be >= 2 (a standard error needs two), got {a.trials}")
    alphas = {3: a.alphas_3d, 2: a.alphas_2d}
    bad = [x for x in a.alphas_3d + a.alphas_2d if not x >= 0]
    if bad:
        ap.error(f"aspect ratios must be >= 0 or inf, got {bad}")
    if not any(alphas.values()):
        ap.error("give aspect ratios: --alphas-3d and/or --alphas-2d")
    t = table({d: v for d, v in alphas.items() if v}, a.trials, a.seed)
    a.table.parent.mkdir(parents=True, exist_ok=True)
    atomic_write_text(a.table, t.to_csv(index=False))
    a.figure.parent.mkdir(parents=True, exist_ok=True)
    caging_numbers(t, a.figure, paper_values())
    return 0


def paper_values(references=REFERENCES) -> pd.DataFrame:
    """The papers' caging numbers (``references/``): ``dimension``, ``alpha`` (inf for
    the infinite rod), ``value``."""
    refs = read_references(references)
    refs = refs[(refs["observable"] == "caging_number") & (refs["kind"] == "value")]
    dims = [next((float(v) for k, _, v in parse_conditions(text) if k == "dimension"), np.nan)
            for text in refs["conditions"]]
    return pd.DataFrame({"dimension": dims,
                         "alpha": pd.to_numeric(refs["alpha"], errors="coerce").to_numpy(),
                         "value": refs["value"].astype(float).to_numpy()})


if __name__ == "__main__":
    sys.exit(main())
