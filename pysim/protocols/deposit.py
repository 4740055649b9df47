"""Deposition under gravity into a box (science.md section 4, the cohesive-deposit study).

Grains start as a dilute random column in the box ``0 < x (, y) < W`` above the base
(height 0 along the last axis: ``z`` in 3-D, ``y`` in 2-D) with random orientations and
random velocities (``protocol.v_init``), written by :func:`pysim.initial.write_initial`.
Under gravity the column falls as a whole, so grains reach the growing heap one after the
other at a rate set by the column's density ``phi_init`` (a rain, not an inlet: pysim
keeps a fixed set of particles). With ``protocol.rain_speed`` the rain is slowed for
``rain_time``: a background drag caps every grain's fall speed at ``rain_speed``
(:func:`rain_drag`), so grains land gently, at a low rate ``phi_init rain_speed`` per area,
as from a slow feed; then the drag is off. Side walls and base are flat, frictional walls with the
grains' contact law (``contact.wall_friction``, default ``friction``). Cohesion: a
constant attraction ``F_c = Bo_g m g`` (mean grain) between grains whose gap is below
``d_c = cohesion_range D`` (:func:`cohesion`).

The run ends at the first ``thermo.dat`` row (every ``output.thermo_every`` steps, after
``min_time``) where the kinetic energy is below ``ke_ratio`` times its running peak, or
at ``max_time``; ``run.json`` says which (``settled``). Frames every ``output.dump_every``
steps and at the last step. Positions in the files are absolute; checkpoints and resume
as in :mod:`pysim.protocols.tapping` (the peak kinetic energy is kept in the checkpoint).
"""
from __future__ import annotations

import math
import time
from dataclasses import replace

import numpy as np
from tqdm import tqdm

from pysim import walls
from pysim.protocols.compress import max_overlap, model_from_case
from pysim.protocols.output import RunFiles
from pysim.simulation import BlowUpError, Simulation
from pysim.state import State


def grain_mass(case: dict) -> float:
    """Mass of the mean grain: ``rho (pi D^2 L / 4 + pi D^3 / 6)`` in 3-D, ``rho (D L +
    pi D^2 / 4)`` per unit thickness in 2-D."""
    p = case["particles"]
    d = p["diameter"]["mean"]
    length = p.get("aspect_ratio", 0.0) * d
    if p.get("dimension", 3) == 2:
        measure = d * length + math.pi * d * d / 4
    else:
        measure = math.pi * d * d * length / 4 + math.pi * d**3 / 6
    return p.get("density", 1.0) * measure


def cohesion(case: dict) -> tuple[float, float]:
    """``(F_c, d_c)``: the constant cohesive force ``F_c = Bo_g m g`` of the mean grain
    (force) and its range ``d_c = cohesion_range D`` (length); ``(0, 0)`` without a Bond
    number."""
    c = case["contact"]
    bo = c.get("bond_number", 0.0)
    if not bo > 0:
        return 0.0, 0.0
    d_c = c.get("cohesion_range", 1e-4) * case["particles"]["diameter"]["mean"]
    return bo * grain_mass(case) * case["gravity"], d_c


def rain_drag(case: dict) -> tuple[float, float]:
    """``(gamma_bg, gamma_rot)`` while it rains: ``m g / rain_speed`` for the mean grain
    (:func:`grain_mass`: terminal fall speed ``rain_speed``) and ``gamma_bg L^2 / 12`` for
    its rotation; ``(0, 0)`` without ``protocol.rain_speed`` (free fall)."""
    v_s = case["protocol"].get("rain_speed")
    if v_s is None:
        return 0.0, 0.0
    gamma = grain_mass(case) * case["gravity"] / v_s
    length = case["particles"].get("aspect_ratio", 0.0) * case["particles"]["diameter"]["mean"]
    return gamma, gamma * length**2 / 12.0


def rain_steps(protocol: dict) -> int:
    """The step at which the rain drag is switched off: ``rain_time / dt`` rounded (0
    without a rain)."""
    return int(round(protocol.get("rain_time", 0.0) / protocol["dt"]))


def simulation_from_case(case: dict, init: dict) -> Simulation:
    """The :class:`Simulation` of a deposition case: non-periodic box from the initial
    data file, gravity along the last axis, base and side walls (relative to the lower
    box corner), cohesion from the Bond number."""
    dim = case["particles"].get("dimension", 3)
    lo = init["box_lo"].copy()
    box = init["box"].copy()
    x = init["x"] - lo
    axis = init["axis"].copy()
    v = init["v"].copy()
    if dim == 2:
        lo[2] = 0.0
        box[2] = 0.0
        x[:, 2] = 0.0
        axis[:, 2] = 0.0
        axis /= np.linalg.norm(axis, axis=1, keepdims=True)
        v[:, 2] = 0.0
    state = State.create(x, init["radius"], init["length"], box, axis=axis, v=v,
                         density=case["particles"].get("density", 1.0),
                         periodic=(False, False, False), dimension=dim)
    c = case["contact"]
    f_c, d_c = cohesion(case)
    model = replace(model_from_case(case), f_coh=f_c, d_coh=d_c)
    if "wall_friction" in c:
        model = replace(model, mu_wall=c["wall_friction"])
    up = dim - 1
    w = case["container"]["width"]
    planes = []
    for k in range(dim):
        n = np.zeros(3)
        n[k] = 1.0
        planes.append(walls.plane(n, -lo * n))  # base (k = up) or the wall at 0
        if k != up:
            far = np.zeros(3)
            far[k] = w - lo[k]
            planes.append(walls.plane(-n, far))
    g = np.zeros(3)
    g[up] = -case["gravity"]
    return Simulation(state, model, dt=case["protocol"]["dt"], gravity=g, planes=planes,
                      skin=0.2 * 2.0 * float(np.max(state.radius)),
                      max_overlap=max_overlap(case))


def run(case: dict, init: dict, out_dir, progress: bool = True, resume: bool = False,
        checkpoint_every: float = 300.0) -> dict:
    """Run the deposition and write the common output files to ``out_dir``.

    Returns a summary: steps, wall time, whether the deposit settled, the peak and final
    kinetic energy. Raises :class:`pysim.simulation.BlowUpError` (keeping the last
    checkpoint and the partial files) when the integration becomes unstable.
    """
    pr = case["protocol"]
    out = case.get("output", {})
    thermo_every = int(out.get("thermo_every", 1000))
    dump_every = int(out.get("dump_every", 4000))
    dt = pr["dt"]
    max_steps = int(math.ceil(pr["max_time"] / dt))
    min_steps = int(math.ceil(pr.get("min_time", 0.0) / dt))
    ratio = pr.get("ke_ratio", 1e-6)
    rain_end = rain_steps(pr)
    drag = rain_drag(case)
    files = RunFiles(out_dir, init["ids"], origin=init["box_lo"])
    if resume:
        sim, drv = files.resume()
    else:
        sim = simulation_from_case(case, init)
        files.start()
        drv = {"peak": 0.0}
    s = sim.state
    free = (sim.model.gamma_bg, sim.model.gamma_rot)  # the case's own drag, after the rain
    sim.set_drag(*(drag if s.step < rain_end else free))
    t0 = time.perf_counter()
    last_ckpt = t0
    steps_at_start = s.step
    settled = False
    bar = tqdm(total=max_steps, initial=s.step, disable=not progress, unit="step",
               mininterval=1.0, desc="pysim deposit", dynamic_ncols=True)
    try:
        if not resume:
            th = sim.thermo()
            drv["peak"] = th.ke
            files.thermo((th.step, th.time, math.nan, math.nan, th.ke, th.pe, th.n_contacts))
            files.dump(sim)
            files.checkpoint(sim, drv)
        while s.step < max_steps:
            nxt = min(max_steps, (s.step // thermo_every + 1) * thermo_every,
                      (s.step // dump_every + 1) * dump_every)
            if s.step < rain_end:
                nxt = min(nxt, rain_end)
            before = s.step
            sim.run(nxt - s.step)
            if s.step == rain_end:
                sim.set_drag(*free)
            bar.update(s.step - before)
            if s.step % thermo_every == 0 or s.step == max_steps:
                th = sim.thermo()
                drv["peak"] = max(drv["peak"], th.ke)
                files.thermo((th.step, th.time, math.nan, math.nan, th.ke, th.pe, th.n_contacts))
                bar.set_postfix(ke=f"{th.ke:.3g}", peak=f"{drv['peak']:.3g}", refresh=False)
                settled = s.step >= max(min_steps, rain_end) and th.ke < ratio * drv["peak"]
            if s.step % dump_every == 0 or settled or s.step == max_steps:
                files.dump(sim)
            if settled:
                break
            if time.perf_counter() - last_ckpt > checkpoint_every:
                files.checkpoint(sim, drv)
                last_ckpt = time.perf_counter()
    except BlowUpError as exc:
        raise BlowUpError(f"{exc}; the last good checkpoint is {files.ckpt}") from None
    finally:
        bar.close()
        files.close()
    wall = time.perf_counter() - t0
    files.finalize()
    th = sim.thermo()
    done = s.step - steps_at_start
    return {"steps": s.step, "wall_seconds": wall, "settled": bool(settled),
            "ke_peak": drv["peak"], "ke_ratio": th.ke / drv["peak"] if drv["peak"] > 0 else 0.0,
            "final": {"step": th.step, "time": th.time, "ke": th.ke, "n_contacts": th.n_contacts},
            "particle_steps_per_second": s.n * done / wall if wall > 0 else float("nan"),
            "neighbor_rebuilds": sim.rebuilds, "resumed": bool(resume)}
