"""Files that are whole or absent: a file is written under ``<name>.part`` and renamed
when complete, so a killed process never leaves a half-written result under its real
name (every engine's outputs, run records, tables)."""
from __future__ import annotations

import os
from pathlib import Path


def part_path(path) -> Path:
    """Temporary name a file is written under until :func:`finalize`."""
    path = Path(path)
    return path.with_name(path.name + ".part")


def finalize(path):
    """Atomically move ``<path>.part`` to ``path`` (after flushing it to disk)."""
    tmp = part_path(path)
    with open(tmp, "rb+") as fh:
        os.fsync(fh.fileno())
    os.replace(tmp, path)


def atomic_write_text(path, text: str):
    """Write ``text`` to ``path`` atomically (temporary file, fsync, rename)."""
    tmp = part_path(path)
    with open(tmp, "w") as fh:
        fh.write(text)
        fh.flush()
        os.fsync(fh.fileno())
    os.replace(tmp, path)
