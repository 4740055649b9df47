"""Compression to jamming in a periodic box (the LAMMPS/LIGGGHTS decks' protocol).

Stages: an optional fast compression ``phi_init -> phi_fast`` at true strain rate
``rate_fast``, then a slow one at ``rate`` to ``phi_final`` (or until the contact
pressure reaches ``pressure_final``). A stage from ``phi_a`` to ``phi_b`` lasts
``round(ln(phi_b/phi_a) / (3 rate dt))`` steps, the same count as the decks.
Thermo rows are written at multiples of ``thermo_every`` steps, dump frames at
multiples of ``dump_every``, as LAMMPS does.
"""
from __future__ import annotations

import math
import time
from pathlib import Path

import numpy as np
from tqdm import tqdm

from pysim import io
from pysim.simulation import ContactModel, Simulation
from pysim.state import State


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


def run(case: dict, x, diameters, box, out_dir, ids=None, progress: bool = True) -> dict:
    """Run the compression protocol and write the common output files to ``out_dir``.

    Returns a summary: steps, wall time, final thermo row, particle-steps per second.
    """
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    sim = simulation_from_case(case, x, diameters, box)
    s = sim.state
    ids = np.arange(1, s.n + 1) if ids is None else np.asarray(ids)
    types = np.ones(s.n, dtype=np.int64)
    outp = case.get("output", {})
    thermo_every = int(outp.get("thermo_every", 1000))
    dump_every = int(outp.get("dump_every", 4000))
    p_final = case["protocol"].get("pressure_final", math.inf)
    stages = stage_plan(case["protocol"])
    total = sum(n for _, n, _ in stages)

    paths = {k: out / f"{k}" for k in ("particles.dump", "contacts.dump", "thermo.dat")}
    fh = {k: open(io.part_path(p), "w") for k, p in paths.items()}
    fh["thermo.dat"].write(io.thermo_header())

    def dump():
        io.write_particles_frame(fh["particles.dump"], s.step, s.box, s.periodic, ids, types,
                                 s.x, s.radius)
        ij, rec = sim.contact_table()
        io.write_contacts_frame(fh["contacts.dump"], s.step, s.box, s.periodic, ids[ij], rec)

    t0 = time.perf_counter()
    bar = tqdm(total=total, disable=not progress, unit="step", mininterval=1.0,
               desc="pysim compress", dynamic_ncols=True)
    try:
        dump()
        stopped = False
        for name, nsteps, rate in stages:
            end = s.step + nsteps
            while s.step < end:
                nxt = min(end, (s.step // thermo_every + 1) * thermo_every,
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
                    stopped = True
                    break
            if stopped:
                break
    finally:
        bar.close()
        for f in fh.values():
            f.close()
    wall = time.perf_counter() - t0
    for p in paths.values():
        io.finalize(p)
    th = sim.thermo()
    return {"steps": s.step, "wall_seconds": wall, "final": dict(zip(io.THERMO_COLUMNS, th.row())),
            "particle_steps_per_second": s.n * s.step / wall if wall > 0 else float("nan"),
            "neighbor_rebuilds": sim.rebuilds}
