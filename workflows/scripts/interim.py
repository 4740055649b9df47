"""Interim tables of a profile still running: ``summary.csv``, ``comparison.csv``,
``failures.csv`` of every results folder from the runs finished so far, then
``vs_paper.csv`` from them all.

  python -m workflows.scripts.interim --results /work/runs/tapping /work/runs/dep \\
      --keep docs/studies/vs_paper.csv --docs docs/studies

A run counts once its analysis has written ``observables.csv``; a run that failed counts in
``failures.csv``; a run under way (no ``run.json`` yet) is left out. The pipeline rewrites
these tables when the profile ends (``make run``). ``--keep`` and ``--docs`` are those of
:mod:`workflows.scripts.vs_paper`; without ``--docs`` the table goes to the first folder's
``vs_paper.csv``."""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

from workflows.scripts import summarize
from workflows.scripts import vs_paper


def finished(results: Path) -> tuple[list[Path], list[Path]]:
    """``(records, observables)``: every ``run.json`` under ``results`` (finished or
    failed runs) and every ``observables.csv`` (analysed runs), in the layout
    ``<study>/<case>/seed<k>/<engine>/``."""
    records = sorted(results.glob("*/*/seed*/*/run.json"))
    observables = sorted(results.glob("*/*/seed*/*/observables.csv"))
    return records, observables


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--results", nargs="+", type=Path, required=True,
                    help="results folders of profiles (running or not)")
    ap.add_argument("--references", type=Path, default=vs_paper.REFERENCES,
                    help="folder of the papers' reference tables (default: %(default)s)")
    ap.add_argument("--keep", type=Path, help="earlier vs_paper.csv (see vs_paper --keep)")
    ap.add_argument("--docs", type=Path, help="study notebooks' folder (see vs_paper --docs)")
    a = ap.parse_args(argv)
    with_runs = []
    for root in a.results:
        if not root.is_dir():
            ap.error(f"--results {root}: no such folder (give a profile's results folder)")
        records, observables = finished(root)
        if not observables:
            print(f"{root}: no analysed run yet", file=sys.stderr)
            continue
        summarize.main(["--summary", str(root / "summary.csv"),
                        "--comparison", str(root / "comparison.csv"),
                        "--failures", str(root / "failures.csv"),
                        "--records", *map(str, records),
                        "--observables", *map(str, observables)])
        with_runs.append(root)
    args = ["--references", str(a.references), "--results", *map(str, with_runs or a.results)]
    if a.keep is not None:
        args += ["--keep", str(a.keep)]
    args += ["--docs", str(a.docs)] if a.docs else ["--out", str(a.results[0] / "vs_paper.csv")]
    return vs_paper.main(args)


if __name__ == "__main__":
    sys.exit(main())
