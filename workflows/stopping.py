"""Stopping a run is not failing it.

A run stopped by a signal — SIGINT (Ctrl-C), SIGTERM (``kill``, ``scancel``, a batch
system's time limit) or SIGHUP (the terminal closed) — has no result yet: it must leave no
``run.json``, so that Snakemake counts the job as not done and the next run resumes it from
its last checkpoint or restart file. :func:`stop_signals_raise` turns those signals into
:class:`Interrupted` in the runner; :func:`check_signalled` does the same for an engine
process that one of them ended; :func:`stop_process` ends an engine process politely.
"""
from __future__ import annotations

import contextlib
import signal
import subprocess
import threading

#: signals that stop a run without making it a failure
STOP_SIGNALS = (signal.SIGINT, signal.SIGTERM, signal.SIGHUP)
#: seconds an engine gets to end after SIGTERM (mpiexec passes it to its ranks) before SIGKILL
GRACE_SECONDS = 10.0


class Interrupted(BaseException):
    """A run was stopped by signal ``signum`` before it finished: no result, to be resumed.

    A ``BaseException``, like ``KeyboardInterrupt``, so that no ``except Exception`` turns
    it into a failure record."""

    def __init__(self, signum: int, who: str = "the runner"):
        self.signum = int(signum)
        super().__init__(f"{who} got {signal.Signals(signum).name}")


def _raise(signum, frame):
    raise Interrupted(signum)


@contextlib.contextmanager
def stop_signals_raise():
    """Inside the block, :data:`STOP_SIGNALS` raise :class:`Interrupted` (main thread only;
    elsewhere Python cannot install handlers and the block runs unchanged)."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    previous = {s: signal.signal(s, _raise) for s in STOP_SIGNALS}
    try:
        yield
    finally:
        for s, handler in previous.items():
            signal.signal(s, handler)


def check_signalled(who: str, returncode: int) -> None:
    """Raise :class:`Interrupted` when the process ``who`` ended by one of
    :data:`STOP_SIGNALS`: killed by it (a ``returncode`` of minus the signal number) or
    exiting with ``128 +`` its number after catching it, as ``python -m pysim run`` does
    on Ctrl-C (130) and shells do."""
    if returncode is None:
        return
    for s in STOP_SIGNALS:
        if returncode in (-s, 128 + s):
            raise Interrupted(s, who)


def stop_process(proc: subprocess.Popen, grace: float = GRACE_SECONDS) -> None:
    """End ``proc``: SIGTERM, then SIGKILL if it is still running after ``grace`` seconds."""
    if proc.poll() is not None:
        return
    proc.terminate()
    try:
        proc.wait(timeout=grace)
    except subprocess.TimeoutExpired:
        proc.kill()
        proc.wait()
