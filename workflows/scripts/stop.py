"""Stop the pipeline running in this directory so that the next ``make run`` resumes it.

``make stop`` sends SIGTERM to every Snakemake working in the directory, which then
schedules no further job and exits once the running ones have ended, and SIGINT to all the
processes those started. Each engine run stops, writes no ``run.json`` and keeps its last
checkpoint or restart file (:mod:`workflows.stopping`), so the next ``make run`` resumes
every stopped run where its checkpoint left it (pysim checkpoints every 300 s of wall
time, growth and jamming runs after every relaxation) and reruns nothing that finished.
Waits until they have all ended.

Neither signal alone stops a pipeline: with ``--keep-going`` a SIGINT to Snakemake
(measured with Snakemake 9.27) leaves it scheduling new jobs as the stopped ones fail, and
a SIGTERM to Snakemake alone makes it wait for every running job to finish, which for a
paper profile takes hours.
"""
from __future__ import annotations

import argparse
import signal
import sys
from pathlib import Path

import psutil

from workflows.scripts.unlock_if_idle import snakemake_processes_in


def stop(directory: Path, timeout: float = 120.0) -> int:
    """SIGTERM to the Snakemakes working in ``directory``, SIGINT to their descendants;
    wait up to ``timeout`` seconds for all to end. Returns how many processes were
    signalled."""
    top = {p.pid: p for p in snakemake_processes_in(directory)}
    jobs = {}
    for p in top.values():
        try:
            jobs.update({c.pid: c for c in p.children(recursive=True) if c.pid not in top})
        except psutil.Error:
            continue
    # Snakemake first, so that it schedules nothing new once the running jobs stop
    for procs, sig in ((top, signal.SIGTERM), (jobs, signal.SIGINT)):
        for p in procs.values():
            try:
                p.send_signal(sig)
            except psutil.Error:
                continue
    procs = [*top.values(), *jobs.values()]
    gone, alive = psutil.wait_procs(procs, timeout=timeout)
    if alive:
        names = ", ".join(f"{p.pid}" for p in alive)
        raise RuntimeError(f"processes {names} are still running {timeout:g} s after the stop "
                           "signals; "
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
