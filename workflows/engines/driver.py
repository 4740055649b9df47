"""Running a peer engine (LAMMPS, LIGGGHTS) on a case: the adapter of the case
(:mod:`workflows.engines.table`) gives the deck, its ``-var`` values, the data file it
reads and the converter of its output; :func:`run` writes the data, starts the engine in
``outdir/work`` (resuming an interrupted run of the same case where the adapter can),
checks what it printed and leaves the common-format files in ``outdir``."""
from __future__ import annotations

import json
import os
import re
import shutil
import time
from pathlib import Path

from pysim import io
from workflows.engines.common import EngineError
from workflows.engines.convert import _count_atoms, _last_step
from workflows.engines.restarts import cut_outputs, restart_interval, resume_stamp, _run_pruning
from workflows.engines.table import ADAPTERS, deck_vars, lookup
from workflows.stopping import check_signalled

#: prefixes of the variables with which SLURM and its PMI describe the job step that runs
#: the runner. An engine that inherits them takes itself for a rank that srun started:
#: Debian's Open MPI (LIGGGHTS) then aborts in MPI_Init, built without SLURM's PMI, and
#: mpirun and MPICH's mpiexec start their ranks with a nested srun, which waits for the
#: CPUs that the step itself holds.
JOB_STEP_PREFIXES = ("SLURM", "PMI_", "PMIX_")


def engine_env() -> dict:
    """This process's environment less the batch system's job-step variables
    (:data:`JOB_STEP_PREFIXES`): an engine and its MPI ranks start on this node as on a
    workstation, inside the CPUs that the job holds (an engine job is one task on one node
    with a CPU per rank)."""
    return {k: v for k, v in os.environ.items() if not k.startswith(JOB_STEP_PREFIXES)}


def command(engine: str, data: Path, outdir: Path, case: dict, ranks: int = 1,
            extra_vars: dict | None = None) -> list[str]:
    """The command line that runs the case's deck."""
    adapter = lookup(engine, case)
    args = []
    for k, val in {**deck_vars(case, engine), **(extra_vars or {})}.items():
        args += ["-var", k, str(val)]
    args += ["-var", "data", str(data), "-var", "outdir", str(outdir)]
    if adapter.command is None:
        raise EngineError(f"{engine} has no deck: workflows.runner runs it itself")
    return adapter.command(adapter.deck_path(), outdir, ranks, args)


def engine_version(engine: str, screen: str) -> str:
    """Version line the engine printed first (``LAMMPS (22 Jul 2025 - Update 4)``)."""
    pattern = next((a.version for a in ADAPTERS.values() if a.engine == engine and a.version),
                   None)
    m = re.search(pattern, screen, re.M) if pattern else None
    return m.group(1) if m else "unknown"


def _error_line(text: str) -> str | None:
    for line in text.splitlines():
        if line.startswith("ERROR"):
            return line.strip()
    return None


#: what a peer's error line has meant in our decks, added to the failure message
ERROR_HINTS = {
    "Rigid body atoms": "glued rods blew up: the sphere contacts between two rods (up to "
                        "tens of them) act as parallel springs and dashpots, and the time "
                        "step was too large for them (tapping at spacing D/4 and dt 2e-5 s: "
                        "speeds grew a thousandfold in 15 steps); try a smaller protocol.dt",
}


def failure_message(engine: str, returncode: int, text: str, screen: Path) -> str:
    """One line for a failed peer run: exit code, the engine's first ``ERROR`` line (or
    its last line), a hint where :data:`ERROR_HINTS` knows the error, and the log."""
    err = _error_line(text)
    line = err or (text.strip().splitlines()[-1] if text.strip() else "no output")
    hints = [h for key, h in ERROR_HINTS.items() if key in line]
    return (f"{engine} failed (exit {returncode}): {line}"
            + "".join(f" ({h})" for h in hints) + f"; log: {screen}")


def run(engine: str, case: dict, data: Path, outdir: Path, ranks: int = 1,
        timeout: float = 3600.0) -> dict:
    """Run one engine on a case and leave the common-format files in ``outdir``.

    The engine works in ``outdir/work``; only complete, converted files are moved to
    ``outdir``. Returns a summary for the provenance record. An engine that cannot run
    the case raises :class:`EngineError` with the reason (:func:`~workflows.engines.
    table.supports`).
    """
    adapter = lookup(engine, case)
    outdir = Path(outdir)
    work = outdir / "work"
    extra = {}
    # resume only an interrupted run of this very case and start
    stamp = resume_stamp(engine, case, data)
    same = work.exists() and (work / "resume.json").exists() and \
        json.loads((work / "resume.json").read_text()) == stamp
    restart = adapter.latest_restart(work) if adapter.resumes and same else None
    if restart is not None:
        step = int(restart.name.split(".")[-1])
        cut_outputs(work, step)
        extra["restart_file"] = str(restart.resolve())
        extra["resume"] = 1
        if adapter.resume_vars is not None:
            extra.update(adapter.resume_vars(work, step))
    else:
        if work.exists():
            shutil.rmtree(work)
        work.mkdir(parents=True)
        io.atomic_write_text(work / "resume.json", json.dumps(stamp))
    if adapter.resumes:
        extra["restart_every"] = restart_interval(case)
    if adapter.one_rank:
        ranks = 1  # the PUBLIC LIGGGHTS runs multisphere bodies on one rank only
    engine_data = Path(data).resolve()
    writer = adapter.writer
    if writer is not None:  # the deck reads the particles converted (glued spheres, bodies)
        engine_data = (work / writer.file).resolve()
        if restart is None or not engine_data.exists():
            measure = writer.write(data, engine_data, case)
            (work / writer.measure_file).write_text(repr(float(measure)))
        two_d = case["particles"].get("dimension", 3) == 2
        extra["arods" if two_d else "vrods"] = (work / writer.measure_file).read_text().strip()
    cmd = command(engine, engine_data, work.resolve(), case, ranks, extra)
    screen_path = work / "screen.txt"
    env = dict(engine_env(), OMP_NUM_THREADS="1")
    t0 = time.perf_counter()
    with open(screen_path, "w") as screen:
        proc = _run_pruning(cmd, screen, work, env, timeout)
        if proc is None:
            raise EngineError(f"{engine} ran past its budget of {timeout:g} s; "
                              f"log: {screen_path}")
    wall = time.perf_counter() - t0
    check_signalled(engine, proc.returncode)
    text = screen_path.read_text(errors="replace")
    if proc.returncode != 0 or _error_line(text):
        raise EngineError(failure_message(engine, proc.returncode, text, screen_path))
    if "Lost atoms" in text:
        raise EngineError(f"{engine} lost atoms; log: {screen_path}")
    dangerous = sum(int(m) for m in re.findall(r"Dangerous builds\s*=\s*(\d+)", text))
    if dangerous:
        raise EngineError(f"{engine} reported {dangerous} dangerous neighbour-list builds (pairs "
                          "may have been missed): reduce dt or the compression rate, or raise "
                          f"the skin; log: {screen_path}")
    stats = adapter.convert(work, case, Path(data))
    for name in ("particles.dump", "contacts.dump", "thermo.dat"):
        os.replace(work / name, outdir / name)
    for old in work.glob("restart.*"):  # finished: nothing left to resume
        old.unlink()
    steps = _last_step(outdir / "thermo.dat")
    n = _count_atoms(outdir / "particles.dump")
    settled = {"settled": "rodpack: settled at step" in text} if adapter.reports_settled else {}
    version = re.search(adapter.version, text, re.M)
    return {**settled, "engine_version": version.group(1) if version else "unknown",
            "command": cmd, "ranks": ranks, "wall_seconds": wall, "steps": steps,
            "particle_steps_per_second": n * steps / wall if wall > 0 else float("nan"),
            "contacts_dropped": stats["dropped"], "status": "ok", **adapter.record,
            "resumed_from": extra.get("restart_file")}
