"""Compression to jamming in a periodic box (the LAMMPS/LIGGGHTS decks' protocol).

Stages: an optional fast compression ``phi_init -> phi_fast`` at true strain rate
``rate_fast``, then a slow one at ``rate`` to ``phi_final`` (or until the contact
pressure reaches ``pressure_final``). A stage from ``phi_a`` to ``phi_b`` lasts
``round(ln(phi_b/phi_a) / (3 rate dt))`` steps, the same count as the decks.
Thermo rows are written at multiples of ``thermo_every`` steps, dump frames at
multiples of ``dump_every``, as LAMMPS does. ``integrator: overdamped`` replaces velocity
Verlet by the overdamped Heun steps against the contracting substrate (science.md, 2-D
compression; ``kappa`` = ``rate``).

Long runs checkpoint every ``checkpoint_every`` seconds of wall time
(``checkpoint.npz`` next to the outputs, which grow as ``*.part`` files until the run
ends); ``resume=True`` continues from the last checkpoint and gives the same files and
final state, bit for bit, as an uninterrupted run.
"""
from __future__ import annotations

import math
import time

import numpy as np
from tqdm import tqdm

from pysim import io
from pysim.protocols.output import ResumeError, RunFiles  # noqa: F401 (ResumeError re-exported)
from pysim.simulation import ContactModel, Simulation
from pysim.state import State


def stage_plan(protocol: dict, dimension: int = 3) -> list[tuple[str, int, float]]:
    """``[(name, nsteps, strain_rate)]`` of the compression stages (rates negative); a
    stage from ``phi_a`` to ``phi_b`` lasts ``round(ln(phi_b/phi_a) / (d rate dt))``."""
    dt = protocol["dt"]
    stages = []
    phi = protocol["phi_init"]
    if "phi_fast" in protocol:
        n = round(math.log(protocol["phi_fast"] / phi) / (dimension * protocol["rate_fast"] * dt))
        stages.append(("fast", n, -protocol["rate_fast"]))
        phi = protocol["phi_fast"]
    n = round(math.log(protocol["phi_final"] / phi) / (dimension * protocol["rate"] * dt))
    stages.append(("slow", n, -protocol["rate"]))
    return stages


def model_from_case(case: dict) -> ContactModel:
    """The :class:`ContactModel` of a case's ``contact`` block. Without an explicit
    ``gamma_rot`` the rotational drag is that of a drag spread evenly along the spine,
    ``gamma_bg L^2 / 12`` (``L`` of the mean diameter)."""
    c = case["contact"]
    p = case["particles"]
    length = p.get("aspect_ratio", 0.0) * p["diameter"]["mean"]
    gamma_bg = c.get("gamma_bg", 0.0)
    return ContactModel(c["law"], k_n=c["k_n"], gamma_n=c.get("gamma_n", 0.0),
                        k_t=c.get("k_t", 0.0), gamma_t=c.get("gamma_t", 0.0),
                        mu=c.get("friction", 0.0), gamma_bg=gamma_bg,
                        gamma_rot=c.get("gamma_rot", gamma_bg * length**2 / 12.0),
                        spine_contact=c.get("spine_contact", "closest"),
                        limit_damping=c.get("limit_damping", False),
                        tangential_spring=c.get("tangential_spring", "reset"),
                        wall_cohesion=c.get("wall_cohesion", False))


def max_overlap(case: dict) -> float:
    """Blow-up limit of the case: overlap as a fraction of a diameter (``contact.max_overlap``,
    0.25 when absent)."""
    return float(case["contact"].get("max_overlap", 0.25))


def state_from_init(case: dict, init: dict) -> State:
    """A :class:`State` in a periodic box from an initial configuration read by
    :func:`pysim.io.read_particle_data` (positions taken relative to the box origin)."""
    dim = case["particles"].get("dimension", 3)
    box = init["box"].copy()
    x = init["x"] - init["box_lo"]
    axis = init["axis"].copy()
    if dim == 2:  # quaternions round to spines a hair out of the plane: project them back
        box[2] = 0.0
        x[:, 2] = 0.0
        axis[:, 2] = 0.0
        axis /= np.linalg.norm(axis, axis=1, keepdims=True)
    return State.create(x, init["radius"], init["length"], box, axis=axis,
                        density=case["particles"].get("density", 1.0),
                        periodic=(True, True, dim == 3), dimension=dim)


def simulation_from_case(case: dict, init: dict, check_dt: bool = True) -> Simulation:
    """Build the :class:`Simulation` a compression case describes (``check_dt``: refuse a
    time step too large for the contact time; off for overdamped and minimising drivers)."""
    state = state_from_init(case, init)
    return Simulation(state, model_from_case(case), dt=case["protocol"]["dt"],
                      skin=0.2 * 2.0 * float(np.max(state.radius)), check_dt=check_dt,
                      max_overlap=max_overlap(case))


def run(case: dict, init: dict, out_dir, progress: bool = True, resume: bool = False,
        checkpoint_every: float = 300.0) -> dict:
    """Run the compression protocol and write the common output files to ``out_dir``.

    ``init`` is the initial configuration (:func:`pysim.io.read_particle_data`). Returns
    a summary: steps, wall time, final thermo row, particle-steps per second. Raises
    :class:`pysim.simulation.BlowUpError` (keeping the last checkpoint and the partial
    files) when the integration becomes unstable.
    """
    files = RunFiles(out_dir, init["ids"])
    if resume:
        sim, _ = files.resume()
    else:
        sim = simulation_from_case(case, init)
        files.start()
    s = sim.state
    outp = case.get("output", {})
    thermo_every = int(outp.get("thermo_every", 1000))
    dump_every = int(outp.get("dump_every", 4000))
    p_final = case["protocol"].get("pressure_final", math.inf)
    stages = stage_plan(case["protocol"], s.dimension)
    ends = np.cumsum([n for _, n, _ in stages])
    overdamped = case["protocol"].get("integrator", "verlet") == "overdamped"
    k_d = case["protocol"].get("k_d", 1.0)

    t0 = time.perf_counter()
    last_ckpt = t0
    steps_at_start = s.step
    bar = tqdm(total=int(ends[-1]), initial=s.step, disable=not progress, unit="step",
               mininterval=1.0, desc="pysim compress", dynamic_ncols=True)
    with files.guard(bar):
        if not resume:
            files.dump(sim)
            files.checkpoint(sim)
        for (name, _, rate), end in zip(stages, ends):
            while s.step < end:
                nxt = min(int(end), (s.step // thermo_every + 1) * thermo_every,
                          (s.step // dump_every + 1) * dump_every)
                before = s.step
                if overdamped:
                    sim.run_overdamped(nxt - s.step, k_d=k_d, kappa=-rate)
                else:
                    sim.run(nxt - s.step, strain_rate=rate)
                bar.update(s.step - before)
                th = sim.thermo()
                if s.step % thermo_every == 0:
                    files.thermo(th.row())
                    bar.set_postfix(stage=name, phi=f"{th.phi:.4f}", p=f"{th.pressure:.3g}",
                                    ke=f"{th.ke:.3g}", refresh=False)
                if s.step % dump_every == 0:
                    files.dump(sim)
                if name == "slow" and th.pressure >= p_final:
                    break
                if time.perf_counter() - last_ckpt > checkpoint_every:
                    files.checkpoint(sim)
                    last_ckpt = time.perf_counter()
            else:
                continue
            break  # pressure_final reached
    wall = time.perf_counter() - t0
    files.finalize()
    th = sim.thermo()
    done = s.step - steps_at_start
    return {"steps": s.step, "wall_seconds": wall, "final": dict(zip(io.THERMO_COLUMNS, th.row())),
            "particle_steps_per_second": s.n * done / wall if wall > 0 else float("nan"),
            "neighbor_rebuilds": sim.rebuilds, "resumed": bool(resume)}
