"""Join every run's observables: ``summary.csv`` (tidy), ``comparison.csv`` (engine
pairs with verdicts) and ``failures.csv`` (runs that produced no result)."""
from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import pandas as pd

from analysis.compare import compare
from analysis.summary import TIDY_COLUMNS
from rodcase.files import atomic_write_text
from rodcase.case import read_yaml
from workflows.studies import varying_columns
from workflows.scripts.analyse_run import PROVENANCE

FAILURE_COLUMNS = ["study", "case", "engine", "seed", "error", "log", "run_dir"]


def failures(records: list[Path]) -> pd.DataFrame:
    """One row per ``run.json`` whose status is not ``ok``; the run directory layout
    ``<results>/<study>/<case>/seed<k>/<engine>/run.json`` names it."""
    rows = []
    for p in records:
        rec = json.loads(Path(p).read_text())
        if rec.get("status") == "ok":
            continue
        engine_dir = Path(p).parent
        seed_dir = engine_dir.parent
        err = rec.get("error", "unknown error")
        log = err.rsplit("log: ", 1)[1] if "log: " in err else str(engine_dir / "log.txt")
        rows.append({"study": seed_dir.parent.parent.name, "case": seed_dir.parent.name,
                     "engine": engine_dir.name, "seed": int(seed_dir.name.removeprefix("seed")),
                     "error": err, "log": log, "run_dir": str(engine_dir)})
    return pd.DataFrame(rows, columns=FAILURE_COLUMNS)


def with_parameters(df: pd.DataFrame, observables: list[Path]) -> pd.DataFrame:
    """The varying case parameters of each study as columns (``alpha``, ``sigma``,
    ``kappa``, ...), taken from the ``case.yaml`` of every run present
    (``<results>/<study>/<case>/seed<k>/case.yaml``), not from the columns each run's
    analysis wrote: a variant added to a study later makes a parameter vary that the
    older runs' tables do not have."""
    cases: dict[str, dict[str, dict]] = {}
    for p in observables:
        seed_dir = Path(p).parent.parent
        cases.setdefault(seed_dir.parent.parent.name, {})[seed_dir.parent.name] = (
            read_yaml(seed_dir / "case.yaml"))
    df = df.drop(columns=[c for c in df.columns
                          if c not in TIDY_COLUMNS and c not in PROVENANCE])
    parts = []
    for study, g in df.groupby("study", sort=False):
        g = g.copy()
        for name, values in varying_columns(cases.get(study, {})).items():
            g[name] = g["case"].map(values)
        parts.append(g)
    return pd.concat(parts, ignore_index=True) if parts else df


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--summary", required=True, type=Path)
    ap.add_argument("--comparison", required=True, type=Path)
    ap.add_argument("--failures", required=True, type=Path)
    ap.add_argument("--records", nargs="+", type=Path, required=True)
    ap.add_argument("--observables", nargs="+", type=Path, required=True)
    a = ap.parse_args(argv)
    df = with_parameters(pd.concat([pd.read_csv(p) for p in a.observables],
                                   ignore_index=True), a.observables)
    extra = [c for c in df.columns if c not in TIDY_COLUMNS]
    df = df[TIDY_COLUMNS + extra].sort_values(["study", "case", "engine", "seed", "observable"])
    atomic_write_text(a.summary, df.to_csv(index=False))
    cmp = compare(df)
    atomic_write_text(a.comparison, cmp.to_csv(index=False))
    fail = failures(a.records)
    atomic_write_text(a.failures, fail.to_csv(index=False))
    # the verdicts themselves are the landing page's to print (workflows/landing.py)
    print(f"{a.summary}: {len(df)} rows; {a.comparison}: {len(cmp)} engine pairs; "
          f"{a.failures}: {len(fail)} failed runs", file=sys.stderr)
    for _, r in fail.iterrows():
        print(f"FAILED {r.study}/{r.case}/seed{r.seed}/{r.engine}: {r.error}", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
