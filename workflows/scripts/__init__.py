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
