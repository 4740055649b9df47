"""Stop the pipeline running in this directory so that the next ``make run`` resumes it.

``make stop`` does what Ctrl-C does in the terminal that started ``make run``: it sends
SIGINT to every Snakemake working in the directory and to all the processes it started.
Snakemake schedules no further job; each engine run stops, writes no ``run.json`` and keeps
its last checkpoint or restart file (:mod:`workflows.stopping`), so the next ``make run``
resumes every stopped run where its checkpoint left it (pysim checkpoints every 300 s of
wall time, growth and jamming runs after every relaxation) and reruns nothing that
finished. Waits until they have all ended.

Do not stop a pipeline with ``kill`` on Snakemake alone: a SIGTERM makes Snakemake wait for
every running job to finish, which for a paper profile takes hours.
"""
from __future__ import annotations

import argparse
import signal
import sys
import time
from pathlib import Path

import psutil

from workflows.scripts.unlock_if_idle import snakemake_processes_in


def stop(directory: Path, timeout: float = 120.0) -> int:
    """SIGINT to the Snakemakes working in ``directory`` and their descendants; wait up to
    ``timeout`` seconds for all to end. Returns how many processes were signalled."""
    top = snakemake_processes_in(directory)
    procs = {p.pid: p for p in top}
    for p in top:
        try:
            procs.update({c.pid: c for c in p.children(recursive=True)})
        except psutil.Error:
            continue
    procs = list(procs.values())
    for p in procs:  # Snakemake first: it must schedule nothing new
        try:
            p.send_signal(signal.SIGINT)
        except psutil.Error:
            continue
    gone, alive = psutil.wait_procs(procs, timeout=timeout)
    if alive:
        names = ", ".join(f"{p.pid}" for p in alive)
        raise RuntimeError(f"processes {names} are still running {timeout:g} s after SIGINT; "
                           "look at them with ps, and end them with kill -9 (their runs then "
                           "resume from the last checkpoint)")
    return len(procs)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--directory", type=Path, default=Path.cwd(),
                    help="the pipeline's working directory (default: here)")
    ap.add_argument("--timeout", type=float, default=120.0,
                    help="seconds to wait for the processes to end (default 120)")
    a = ap.parse_args(argv)
    directory = a.directory.resolve()
    try:
        n = stop(directory, a.timeout)
    except RuntimeError as exc:
        print(f"rodpack: {exc}", file=sys.stderr)
        return 1
    if n == 0:
        print(f"rodpack: no pipeline is running in {directory}", file=sys.stderr)
    else:
        print(f"rodpack: stopped the pipeline in {directory} ({n} processes); "
              "'make run' resumes it", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
