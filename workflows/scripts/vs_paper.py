"""Every published value against our runs: ``vs_paper.csv``.

  python -m workflows.scripts.vs_paper --results results --out results/vs_paper.csv
  python -m workflows.scripts.vs_paper --results results /work/runs/* --docs docs/studies
  python -m workflows.scripts.vs_paper --results /work/runs/* --keep docs/studies/vs_paper.csv \
      --docs docs/studies

``--keep`` carries over the rows of an earlier table whose studies (in its ``runs`` column)
these results folders do not answer: measurements of runs whose folders are elsewhere.

``--docs`` writes ``<docs>/vs_paper.csv`` and the verdict block at the top of every study
notebook there (the table the study docs report, kept in git)."""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

import pandas as pd

from analysis.vs_paper import ReferenceError, verdict_counts
from rodcase.files import atomic_write_text
from rodcase.case import ConfigError
from workflows.vs_paper import (REFERENCES, STUDY_DOCS, carry_forward, markdown_table,
                                vs_paper, with_block)



def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--references", type=Path, default=REFERENCES,
                    help="folder of the papers' reference tables (default: %(default)s)")
    ap.add_argument("--results", nargs="+", type=Path, required=True,
                    help="results folders (each with summary.csv and the runs' case.yaml)")
    ap.add_argument("--out", type=Path, help="vs_paper.csv to write")
    ap.add_argument("--figure", type=Path, help="PNG of the published values against ours")
    ap.add_argument("--docs", type=Path,
                    help="study notebooks' folder: writes vs_paper.csv and their blocks")
    ap.add_argument("--keep", type=Path,
                    help="earlier vs_paper.csv whose rows stay where these results do not "
                         "answer their studies")
    a = ap.parse_args(argv)
    if a.out is None and a.docs is None:
        ap.error("give --out, --docs or both")
    try:
        table, judged = vs_paper(a.references, a.results)
        if a.keep is not None:
            if not a.keep.is_file():
                raise ConfigError(f"--keep {a.keep}: no such file (give an earlier vs_paper.csv)")
            table, kept = carry_forward(table, pd.read_csv(a.keep), judged)
            print(f"kept {kept} rows of {a.keep} whose studies these results do not answer",
                  file=sys.stderr)
    except (ReferenceError, ConfigError) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    csv = table.to_csv(index=False)
    if a.out is not None:
        atomic_write_text(a.out, csv)
    if a.figure is not None:
        from analysis.plots import against_papers

        against_papers(table, a.figure)
    if a.docs is not None:
        atomic_write_text(a.docs / "vs_paper.csv", csv)
        for study, name in STUDY_DOCS.items():
            doc = a.docs / name
            if doc.is_file():
                atomic_write_text(doc, with_block(doc.read_text(), markdown_table(table, study)))
    counts = verdict_counts(table)
    print("against the papers: " + ", ".join(f"{n} {v}" for v, n in sorted(counts.items())),
          file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
