"""The run record (``run.json``) every engine's run leaves beside its output: engine and
version, case hash and seed, git revision, host, outcome (``docs/formats.md``)."""
from __future__ import annotations

import json
import os
import platform
import subprocess
import time
from pathlib import Path

from rodcase.case import case_hash
from rodcase.files import atomic_write_text

PROJECT_ROOT = Path(__file__).resolve().parents[1]


def git_revision() -> str:
    """The project's git revision (``-dirty`` when the tree has changes), or 'unknown'."""
    try:
        rev = subprocess.run(["git", "rev-parse", "--short=12", "HEAD"], cwd=PROJECT_ROOT,
                             capture_output=True, text=True, timeout=10).stdout.strip()
        dirty = subprocess.run(["git", "status", "--porcelain", "--untracked-files=no"],
                               cwd=PROJECT_ROOT, capture_output=True, text=True,
                               timeout=10).stdout.strip()
        return (rev + ("-dirty" if dirty else "")) if rev else "unknown"
    except (OSError, subprocess.SubprocessError):
        return "unknown"


def make(engine: str, version: str, case: dict, **extra) -> dict:
    """A run record: engine and version, case hash and seed, git revision, host."""
    return {
        "engine": engine,
        "engine_version": version,
        "case_hash": case_hash(case),
        "seed": case.get("seed"),
        "git_revision": git_revision(),
        "host": platform.node(),
        "python": platform.python_version(),
        "finished_at": time.strftime("%Y-%m-%dT%H:%M:%S%z"),
        "pid": os.getpid(),
        **extra,
    }


def write(path, rec: dict):
    """Write a record as sorted, indented JSON, atomically."""
    atomic_write_text(path, json.dumps(rec, indent=2, sort_keys=True, default=str) + "\n")
