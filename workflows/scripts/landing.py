"""The report's first page and the verdicts at the end of ``make run``.

  python -m workflows.scripts.landing --results results --print
  python -m workflows.scripts.landing --results results --html results/landing.html \\
      --figure results/figures/engine_differences.png
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

from rodcase.files import atomic_write_text
from workflows.landing import landing_html, landing_text, tables


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--results", type=Path, required=True, help="a results folder")
    ap.add_argument("--html", type=Path, help="the first page's HTML fragment to write")
    ap.add_argument("--figure", type=Path, help="PNG of the engines' differences")
    ap.add_argument("--print", action="store_true", help="print the verdicts")
    a = ap.parse_args(argv)
    if not a.results.is_dir():
        print(f"error: {a.results}: no such results folder", file=sys.stderr)
        return 2
    if a.html:
        atomic_write_text(a.html, landing_html(a.results))
    if a.figure:
        from analysis.plots import engine_differences, message_figure

        cmp = tables(a.results)["comparison"]
        if len(cmp):
            engine_differences(cmp, a.figure)
        else:
            message_figure(a.figure, "No case ran on two engines.")
    if a.print:
        print(landing_text(a.results))
    return 0


if __name__ == "__main__":
    sys.exit(main())
