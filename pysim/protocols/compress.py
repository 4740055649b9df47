"""Compression to jamming in a periodic box (the LAMMPS/LIGGGHTS decks' protocol).

Stages: an optional fast compression ``phi_init -> phi_fast`` at true strain rate
``rate_fast``, then a slow one at ``rate`` to ``phi_final`` (or until the contact
pressure reaches ``pressure_final``). A stage from ``phi_a`` to ``phi_b`` lasts
``round(ln(phi_b/phi_a) / (3 rate dt))`` steps, the same count as the decks.
Thermo rows are written at multiples of ``thermo_every`` steps, dump frames at
multiples of ``dump_every``, as LAMMPS does.

Long runs checkpoint every ``checkpoint_every`` seconds of wall time
(``checkpoint.npz`` next to the outputs, which grow as ``*.part`` files until the run
ends); ``resume=True`` continues from the last checkpoint and gives the same files and
final state, bit for bit, as an uninterrupted run.
"""
from __future__ import annotations

import math
import os
import time
from pathlib import Path

import numpy as np
from tqdm import tqdm

from pysim import checkpoint, io
from pysim.simulation import BlowUpError, ContactModel, Simulation
from pysim.state import State

OUTPUTS = ("particles.dump", "contacts.dump", "thermo.dat")
CHECKPOINT = "checkpoint.npz"


def stage_plan(protocol: dict) -> list[tuple[str, int, float]]:
    """``[(name, nsteps, strain_rate)]`` of the compression stages (rates negative)."""
    dt = protocol["dt"]
    stages = []
    phi = protocol["phi_init"]
    if "phi_fast" in protocol:
        n = round(math.log(protocol["phi_fast"] / phi) / (3.0 * protocol["rate_fast"] * dt))
        stages.append(("fast", n, -protocol["rate_fast"]))
        phi = protocol["phi_fast"]
    n = round(math.log(protocol["phi_final"] / phi) / (3.0 * protocol["rate"] * dt))
    stages.append(("slow", n, -protocol["rate"]))
    return stages


def simulation_from_case(case: dict, x, diameters, box) -> Simulation:
    """Build the :class:`Simulation` a compression case describes."""
    c = case["contact"]
    state = State.spheres(x, np.asarray(diameters) / 2.0, box,
                          density=case["particles"]["density"])
    model = ContactModel(c["law"], k_n=c["k_n"], gamma_n=c.get("gamma_n", 0.0),
                         k_t=c.get("k_t", 0.0), gamma_t=c.get("gamma_t", 0.0),
                         mu=c.get("friction", 0.0), gamma_bg=c.get("gamma_bg", 0.0))
    return Simulation(state, model, dt=case["protocol"]["dt"],
                      skin=0.2 * float(np.max(diameters)))


class ResumeError(RuntimeError):
    """A run cannot be resumed (no checkpoint, or its files do not match it)."""


def run(case: dict, x, diameters, box, out_dir, ids=None, progress: bool = True,
        resume: bool = False, checkpoint_every: float = 300.0) -> dict:
    """Run the compression protocol and write the common output files to ``out_dir``.

    Returns a summary: steps, wall time, final thermo row, particle-steps per second.
    Raises :class:`pysim.simulation.BlowUpError` (keeping the last checkpoint and the
    partial files) when the integration becomes unstable.
    """
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    ckpt = out / CHECKPOINT
    paths = {k: out / k for k in OUTPUTS}
    if resume:
        if not ckpt.exists():
            raise ResumeError(f"{ckpt}: no checkpoint to resume from; run without --resume")
        sim, extra = checkpoint.load(ckpt)
        for name, size in extra["files"].items():
            part = io.part_path(paths[name])
            if not part.exists() or part.stat().st_size < size:
                raise ResumeError(f"{part}: missing or shorter ({part.stat().st_size if part.exists() else 0} "
                                  f"bytes) than the checkpoint records ({size}); rerun from the start")
            with open(part, "r+b") as fh:
                fh.truncate(size)
        fh = {k: open(io.part_path(p), "a") for k, p in paths.items()}
    else:
        sim = simulation_from_case(case, x, diameters, box)
        fh = {k: open(io.part_path(p), "w") for k, p in paths.items()}
        fh["thermo.dat"].write(io.thermo_header())
        if ckpt.exists():
            ckpt.unlink()
    s = sim.state
    ids = np.arange(1, s.n + 1) if ids is None else np.asarray(ids)
    types = np.ones(s.n, dtype=np.int64)
    outp = case.get("output", {})
    thermo_every = int(outp.get("thermo_every", 1000))
    dump_every = int(outp.get("dump_every", 4000))
    p_final = case["protocol"].get("pressure_final", math.inf)
    stages = stage_plan(case["protocol"])
    ends = np.cumsum([n for _, n, _ in stages])
    total = int(ends[-1])

    def dump():
        io.write_particles_frame(fh["particles.dump"], s.step, s.box, s.periodic, ids, types,
                                 s.x, s.radius)
        ij, rec = sim.contact_table()
        io.write_contacts_frame(fh["contacts.dump"], s.step, s.box, s.periodic, ids[ij], rec)

    def save_checkpoint():
        sizes = {}
        for k, f in fh.items():
            f.flush()
            os.fsync(f.fileno())
            sizes[k] = f.tell()
        checkpoint.save(sim, ckpt, extra={"files": sizes})

    t0 = time.perf_counter()
    last_ckpt = t0
    steps_at_start = s.step
    bar = tqdm(total=total, initial=s.step, disable=not progress, unit="step", mininterval=1.0,
               desc="pysim compress", dynamic_ncols=True)
    try:
        if not resume:
            dump()
            save_checkpoint()
        for (name, _, rate), end in zip(stages, ends):
            while s.step < end:
                nxt = min(int(end), (s.step // thermo_every + 1) * thermo_every,
                          (s.step // dump_every + 1) * dump_every)
                before = s.step
                sim.run(nxt - s.step, strain_rate=rate)
                bar.update(s.step - before)
                th = sim.thermo()
                if s.step % thermo_every == 0:
                    io.write_thermo_row(fh["thermo.dat"], th.row())
                    bar.set_postfix(stage=name, phi=f"{th.phi:.4f}", p=f"{th.pressure:.3g}",
                                    ke=f"{th.ke:.3g}", refresh=False)
                if s.step % dump_every == 0:
                    dump()
                if name == "slow" and th.pressure >= p_final:
                    break
                if time.perf_counter() - last_ckpt > checkpoint_every:
                    save_checkpoint()
                    last_ckpt = time.perf_counter()
            else:
                continue
            break  # pressure_final reached
    except BlowUpError as exc:
        bar.close()
        for f in fh.values():
            f.close()
        raise BlowUpError(f"{exc}; the last good checkpoint is {ckpt}") from None
    finally:
        bar.close()
        for f in fh.values():
            if not f.closed:
                f.close()
    wall = time.perf_counter() - t0
    for p in paths.values():
        io.finalize(p)
    ckpt.unlink(missing_ok=True)
    th = sim.thermo()
    done = s.step - steps_at_start
    return {"steps": s.step, "wall_seconds": wall, "final": dict(zip(io.THERMO_COLUMNS, th.row())),
            "particle_steps_per_second": s.n * done / wall if wall > 0 else float("nan"),
            "neighbor_rebuilds": sim.rebuilds, "resumed": bool(resume)}
