"""Run one case on one engine and record the outcome, success or failure, in run.json.

Every engine run of the pipeline goes through :func:`run`. A run that succeeds leaves the
common format (``docs/formats.md``) and a ``run.json`` with ``status: ok`` and its
provenance. A run that fails — the engine stops with an error, runs past its time
budget, loses atoms, or blows up (:func:`workflows.checks.check_run`) — leaves a
``run.json`` with ``status: failed``, the engine's own error line and the path of its
log, and *no* common-format files (they are moved to ``failed/``), so nothing
half-written can be read as a result. The pipeline carries on with the other runs and
the report lists the failed ones.

pysim runs resume from their last checkpoint when it belongs to the same case and initial
data (``resume.json``), so a killed pipeline re-run picks up where it stopped; the
checkpoint of another case (the configuration changed) is removed and the run starts over.

A run that is *stopped* rather than failed — the runner gets SIGINT (Ctrl-C), SIGTERM (a
``kill``, ``scancel``, a batch system's time limit) or SIGHUP, or the engine process dies of
one of them — is not a result: the runner stops the engine, writes no ``run.json`` and
raises :class:`Interrupted`, so Snakemake counts the job as not done and the next run
resumes it from its last checkpoint or restart file.
"""
from __future__ import annotations

import json
import os
import shutil
import subprocess
import time
from pathlib import Path

from rodcase import record
from workflows import checks, engines
from rodcase.case import load_case
from workflows.stopping import Interrupted, check_signalled, stop_process, stop_signals_raise

COMMON = ("particles.dump", "contacts.dump", "thermo.dat")
#: pysim's own record of a run that finished while the runner was being stopped
FINISHED = "pysim_finished.json"
#: keys of a provenance record that the runner writes itself
PROVENANCE_KEYS = ("engine", "engine_version", "case_hash", "seed", "git_revision", "host",
                   "python", "finished_at", "pid", "status")


class RunFailure(RuntimeError):
    """A run did not produce a valid result; the message is one line."""


def _pysim(case_path: Path, data: Path, out: Path, threads: int, timeout: float) -> dict:
    import pysim

    cmd = engines.pysim.command(case_path, data, out, threads)
    # resume only a checkpoint of this very case and start (a changed case starts over,
    # one changed only in when it stops goes on); keep only a finish of this very case
    stamp = engines.resume_stamp("pysim", load_case(case_path), data)
    stamp_path = out / "resume.json"
    stored = json.loads(stamp_path.read_text()) if stamp_path.exists() else None
    done = out / FINISHED
    if not (stored == stamp and done.exists() and all((out / n).exists() for n in COMMON)):
        done.unlink(missing_ok=True)
        same = stored is not None and engines.resumable(stored, stamp)
        _run_pysim(cmd, out, stamp, same, threads, timeout)
        os.replace(out / "run.json", done)  # the runner writes run.json, once checked
    # else pysim had finished when a stop signal reached the runner: its record stands
    rec = json.loads(done.read_text())
    keep = {k: v for k, v in rec.items() if k not in PROVENANCE_KEYS}
    keep["engine_version"] = pysim.__version__
    keep["command"] = cmd
    return keep


def _run_pysim(cmd: list, out: Path, stamp: dict, same: bool, threads: int,
               timeout: float) -> None:
    """Start (or resume) pysim, which writes its record to ``out/run.json``."""
    from rodcase.files import atomic_write_text

    if (out / "checkpoint.npz").exists() and same:
        cmd.append("--resume")
    else:
        for stale in [out / "checkpoint.npz", *out.glob("*.part")]:
            stale.unlink(missing_ok=True)
    # a resumed run takes the stamp of its new stop keys
    atomic_write_text(out / "resume.json", json.dumps(stamp))
    log = out / "pysim.log"
    env = dict(os.environ, NUMBA_NUM_THREADS=str(threads))
    with open(log, "w") as fh:
        proc = subprocess.Popen(cmd, stdout=fh, stderr=subprocess.STDOUT, env=env)
        try:
            proc.wait(timeout=timeout)
        except subprocess.TimeoutExpired:
            stop_process(proc)
            raise RunFailure(f"pysim ran past its budget of {timeout:g} s; log: {log}") from None
        except BaseException:
            stop_process(proc)
            raise
    check_signalled("pysim", proc.returncode)
    text = log.read_text(errors="replace")
    if proc.returncode != 0:
        errs = [ln for ln in text.splitlines() if ln.startswith("error:")]
        line = errs[-1][len("error:"):].strip() if errs else (text.strip().splitlines() or ["no output"])[-1]
        raise RunFailure(f"pysim failed (exit {proc.returncode}): {line}; log: {log}")


def run(engine: str, case_path, data, out, ranks: int = 1, threads: int = 1,
        timeout: float = 3600.0) -> dict:
    """Run ``engine`` on the case file ``case_path`` from ``data`` into ``out``; returns
    the record written to ``out/run.json`` (``status`` is ``ok`` or ``failed``).

    Raises :class:`Interrupted`, writing no record, when a stop signal ends the run."""
    out = Path(out)
    with stop_signals_raise():
        try:
            return _run(engine, Path(case_path), Path(data), out, ranks, threads, timeout)
        except Interrupted:
            # a stopped run has no record (a pysim run that had finished keeps its own
            # record aside, FINISHED, and the next run checks and records it instead)
            (out / "run.json").unlink(missing_ok=True)
            raise


def _run(engine: str, case_path: Path, data: Path, out: Path, ranks: int, threads: int,
         timeout: float) -> dict:
    out.mkdir(parents=True, exist_ok=True)
    case = load_case(case_path)
    t0 = time.perf_counter()
    version = "unknown"
    try:
        if engine == "pysim":
            summary = _pysim(case_path, data, out, threads, timeout)
        else:
            summary = engines.run(engine, case, data, out, ranks=ranks, timeout=timeout)
        version = summary.pop("engine_version", version)
        problem = checks.check_run(out, case)
        if problem:
            raise RunFailure(f"{engine} blew up: {problem}")
        rec = record.make(engine, version, case, **{**summary, "status": "ok"})
    except Exception as exc:  # noqa: BLE001 - every failure becomes a reported result
        if not isinstance(exc, (engines.EngineError, RunFailure)):
            import traceback

            traceback.print_exc()  # to the rule's log: this is a rodpack bug, not the engine's
            exc = RunFailure(f"internal error while checking the {engine} run: "
                             f"{type(exc).__name__}: {exc}")
        failed = out / "failed"
        failed.mkdir(exist_ok=True)
        for name in COMMON:
            if (out / name).exists():
                os.replace(out / name, failed / name)
        rec = record.make(engine, version, case, status="failed", error=str(exc),
                                wall_seconds=time.perf_counter() - t0)
    record.write(out / "run.json", rec)
    (out / FINISHED).unlink(missing_ok=True)
    return rec


def clear_failed(out) -> None:
    """Remove what a failed attempt left (before a retry)."""
    shutil.rmtree(Path(out) / "failed", ignore_errors=True)


def ok_runs(run_dirs) -> list[Path]:
    """The run directories among ``run_dirs`` whose ``run.json`` has ``status: ok``, in
    their order, as paths: what the figures draw (failed runs are listed in
    ``failures.csv`` instead; a run still going has no ``run.json`` yet)."""
    return [Path(d) for d in run_dirs if (Path(d) / "run.json").is_file()
            and json.loads((Path(d) / "run.json").read_text()).get("status") == "ok"]
