"""Join every run's observables: ``summary.csv`` (tidy), ``comparison.csv`` (engine
pairs with verdicts)."""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

import pandas as pd

from analysis.compare import compare
from analysis.summary import TIDY_COLUMNS
from pysim.io import atomic_write_text


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--summary", required=True, type=Path)
    ap.add_argument("--comparison", required=True, type=Path)
    ap.add_argument("observables", nargs="+", type=Path)
    a = ap.parse_args(argv)
    df = pd.concat([pd.read_csv(p) for p in a.observables], ignore_index=True)
    extra = [c for c in df.columns if c not in TIDY_COLUMNS]
    df = df[TIDY_COLUMNS + extra].sort_values(["study", "case", "engine", "seed", "observable"])
    atomic_write_text(a.summary, df.to_csv(index=False))
    cmp = compare(df)
    atomic_write_text(a.comparison, cmp.to_csv(index=False))
    for _, r in cmp.iterrows():
        print(f"{r.study}/{r.case} {r.observable}: {r.engine_a} {r.mean_a:.4f} vs {r.engine_b} "
              f"{r.mean_b:.4f} -> {r.verdict}", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
