"""Remove Snakemake's lock on a directory when no Snakemake process works in it.

A pipeline killed with ``kill -9`` (or a lost session) leaves ``.snakemake/locks`` behind
and the next run refuses to start. ``make run`` calls this first: if no running
Snakemake has the directory as its working directory, the lock is stale and is removed
(``snakemake --unlock``); otherwise nothing is touched.
"""
from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import psutil


def snakemake_processes_in(directory: Path) -> list[psutil.Process]:
    """The running Snakemake processes whose working directory is ``directory`` (this
    script and ``stop`` excluded)."""
    me = os.getpid()
    found = []
    for proc in psutil.process_iter(["pid", "cmdline", "cwd"]):
        try:
            cmd = " ".join(proc.info["cmdline"] or [])
            if proc.info["pid"] != me and "snakemake" in cmd and "unlock_if_idle" not in cmd \
                    and "scripts.stop" not in cmd \
                    and Path(proc.info["cwd"] or "/").resolve() == Path(directory).resolve():
                found.append(proc)
        except (psutil.Error, OSError):
            continue
    return found


def snakemake_running_in(directory: Path) -> bool:
    return bool(snakemake_processes_in(directory))


def main(argv=None) -> int:
    args = sys.argv[1:] if argv is None else argv
    directory = Path.cwd().resolve()
    locks = directory / ".snakemake" / "locks"
    if not locks.exists() or not any(locks.iterdir()):
        return 0
    if snakemake_running_in(directory):
        print("rodpack: another Snakemake is running here; leaving its lock", file=sys.stderr)
        return 0
    print("rodpack: removing the stale Snakemake lock of an interrupted run", file=sys.stderr)
    snakemake = Path(sys.executable).parent / "snakemake"
    return subprocess.run([str(snakemake), "--unlock", *args], capture_output=True).returncode


if __name__ == "__main__":
    sys.exit(main())
