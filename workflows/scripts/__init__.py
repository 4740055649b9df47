"""The pipeline's command-line steps, one module per rule."""
from __future__ import annotations

import sys


def case_or_none(path):
    """The case file at ``path`` (:func:`rodcase.case.load_case`), or ``None`` once its
    one-line error is on standard error (the caller exits with status 2)."""
    from rodcase.case import ConfigError, load_case

    try:
        return load_case(path)
    except ConfigError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return None


def study_figure_args(doc: str, argv=None):
    """The arguments of a script that draws one figure and writes one table from a
    study's run directories (``--figure F.png --table T.csv RUN_DIR...``), with the runs
    that finished (``status: ok``) as ``a.done``."""
    import argparse
    from pathlib import Path

    from workflows.runner import ok_runs

    ap = argparse.ArgumentParser(description=doc.split("\n\n")[0])
    ap.add_argument("--figure", type=Path, required=True)
    ap.add_argument("--table", type=Path, required=True)
    ap.add_argument("runs", nargs="+", type=Path)
    a = ap.parse_args(argv)
    a.done = ok_runs(a.runs)
    return a

