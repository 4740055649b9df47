"""Stopping and resuming a peer run: what identifies it (``resume.json``), its restart
files (written every :data:`RESTART_DUMPS` dump intervals, pruned while it runs, the newest
complete one found by the engine reading it back) and its outputs cut back to the restart
step."""
from __future__ import annotations

import hashlib
import re
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

from pysim import io
from workflows.stopping import stop_process

#: LAMMPS writes a restart file every this many dump intervals
RESTART_DUMPS = 10
#: restart files kept while an engine runs (the newest may be half written, so two
#: complete ones stay); older ones are deleted every PRUNE_SECONDS: a long deposit wrote
#: 140 files, 60 MB, for 150 rods
KEEP_RESTARTS = 3
PRUNE_SECONDS = 10.0


#: keys of a pysim protocol that only say when a run stops, not how it moves: a run whose
#: case changed in them alone resumes from its checkpoint (a later max_time or phi_final
#: goes on along the same trajectory; a looser ke_ratio stops at the first settling check
#: after the checkpoint that meets it, which may be later than where a run started afresh
#: would stop). A finished run whose stop keys changed runs again.
STOP_KEYS = {"deposit": ("max_time", "ke_ratio"),
             # compress: phi_final sets only the end of the last stage, not its rate
             "compress": ("phi_final", "pressure_final")}


def resume_stamp(engine: str, case: dict, data) -> dict:
    """What identifies a run for resuming (``resume.json``): engine, case hash (for pysim
    without the protocol's :data:`STOP_KEYS`), the initial data's hash and, where the
    protocol has stop keys, their values (``stops``)."""
    from rodcase.case import case_hash

    stops = STOP_KEYS.get(case["protocol"]["name"], ()) if engine == "pysim" else ()
    values = {k: case["protocol"].get(k) for k in stops}
    if stops:
        case = {**case, "protocol": {k: v for k, v in case["protocol"].items()
                                     if k not in stops}}
    stamp = {"engine": engine, "case_hash": case_hash(case),
             "data": hashlib.sha256(Path(data).read_bytes()).hexdigest()}
    if stops:
        stamp["stops"] = values
    return stamp


def resumable(stored: dict, stamp: dict) -> bool:
    """Whether a run stamped ``stored`` may go on under ``stamp``: the same run but for
    its stop keys (:data:`STOP_KEYS`)."""
    def bare(s: dict) -> dict:
        return {k: v for k, v in s.items() if k != "stops"}
    return bare(stored) == bare(stamp)


def restart_interval(case: dict) -> int:
    """Steps between LAMMPS restart files: every :data:`RESTART_DUMPS` dump intervals
    (tapping: frame intervals; deposition: thermo rows)."""
    if case["protocol"]["name"] == "tapping":
        from pysim.protocols.tapping import plan

        tp = plan(case["protocol"], case["gravity"])
        return RESTART_DUMPS * max(int(np.diff(tp.frame_steps).max()), 1)
    if case["protocol"]["name"] == "deposit":  # few frames: every 10 settling checks
        return RESTART_DUMPS * case.get("output", {}).get("thermo_every", 1000)
    return RESTART_DUMPS * case.get("output", {}).get("dump_every", 4000)


def prune_restarts(work: Path, keep: int = KEEP_RESTARTS) -> list[Path]:
    """Delete all but the ``keep`` newest ``restart.<step>`` files in ``work`` (by step);
    returns the deleted paths."""
    if keep < 1:
        raise ValueError(f"keep must be at least 1 (the newest restart file), got {keep}")
    files = sorted((p for p in work.glob("restart.*") if p.name.split(".")[-1].isdigit()),
                   key=lambda p: int(p.name.split(".")[-1]))
    old = files[:-keep]
    for path in old:
        path.unlink(missing_ok=True)
    return old


def _run_pruning(cmd, screen, work: Path, env: dict, timeout: float):
    """Run ``cmd`` in ``work`` with output to ``screen`` and prune its restart files
    (:func:`prune_restarts`) every :data:`PRUNE_SECONDS` while it runs. Returns the
    finished process, or None when it ran past ``timeout`` seconds (it is stopped, as it is
    on any exception here, by :func:`workflows.stopping.stop_process`)."""
    proc = subprocess.Popen(cmd, stdout=screen, stderr=subprocess.STDOUT, cwd=work, env=env)
    deadline = time.perf_counter() + timeout
    try:
        while True:
            left = deadline - time.perf_counter()
            try:
                proc.wait(timeout=max(min(PRUNE_SECONDS, left), 0.0))
                break
            except subprocess.TimeoutExpired:
                prune_restarts(work)
                if time.perf_counter() >= deadline:
                    stop_process(proc)
                    return None
    except BaseException:
        stop_process(proc)
        raise
    prune_restarts(work)
    return proc


def latest_restart(work: Path) -> Path | None:
    """The newest complete restart file of an interrupted LAMMPS run in ``work``.

    LAMMPS writes ``restart.<step>`` in place, so a run killed while writing leaves the
    newest file short. File sizes say nothing (a restart holds the contact history, which
    shrinks when a tapped packing is in flight), so each candidate, newest first, is read
    back by LAMMPS itself (:func:`restart_is_complete`) and the first that reads is taken.
    """
    return _newest_complete(work, restart_is_complete)


def _newest_complete(work: Path, is_complete) -> Path | None:
    """The newest ``restart.<step>`` in ``work`` that is not empty and that
    ``is_complete(path)`` accepts, newest first, or None."""
    if not work.exists():
        return None
    files = sorted((p for p in work.glob("restart.*") if p.name.split(".")[-1].isdigit()),
                   key=lambda p: int(p.name.split(".")[-1]))
    for path in reversed(files):
        if path.stat().st_size > 0 and is_complete(path):
            return path
    return None


def restart_is_complete(path: Path) -> bool:
    """Whether LAMMPS reads the restart file ``path`` to its end (in a child process: a
    corrupt file may abort the reader)."""
    code = ("import sys, lammps; l = lammps.lammps(cmdargs=['-log', 'none', '-screen', 'none']);"
            "l.command('read_restart ' + sys.argv[1])")
    r = subprocess.run([sys.executable, "-c", code, str(path)], capture_output=True, text=True,
                       timeout=300)
    return r.returncode == 0


def cut_outputs(work: Path, step: int):
    """Cut a run's outputs back to before ``step`` (frames and rows at or after it are
    written again by the resumed run)."""
    for name in ("particles.dump", "contacts.native", "box.dat"):
        path = work / name
        if not path.exists():
            continue
        lines = path.read_text().splitlines(keepends=True)
        if name == "box.dat":
            keep = [ln for ln in lines if ln.startswith("#") or int(float(ln.split()[0])) < step]
        else:
            keep = []
            k = 0
            while k < len(lines):
                if lines[k].startswith("ITEM: TIMESTEP") and int(lines[k + 1]) >= step:
                    break
                keep.append(lines[k])
                k += 1
        io.atomic_write_text(path, "".join(keep))
    thermo = work / "thermo.dat"
    if thermo.exists():
        rows = thermo.read_text().splitlines(keepends=True)
        keep = [r for r in rows if r.startswith("#") or not r.strip()
                or int(float(r.split()[0])) < step]
        io.atomic_write_text(thermo, "".join(keep))


def _ke_peak(screen: Path, step: int) -> float:
    """Running peak of the kinetic energy printed by the deposition deck at its last
    check at or before ``step`` (``rodpack: step S ke K peak P``); 0 when none."""
    peak = 0.0
    if screen.exists():
        for m in re.finditer(r"rodpack: step (\d+) ke \S+ peak (\S+)", screen.read_text()):
            if int(m.group(1)) <= step:
                peak = float(m.group(2))
    return peak
