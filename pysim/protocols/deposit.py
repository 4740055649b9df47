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
``d_c = cohesion_range D`` (:func:`cohesion`), and between grains and walls with
``contact.wall_cohesion``.

**Feed** (``protocol.feed``, 2-D; the cohesive-deposit paper's protocol): instead of a
column, grains enter one at a time at ``rate`` grains per unit time, grain ``k`` (in the
order of the initial data file, :func:`pysim.initial.feed_queue`) at step
``round(k / (rate dt))``, the first at step 0. Each enters with its centre on the line
``y = feed.height`` above the base, at a uniformly random ``x`` that keeps it inside the
side walls, a uniformly random orientation and a velocity of magnitude ``feed.speed`` in
a uniformly random direction, no spin (:func:`entry`); a spot where it would touch a
grain (gap not above the cohesion range) is drawn again, up to :data:`ENTRY_TRIES`
times, else :class:`FeedBlockedError`. The draws of grain ``k`` come from its own stream
(``default_rng([seed, k])``), so a resumed run draws the same. Grains not yet fed are not
part of the simulation (:meth:`pysim.simulation.Simulation.add_particles`); frames hold
the grains fed so far.

The run ends at the first ``thermo.dat`` row (every ``output.thermo_every`` steps, after
``min_time``, the rain and the feed) where the kinetic energy is below ``ke_ratio`` times
its running peak, or at ``max_time``; ``run.json`` says which (``settled``). A fed run
that reaches ``max_time`` unsettled (or not fully fed) stops with :class:`NotSettledError`
and keeps its checkpoint at that step, so that the same command with a larger
``max_time`` and ``--resume`` goes on as if it had been given from the start. Frames
every ``output.dump_every`` steps and at the last step. Positions in the files are
absolute; checkpoints and resume as in :mod:`pysim.protocols.tapping` (the peak kinetic
energy is kept in the checkpoint).
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
from pysim.simulation import Simulation
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


#: draws of an entry spot before a grain counts as blocked
ENTRY_TRIES = 1000


class FeedBlockedError(RuntimeError):
    """A fed grain found no free spot on the entry line."""


class NotSettledError(RuntimeError):
    """A fed deposit reached ``max_time`` before it was fed and settled."""


def entry_step(k: int, protocol: dict) -> int:
    """The step at which fed grain ``k`` (0-based) enters: ``round(k / (rate dt))``."""
    return int(round(k / (protocol["feed"]["rate"] * protocol["dt"])))


def entry_draws(case: dict, k: int, radius: float, length: float, lo):
    """The entry draws of fed grain ``k`` (radius, spine length), in the order
    :func:`entry` tries them: an endless generator of ``(x (3,), axis (3,), v (3,))`` in
    the simulation's coordinates (the container's shifted by ``-lo``), from the grain's
    own stream ``default_rng([seed, k])``. The centre sits at ``feed.height`` above the
    base, ``x`` uniform over the positions that keep the grain inside the side walls, the
    spine angle uniform in ``[0, pi)``, the velocity of magnitude ``feed.speed`` at an
    angle uniform in ``[0, 2 pi)``."""
    feed = case["protocol"]["feed"]
    w = case["container"]["width"]
    h = 0.5 * length
    rng = np.random.default_rng([int(case["seed"]), k])
    while True:
        theta = rng.uniform(0.0, math.pi)
        u = np.array([math.cos(theta), math.sin(theta), 0.0])
        side = radius + h * abs(u[0])  # centre to the far edge along x
        x = np.array([rng.uniform(side, w - side), feed["height"], 0.0]) - lo
        x[2] = 0.0
        ang = rng.uniform(0.0, 2.0 * math.pi)
        v = feed.get("speed", 0.0) * np.array([math.cos(ang), math.sin(ang), 0.0])
        yield x, u, v


def entry(case: dict, k: int, radius: float, length: float, lo, others) -> tuple:
    """Entry of fed grain ``k`` (radius, spine length): ``(x (3,), axis (3,), v (3,))``,
    the first of :func:`entry_draws` that is free. ``others`` = ``(x, u, radius, half)``
    of the grains already in: a draw whose spine comes within ``R_i + R_k + d_c`` of
    another spine is drawn again, up to :data:`ENTRY_TRIES` times."""
    from pysim.geometry import segment_closest_many

    d_c = cohesion_range(case)
    h = 0.5 * length
    ox, ou, orad, ohalf = others
    for _, (x, u, v) in zip(range(ENTRY_TRIES), entry_draws(case, k, radius, length, lo)):
        reach = orad + radius + d_c
        near = np.flatnonzero(np.linalg.norm(ox - x, axis=1) < ohalf + h + reach)
        if len(near):
            m = len(near)
            s, t = segment_closest_many(np.tile(x, (m, 1)), np.tile(u, (m, 1)), np.full(m, h),
                                        ox[near], ou[near], ohalf[near])
            gap = (x + s[:, None] * u) - (ox[near] + t[:, None] * ou[near])
            if np.any(np.linalg.norm(gap, axis=1) <= reach[near]):
                continue
        return x, u, v
    raise FeedBlockedError(
        f"fed grain {k} found no free spot on the entry line y = "
        f"{case['protocol']['feed']['height']:g} in {ENTRY_TRIES} draws (the deposit has "
        "reached it, or grains enter faster than they clear it); raise protocol.feed.height "
        "or lower protocol.feed.rate")


def cohesion_range(case: dict) -> float:
    """``d_c`` of the case (0 without cohesion): the gap within which grains attract."""
    return cohesion(case)[1]


def simulation_from_case(case: dict, init: dict) -> Simulation:
    """The :class:`Simulation` of a deposition case: non-periodic box from the initial
    data file, gravity along the last axis, base and side walls (relative to the lower
    box corner), cohesion from the Bond number. A fed case starts with its first grain
    alone, at its entry (:func:`entry`)."""
    dim = case["particles"].get("dimension", 3)
    lo = init["box_lo"].copy()
    box = init["box"].copy()
    x = init["x"] - lo
    axis = init["axis"].copy()
    v = init["v"].copy()
    radius, length = init["radius"], init["length"]
    if "feed" in case["protocol"]:
        none = (np.zeros((0, 3)), np.zeros((0, 3)), np.zeros(0), np.zeros(0))
        x, axis, v = (a[None, :] for a in entry(case, 0, radius[0], length[0], lo, none))
        radius, length = radius[:1], length[:1]
    if dim == 2:
        lo[2] = 0.0
        box[2] = 0.0
        x[:, 2] = 0.0
        axis[:, 2] = 0.0
        axis /= np.linalg.norm(axis, axis=1, keepdims=True)
        v[:, 2] = 0.0
    state = State.create(x, radius, length, box, axis=axis, v=v,
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
    n_all = len(init["ids"])
    fed = "feed" in pr
    if fed:  # end on a thermo row: a resume with a larger max_time then writes the same
        max_steps = -(-max_steps // thermo_every) * thermo_every
    feed_end = entry_step(n_all - 1, pr) if fed else 0
    files = RunFiles(out_dir, init["ids"], origin=init["box_lo"])
    if resume:
        sim, drv = files.resume()
    else:
        sim = simulation_from_case(case, init)
        files.start()
        drv = {"peak": 0.0}
    s = sim.state
    lo = init["box_lo"]

    def next_entry():
        return entry_step(s.n, pr) if fed and s.n < n_all else None
    free = (sim.model.gamma_bg, sim.model.gamma_rot)  # the case's own drag, after the rain
    sim.set_drag(*(drag if s.step < rain_end else free))
    t0 = time.perf_counter()
    last_ckpt = t0
    grain_steps = 0
    settled = False
    bar = tqdm(total=max_steps, initial=s.step, disable=not progress, unit="step",
               mininterval=1.0, desc="pysim deposit", dynamic_ncols=True)
    with files.guard(bar):
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
            k_in = next_entry()
            if k_in is not None:
                nxt = min(nxt, k_in)
            before = s.step
            sim.run(nxt - s.step)
            grain_steps += s.n * (s.step - before)
            if s.step == rain_end:
                sim.set_drag(*free)
            if s.step == k_in:
                k = s.n
                others = (s.x, s.u, s.radius, sim.half)
                x, u, v = entry(case, k, init["radius"][k], init["length"][k], lo, others)
                sim.add_particles(x[None, :], init["radius"][k], init["length"][k], u[None, :],
                                  v[None, :])
            bar.update(s.step - before)
            if s.step % thermo_every == 0 or s.step == max_steps:
                th = sim.thermo()
                drv["peak"] = max(drv["peak"], th.ke)
                files.thermo((th.step, th.time, math.nan, math.nan, th.ke, th.pe, th.n_contacts))
                bar.set_postfix(ke=f"{th.ke:.3g}", peak=f"{drv['peak']:.3g}", refresh=False)
                settled = (s.step >= max(min_steps, rain_end, feed_end) and s.n == n_all
                           and th.ke < ratio * drv["peak"])
            natural = s.step % dump_every == 0 or settled
            if natural:
                files.dump(sim)
            if s.step == max_steps and not settled:
                if fed:  # a resume with a larger max_time goes on from here, without the
                    files.checkpoint(sim, drv)  # extra last frame below
                if not natural:
                    files.dump(sim)
            if settled:
                break
            if time.perf_counter() - last_ckpt > checkpoint_every:
                files.checkpoint(sim, drv)
                last_ckpt = time.perf_counter()
    if fed and not settled:
        th = sim.thermo()
        why = (f"only {s.n} of {n_all} grains were fed" if s.n < n_all else
               f"the kinetic energy is {th.ke / drv['peak']:.3g} of its peak, above ke_ratio "
               f"{ratio:g}")
        raise NotSettledError(f"the fed deposit did not settle by max_time = {pr['max_time']:g} "
                              f"(step {s.step}): {why}; raise protocol.max_time and run again "
                              f"with --resume (the checkpoint {files.ckpt} is at that step)")
    wall = time.perf_counter() - t0
    files.finalize()
    th = sim.thermo()
    return {"steps": s.step, "wall_seconds": wall, "settled": bool(settled),
            "ke_peak": drv["peak"], "ke_ratio": th.ke / drv["peak"] if drv["peak"] > 0 else 0.0,
            "final": {"step": th.step, "time": th.time, "ke": th.ke, "n_contacts": th.n_contacts},
            "particle_steps_per_second": grain_steps / wall if wall > 0 else float("nan"),
            "neighbor_rebuilds": sim.rebuilds, "resumed": bool(resume)}
