"""Tapping in a cylinder (science.md section 4, the an3-an9 study).

Grains start as a random loose column in a vertical cylinder (axis ``x = y = 0``) on a
flat base at ``z = 0``. Stages, in steps of ``dt``, with the default preparation
(``protocol.preparation.mode: capped``):

1. *settle* for ``settle_time`` under gravity with a background drag
   ``gamma_bg = m g / v_s`` (``v_s`` = ``settle_speed``, the terminal fall speed of the
   mean grain; rotational drag ``gamma_bg L^2 / 12``), base at rest;
2. *relax* for ``relax_time`` without drag;
3. *tap*: the base moves as ``z_b(t) = a sin(2 pi nu (t - t_0))`` from ``t_0`` (the end
   of the relaxation) for ``taps`` periods ``T = 1 / nu``, with ``a = Gamma g /
   (2 pi nu)^2``.

With ``preparation.mode: free`` (Pournin et al. 2005, section 4: the grains settle under
gravity until their kinetic energy has dropped to zero) stages 1-2 are one free fall
without drag: every ``check_time`` the kinetic energy per grain (translation and
rotation), in units of ``m g D`` of the mean grain, is compared with ``ke_stop``, and the
tapping starts (``t_0``) at the first test that finds it below ``ke_stop`` after an earlier
test found it at or above (the column starts at rest: it must have fallen first). A run
that has not settled by ``max_time`` stops with :class:`SettleError`.

Frames (``particles.dump``, ``contacts.dump``) are written at the steps
``S_k = start + floor(k T / (f dt) + 1/2)``, ``k = 0 ... taps f`` (``f`` =
``frames_per_tap``): frame ``k`` is at phase ``2 pi (k mod f) / f`` of tap ``k // f``,
frame 0 is the settled packing. The LAMMPS deck ``inputs/lammps/in.rods.tap`` writes the
same steps. ``thermo.dat`` rows every ``thermo_every`` steps carry ``phi`` and
``pressure`` as ``nan`` (a container has no box packing fraction; the analysis measures
the filled part of the cylinder).

Every stage steps with ``protocol.integrator`` (velocity Verlet by default; ``euler``,
the paper's forward Euler read literally, or ``semi_implicit_euler``:
:mod:`pysim.integrators`).

Positions in the files are absolute (the container's frame); the simulation itself
works relative to the lower box corner. Checkpoints and ``resume`` as in
:mod:`pysim.protocols.compress`: the stage follows from the step number, so a resumed run
picks up the drag and the base motion where they were (a free preparation also stores
its progress, the settled step once known, in the checkpoint).
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass

import numpy as np
from tqdm import tqdm

from pysim import io, walls
from pysim.protocols.compress import max_overlap, model_from_case
from pysim.protocols.deposit import grain_mass
from pysim.protocols.output import RunFiles
from pysim.simulation import Simulation
from pysim.state import State


@dataclass(frozen=True)
class TapPlan:
    """Step numbers and base motion of a tapping run (see the module docstring)."""

    dt: float
    settle_steps: int
    start: int          # first step of the tapping stage (end of the relaxation)
    end: int            # last step
    period: float       # T = 1 / nu (time)
    omega: float        # 2 pi nu (1 / time)
    amplitude: float    # a = Gamma g / omega^2 (length)
    frames_per_tap: int
    frame_steps: np.ndarray  # S_k, k = 0 ... taps * frames_per_tap

    @property
    def t0(self) -> float:
        """Time at which the base starts to oscillate."""
        return self.start * self.dt

    def base_height(self, step) -> np.ndarray:
        """Base position ``z_b`` (length) at the given step(s)."""
        t = np.asarray(step, dtype=np.float64) * self.dt
        return np.where(t > self.t0, self.amplitude * np.sin(self.omega * (t - self.t0)), 0.0)

    def tap_of(self, step) -> np.ndarray:
        """Tap number (float: whole periods since the start of tapping) at the step(s)."""
        return (np.asarray(step, dtype=np.float64) - self.start) * self.dt / self.period


class SettleError(RuntimeError):
    """A free preparation did not settle by its ``max_time``; the message is one line."""


#: the preparation of a tapping case without a ``protocol.preparation`` block
CAPPED = {"mode": "capped"}


def preparation(protocol: dict) -> dict:
    """The ``preparation`` block of a tapping protocol (``{"mode": "capped"}`` when
    absent)."""
    return protocol.get("preparation", CAPPED)


def is_free(protocol: dict) -> bool:
    """Whether the protocol settles freely (no drag, until the kinetic energy is gone)."""
    return preparation(protocol)["mode"] == "free"


def _nearest(x: float) -> int:
    """Round half up, as LAMMPS' ``round()`` for positive values."""
    return int(math.floor(x + 0.5))


def plan(protocol: dict, gravity: float, settled: int | None = None) -> TapPlan:
    """The :class:`TapPlan` of a tapping protocol block and gravity ``g``. A free
    preparation knows its plan only once settled: pass ``settled``, the step at which the
    kinetic energy dropped below ``ke_stop`` (the tapping starts there, no relaxation)."""
    dt = float(protocol["dt"])
    if is_free(protocol):
        if settled is None:
            raise ValueError("a free preparation starts tapping where the bed has settled; "
                             "pass settled=<step>")
        settle, relax = int(settled), 0
    else:
        settle = _nearest(protocol.get("settle_time", 0.4) / dt)
        relax = _nearest(protocol.get("relax_time", 0.1) / dt)
    nu = float(protocol.get("frequency", 30.0))
    period = 1.0 / nu
    omega = 2.0 * math.pi * nu
    amp = protocol["intensity"] * gravity / omega**2
    fpt = int(protocol.get("frames_per_tap", 4))
    taps = int(protocol["taps"])
    start = settle + relax
    k = np.arange(taps * fpt + 1)
    frames = start + np.floor(k * period / (fpt * dt) + 0.5).astype(np.int64)
    return TapPlan(dt=dt, settle_steps=settle, start=start, end=int(frames[-1]), period=period,
                   omega=omega, amplitude=amp, frames_per_tap=fpt, frame_steps=frames)


def settle_drag(case: dict) -> tuple[float, float]:
    """``(gamma_bg, gamma_rot)`` of the settling stage: ``m g / v_s`` for the mean grain
    and ``gamma_bg L^2 / 12``; none for a free preparation."""
    if is_free(case["protocol"]):
        return 0.0, 0.0
    p = case["particles"]
    length = p.get("aspect_ratio", 0.0) * p["diameter"]["mean"]
    gamma = grain_mass(case) * case["gravity"] / case["protocol"].get("settle_speed", 0.2)
    return gamma, gamma * length**2 / 12.0


def ke_unit(case: dict) -> float:
    """``m g D`` of the mean grain (energy): the unit of ``preparation.ke_stop``."""
    return grain_mass(case) * case["gravity"] * case["particles"]["diameter"]["mean"]


def simulation_from_case(case: dict, init: dict) -> Simulation:
    """The :class:`Simulation` of a tapping case: non-periodic box from the initial data
    file, gravity along ``-z``, the base plane (oscillation parameters set when tapping
    starts) and the cylinder, all relative to the lower box corner."""
    lo = init["box_lo"]
    state = State.create(init["x"] - lo, init["radius"], init["length"], init["box"].copy(),
                         axis=init["axis"].copy(), density=case["particles"].get("density", 1.0),
                         periodic=(False, False, False))
    c = case["contact"]
    model = model_from_case(case)
    if "wall_friction" in c:
        from dataclasses import replace

        model = replace(model, mu_wall=c["wall_friction"])
    base = walls.plane((0, 0, 1), (0.0, 0.0, -lo[2]))
    cyl = walls.cylinder(-lo[0], -lo[1], 0.5 * case["container"]["diameter"])
    return Simulation(state, model, dt=case["protocol"]["dt"], gravity=(0.0, 0.0, -case["gravity"]),
                      planes=[base], cylinders=[cyl], skin=0.2 * 2.0 * float(np.max(state.radius)),
                      max_overlap=max_overlap(case),
                      integrator=case["protocol"].get("integrator", "verlet"))


def set_stage(sim: Simulation, tp: TapPlan, drag: tuple[float, float]):
    """Set the settling drag ``(gamma, gamma_rot)`` (N s/m, N m s) before
    ``tp.settle_steps`` and none after, and the base oscillation
    ``z_b = a sin(omega (t - t0))`` from ``tp.start`` on, for the stage the current step
    is in. Idempotent: call it after every stretch of ``sim.run`` that may cross a stage
    boundary (``run`` cuts its stretches there)."""
    step = sim.state.step
    sim.set_drag(*(drag if step < tp.settle_steps else (0.0, 0.0)))
    if step >= tp.start:
        sim.planes[0, 7] = tp.amplitude
        sim.planes[0, 8] = tp.omega
        sim.planes[0, 9] = -tp.omega * tp.t0


def _settle_free(sim: Simulation, case: dict, files: RunFiles, progress: dict, bar,
                 thermo_every: int, checkpoint_every: float) -> int:
    """Run a free preparation (module docstring) from the current step until the kinetic
    energy per grain drops below ``ke_stop`` ``m g D``; returns that step. ``progress``
    (``{"armed": bool}``: the energy has been at or above ``ke_stop`` at a test) is
    updated in place and goes into the checkpoints. Raises :class:`SettleError` (after a
    checkpoint) when ``max_time`` passes first."""
    s = sim.state
    pr = case["protocol"]
    prep = preparation(pr)
    dt = float(pr["dt"])
    every = max(_nearest(prep["check_time"] / dt), 1)
    last = _nearest(prep["max_time"] / dt)
    unit = ke_unit(case) * s.n
    last_ckpt = time.perf_counter()
    while True:
        if s.step % every == 0:
            e = s.kinetic_energy() / unit
            if progress["armed"] and e < prep["ke_stop"]:
                return s.step
            progress["armed"] = progress["armed"] or e >= prep["ke_stop"]
            if s.step >= last:
                files.checkpoint(sim, {"free": dict(progress)})
                raise SettleError(
                    f"free preparation: kinetic energy {e:.3g} m g D per grain at t = "
                    f"{s.time:.4g} is still above protocol.preparation.ke_stop = "
                    f"{prep['ke_stop']:g} at max_time = {prep['max_time']:g}; raise max_time or "
                    f"ke_stop (the last checkpoint is {files.ckpt})")
            bar.set_postfix(stage="settle", ke=f"{e:.3g} mgD", refresh=False)
        nxt = min((s.step // every + 1) * every, (s.step // thermo_every + 1) * thermo_every)
        before = s.step
        sim.run(nxt - s.step)
        bar.update(s.step - before)
        if s.step % thermo_every == 0:
            th = sim.thermo()
            files.thermo((th.step, th.time, math.nan, math.nan, th.ke, th.pe, th.n_contacts))
        if time.perf_counter() - last_ckpt > checkpoint_every:
            files.checkpoint(sim, {"free": dict(progress)})
            last_ckpt = time.perf_counter()


def run(case: dict, init: dict, out_dir, progress: bool = True, resume: bool = False,
        checkpoint_every: float = 300.0) -> dict:
    """Run the tapping protocol and write the common output files to ``out_dir``.

    Returns a summary: steps, wall time, seconds per tap, particle-steps per second.
    Raises :class:`pysim.simulation.BlowUpError` (keeping the last checkpoint and the
    partial files) when the integration becomes unstable, and :class:`SettleError` (the
    same) when a free preparation has not settled by its ``max_time``.
    """
    free = is_free(case["protocol"])
    files = RunFiles(out_dir, init["ids"], origin=init["box_lo"])
    driver = {}
    if resume:
        sim, driver = files.resume()
    else:
        sim = simulation_from_case(case, init)
        files.start()
    s = sim.state
    thermo_every = int(case.get("output", {}).get("thermo_every", 1000))
    drag = settle_drag(case)
    t0 = time.perf_counter()
    steps_at_start = s.step
    tap_wall = 0.0
    free_state = driver.get("free", {"armed": False, "settled": None})
    tp = None if free and free_state["settled"] is None else plan(
        case["protocol"], case["gravity"], free_state["settled"])
    bar = tqdm(total=tp.end if tp else None, initial=s.step, disable=not progress, unit="step",
               mininterval=1.0, desc="pysim tapping", dynamic_ncols=True)
    fresh = not resume  # a checkpoint before the first step
    with files.guard(bar):
        if tp is None:
            sim.set_drag(0.0, 0.0)
            if fresh:
                files.checkpoint(sim, {"free": dict(free_state)})
            settled = _settle_free(sim, case, files, free_state, bar, thermo_every,
                                   checkpoint_every)
            free_state["settled"] = settled
            tp = plan(case["protocol"], case["gravity"], settled)
            bar.total = tp.end
            files.dump(sim)  # frame 0, the settled packing
            fresh = False
        driver_out = {"free": free_state} if free else None
        frames = set(int(k) for k in tp.frame_steps)
        last_ckpt = time.perf_counter()
        set_stage(sim, tp, drag)
        if fresh:
            files.checkpoint(sim)
        while s.step < tp.end:
            later = tp.frame_steps[tp.frame_steps > s.step]
            nxt = min(tp.end, int(later[0]) if len(later) else tp.end,
                      (s.step // thermo_every + 1) * thermo_every)
            for boundary in (tp.settle_steps, tp.start):
                if s.step < boundary < nxt:
                    nxt = boundary
            before = s.step
            tick = time.perf_counter()
            sim.run(nxt - s.step)
            if before >= tp.start:
                tap_wall += time.perf_counter() - tick
            bar.update(s.step - before)
            set_stage(sim, tp, drag)
            if s.step % thermo_every == 0:
                th = sim.thermo()
                files.thermo((th.step, th.time, math.nan, math.nan, th.ke, th.pe, th.n_contacts))
                stage = "settle" if s.step < tp.settle_steps else (
                    "relax" if s.step < tp.start else f"tap {tp.tap_of(s.step):.1f}")
                bar.set_postfix(stage=stage, ke=f"{th.ke:.3g}", refresh=False)
            if s.step in frames:
                files.dump(sim)
            if time.perf_counter() - last_ckpt > checkpoint_every:
                files.checkpoint(sim, driver_out)
                last_ckpt = time.perf_counter()
    wall = time.perf_counter() - t0
    files.finalize()
    done = s.step - steps_at_start
    taps_done = max(tp.tap_of(s.step) - max(tp.tap_of(steps_at_start), 0.0), 0.0)
    th = sim.thermo()
    return {"steps": s.step, "wall_seconds": wall,
            "final": {"step": th.step, "time": th.time, "ke": th.ke, "n_contacts": th.n_contacts},
            "seconds_per_tap": tap_wall / taps_done if taps_done > 0 else float("nan"),
            "particle_steps_per_second": s.n * done / wall if wall > 0 else float("nan"),
            "neighbor_rebuilds": sim.rebuilds, "resumed": bool(resume)}
