"""pysim, the reference engine, in the adapter table: it runs every shape under every
protocol of the case schema (whatever the schema admits, pysim runs), with no deck: the
runner starts ``python -m pysim run`` (:func:`command`), and a stopped run resumes from
its own checkpoint (:func:`latest_checkpoint`)."""
from __future__ import annotations

import sys
from pathlib import Path

from rodcase.case import SCHEMA_DIR, load_schema

#: the protocols of the case schema, in its order: every one of them is pysim's
PROTOCOLS = tuple(load_schema(SCHEMA_DIR / "case.schema.yaml")
                  ["properties"]["protocol"]["properties"]["name"]["enum"])
#: the complete snapshot a pysim run resumes from (:mod:`pysim.checkpoint`)
CHECKPOINT = "checkpoint.npz"


def command(case_path: Path, data: Path, out: Path, threads: int) -> list[str]:
    """``python -m pysim run`` of a case file from ``data`` into ``out`` on ``threads``
    Numba threads, with this interpreter."""
    return [sys.executable, "-m", "pysim", "run", str(case_path), "--data", str(data), "--out",
            str(out), "--no-progress", "--threads", str(threads)]


def latest_checkpoint(out: Path) -> Path | None:
    """The checkpoint a stopped pysim run in ``out`` resumes from, or None."""
    path = Path(out) / CHECKPOINT
    return path if path.exists() else None
