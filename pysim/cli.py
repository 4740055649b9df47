"""Command line: ``python -m pysim init|run CASE.yaml ...``.

* ``init CASE.yaml --out init.data``: the random non-overlapping start of a case
  (LAMMPS data file shared by every engine).
* ``run CASE.yaml --out DIR [--data init.data] [--resume]``: run the case's protocol and
  write ``particles.dump``, ``contacts.dump``, ``thermo.dat`` and ``run.json`` in DIR;
  ``--resume`` continues a killed run from its last checkpoint.
* ``--threads N`` (both): threads of the parallel kernels, default 1 (as the pipeline runs
  pysim; results are the same bits on any number), at most Numba's pool
  (``NUMBA_NUM_THREADS``, all cores unless set).

A bad case file, data file or option is a one-line error and exit status 2, given before
anything is written; a run that blows up stops with a
one-line message naming the step and particles, exit status 3, and keeps its last
checkpoint (so does a tapping run whose free preparation has not settled by its
``max_time``, and a fed deposit that is blocked or not settled by its ``max_time``).
Ctrl-C (SIGINT) stops a run with a one-line message and exit status 130; its
last checkpoint stays, and the same command with ``--resume`` goes on from it.
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

from pysim.initial import write_initial


def main(argv=None) -> int:
    from rodcase.case import ConfigError, load_case

    from pysim.io import DataFileError

    ap = argparse.ArgumentParser(prog="python -m pysim", description=__doc__.split("\n\n")[0])
    common = argparse.ArgumentParser(add_help=False)
    common.add_argument("--threads", type=int, default=1, metavar="N",
                        help="threads of the parallel kernels (default 1; the results do not "
                             "depend on it)")
    sub = ap.add_subparsers(dest="command", required=True)
    a = sub.add_parser("init", parents=[common],
                       help="write the random initial configuration of a case")
    a.add_argument("case", type=Path)
    a.add_argument("--out", type=Path, required=True, help="LAMMPS data file to write")
    r = sub.add_parser("run", parents=[common],
                       help="run a case and write the common output format")
    r.add_argument("case", type=Path)
    r.add_argument("--out", type=Path, required=True, help="output directory")
    r.add_argument("--data", type=Path, help="initial configuration (default: made from the seed)")
    r.add_argument("--no-progress", action="store_true", help="no progress bar")
    r.add_argument("--resume", action="store_true",
                   help="continue a killed run from DIR/checkpoint.npz (same final state)")
    r.add_argument("--checkpoint-every", type=float, default=300.0, metavar="SECONDS",
                   help="wall time between checkpoints (default 300)")
    args = ap.parse_args(argv)
    try:
        case = load_case(args.case)
        _use_threads(args.threads)
        if args.command == "init":
            write_initial(case, args.out)
            return 0
        init = _initial(case, args.data)
    except (ConfigError, DataFileError, UsageError) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    return _run(case, init, args)


class UsageError(ValueError):
    """A command-line option is out of range; the message is one line."""


def _use_threads(n: int) -> None:
    """Run the parallel kernels on ``n`` threads from the start (before any kernel runs,
    so that Numba's pool starts on the layer :mod:`pysim.jit` chose)."""
    from pysim.jit import max_threads, set_threads

    if not 1 <= n <= max_threads():
        raise UsageError(f"--threads {n} is not allowed; use 1 to {max_threads()} (at most "
                         "Numba's pool, NUMBA_NUM_THREADS, all cores unless set)")
    set_threads(n)


def _initial(case: dict, data: Path | None) -> dict:
    """The initial configuration: ``data`` (checked against the case), or the case's
    random start when None. Raises :class:`pysim.io.DataFileError` before anything is
    written."""
    import tempfile

    from pysim import io

    if data is None:
        data = Path(tempfile.mkdtemp()) / "init.data"
        write_initial(case, data)
    init = io.read_particle_data(data)
    if len(init["ids"]) != case["particles"]["n"]:
        raise io.DataFileError(f"{data} holds {len(init['ids'])} particles, the case says "
                               f"particles.n = {case['particles']['n']}; give the data file "
                               "of this case (python -m pysim init CASE.yaml --out ...)")
    return init


def _run(case, init, args) -> int:
    import pysim
    from pysim.jit import get_threads
    from pysim.hard.cells import GridError
    from pysim.hard.edmd import DynamicsError
    from pysim.protocols import (compress, deposit, fb, growth, jammed, ls, mls, quasistatic,
                                 tapping)
    from pysim.protocols.contraction import ContractionJammedError
    from pysim.protocols.hard import StartError
    from pysim.protocols.output import ResumeError
    from pysim.simulation import BlowUpError
    from rodcase import record

    args.out.mkdir(parents=True, exist_ok=True)
    driver = {"compress": compress, "growth": growth, "jammed": jammed,
              "quasistatic": quasistatic, "tapping": tapping, "deposit": deposit, "ls": ls,
              "mls": mls, "fb": fb}[case["protocol"]["name"]]
    try:
        summary = driver.run(case, init, args.out, progress=not args.no_progress,
                             resume=args.resume, checkpoint_every=args.checkpoint_every)
    except (ResumeError, StartError, GridError) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    except (BlowUpError, growth.GrowthLimitError, ContractionJammedError, tapping.SettleError,
            deposit.FeedBlockedError, deposit.NotSettledError, DynamicsError) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 3
    except (KeyboardInterrupt, SystemError) as exc:
        # Ctrl-C inside a compiled kernel reaches Python as a SystemError whose cause
        # chain holds the KeyboardInterrupt
        if not _interrupted(exc):
            raise
        ckpt = args.out / "checkpoint.npz"
        where = (f"its last checkpoint, {ckpt}, stays" if ckpt.exists()
                 else "it had written no checkpoint yet")
        print(f"stopped by Ctrl-C: {where}; run the same command with --resume to go on",
              file=sys.stderr)
        return 130
    record.write(args.out / "run.json",
                     record.make("pysim", pysim.__version__, case, status="ok",
                                       threads=get_threads(), **summary))
    return 0


def _interrupted(exc: BaseException) -> bool:
    """Whether ``exc`` is, or was caused by, a KeyboardInterrupt."""
    seen = set()
    while exc is not None and id(exc) not in seen:
        if isinstance(exc, KeyboardInterrupt):
            return True
        seen.add(id(exc))
        exc = exc.__cause__ or exc.__context__
    return False
