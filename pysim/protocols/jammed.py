"""Mechanically stable packings at jamming (science.md, 2-D compression protocol).

1. **Compress** overdamped (Heun, substrate drag ``k_d``) at rate ``kappa`` from the
   random zero-energy start, with the rods' contact rule ``protocol.compress_spine_contact``
   where given (Marschall & Teitel 2018 compress with one contact at the closest points,
   their Eq. 3, and minimise with two bonds side to side, their Fig. 6); every relaxation
   uses ``contact.spine_contact``. Once the contact pressure exceeds ``pressure_start`` (in
   units of ``k_n / D^(d-1)``), the packing is relaxed (FIRE, on a copy) every
   ``thermo_every`` steps; the compression stops at the first packing whose relaxed
   elastic energy per area ``U/L^d`` exceeds ``energy_target`` (jammed).
2. **Bisect the box size**: between the last unjammed packing fraction and the first jammed
   one, expand the box of the jammed packing affinely to the middle, relax, and move the
   bracket. Where every expansion of the jammed packing unjams (an energy jump), the
   bracket is opened above the unjammed packing, which is compressed until it jams
   (:func:`next_trial`), and the bisection goes on from there. (Starting every trial from
   the trial before, as O'Hern et al. 2003 do in small steps, mixes packings: a large
   compression of an unjammed one lands in another basin.) The bisection ends when
   ``U/L^d`` lies within a factor 2 of ``energy_target``, or the bracket is narrower than
   :data:`PHI_TOL` (opened again when the jammed packing still holds more than
   :data:`REOPEN_ENERGY`, the ends lying in different basins, or was still sliding when
   its relaxation ran out of rounds; see :func:`next_trial`), or
   ``max_bisections`` is reached. Each relaxation (:func:`relax`) runs FIRE and L-BFGS
   (:func:`pysim.minimize.lbfgs`) in rounds until the energy has stopped falling: a packing
   with small residual forces may still be sliding towards an unjammed state, and taken as
   jammed it stalls the bisection (every expansion of it unjams). A relaxed packing counts
   as jammed when its energy density exceeds half the target *and* a contact backbone
   (particles with at least ``d + 1`` contacts, others removed iteratively) holds at least
   half the particles: rods can stay caught on the kink of the spine-distance law with tiny
   overlaps below jamming.

The final packing is the mechanically stable state: its frame is the last of
``particles.dump``/``contacts.dump`` (10 digits), ``stable_state.npz`` holds it at full
precision (a :mod:`pysim.checkpoint`), and ``jammed.json`` records ``phi_j``, ``U/L^d``,
whether the minimisers balanced its forces to ``force_tol`` (``force_balanced``), the
number of bisections, whether its relaxation ended with the energy settled at a minimum
(``energy_settled``), the residual forces and torques relative to the mean contact force
and torque, and ``converged`` (:func:`is_converged`: the energy on target and settled, and
the forces balanced, by ``force_tol`` or to :data:`BALANCE_TOL` of the mean contact force). With
the closest-point law these residuals stay of the order of the contact forces for rods:
the law has a kink at parallel side-by-side contacts, where FIRE stalls; use
``contact.spine_contact: end_bonds`` (:func:`pysim.contacts.end_bond`), whose energy is
smooth there, for mechanically stable rod packings. Energies are in units of ``k_n`` and
lengths in units of the smallest diameter.
"""
from __future__ import annotations

import json
import time
from typing import NamedTuple

import numpy as np
from threadpoolctl import threadpool_limits
from tqdm import tqdm

from pysim import checkpoint, io
from pysim.minimize import lbfgs
from pysim.protocols.compress import simulation_from_case
from pysim.protocols.output import RunFiles
from pysim.simulation import BlowUpError, Simulation


def energy_density(sim: Simulation, d_min: float) -> float:
    """Elastic energy per box area (volume in 3-D), lengths in units of ``d_min``."""
    s = sim.state
    return sim.thermo().pe / (s.volume() / d_min**s.dimension)


#: stop bisecting when the bracket on phi is this narrow: near jamming ``U/L^2`` is about
#: ``0.2 (phi - phi_J)^2`` (2-D, N = 256, alpha 1), so the factor-2 window around the
#: target 1e-15 is only some 5e-8 wide in phi (with a bracket of 1e-7 many states closed
#: just outside the window: docs/performance.md)
PHI_TOL = 1e-8
#: a bracket that closes on a packing with more energy than this is opened again
#: (:func:`next_trial`): with the harmonic law ``U/L^d`` is about ``(phi - phi_J)^2``, so
#: such a packing is still 1e-6 or more above its own jamming point, and the two ends
#: of the bracket lie in different basins: below, when the lower end came from the
#: compression (a lower bound from another packing); above, when it came from expanding
#: the jammed packing, which unjams at the smallest expansion (cases: docs/performance.md)
REOPEN_ENERGY = 1e-12
#: a packing is force-balanced when the minimisers reached ``force_tol`` or when every
#: residual force and torque is below this fraction of the mean contact force and torque:
#: at the target energy the absolute ``force_tol`` (1e-13 k_n / D) is some 4e-6 of the mean
#: contact force, which FIRE does not always reach for rods, while the false jammed state
#: that stalled the bisection kept residuals far above this
BALANCE_TOL = 1e-3
#: rounds (L-BFGS, then FIRE of up to ``max_relax`` iterations) at most per relaxation
#: while the energy still falls (:func:`relax`): a packing with energy left may still be
#: sliding out of a jammed-looking state. Many short rounds for the budget of a few long
#: ones: with a few, rod states with large residuals passed as jammed (docs/performance.md)
RELAX_ROUNDS = 50
#: rounds at most for a trial of the jamming protocol (:func:`run`), whose decision
#: (jammed or not) and final state rest on the relaxation having stopped. 50 were too few
#: for long rods: a trial ran out of them inside the target window, was taken as the
#: stable state, and unjammed with a few rounds more (docs/performance.md)
TRIAL_ROUNDS = 200
#: a relaxation has reached a minimum when its energy fell by less than this fraction of
#: itself in :data:`SETTLE_ROUNDS` rounds in a row (each ``max_relax`` / LBFGS_SHARE L-BFGS
#: iterations and a FIRE run back to :data:`BALANCE_TOL`). Residuals below BALANCE_TOL alone
#: are no minimum: states taken on that rule went on losing energy, some until they
#: unjammed, while settled states lose far less than this per round (L-BFGS resolves no
#: more; docs/performance.md)
ENERGY_RTOL = 1e-6
#: consecutive rounds that must satisfy :data:`ENERGY_RTOL`: near a saddle the energy
#: can stay put for a round or two (L-BFGS' line search gives up at once) and then fall,
#: and a packing taken as settled after two such rounds unjammed on the next expansion
SETTLE_ROUNDS = 3
#: FIRE checks the early stops of a relaxation (energy below a quarter of the target, or
#: every residual below :data:`BALANCE_TOL`) every this many iterations: checked only at
#: the end of each ``max_relax`` round, a state balanced early on went on towards the
#: absolute ``force_tol`` for the rest of the round
CHECK_EVERY = 1000
#: L-BFGS iterations per round are ``max_relax`` over this: FIRE stalls on the
#: ill-conditioned landscape near jamming, where far fewer L-BFGS iterations bring the
#: residuals far lower (docs/performance.md)
LBFGS_SHARE = 10


#: the final stable state as a checkpoint (:mod:`pysim.checkpoint`), beside the dumps
STABLE_STATE = "stable_state.npz"
#: the packing of the last unjammed trial, which the trials compress while the bracket is
#: open above (a :mod:`pysim.checkpoint` kept for resuming while the bisection runs)
BISECT_BASE = "bisect_base.npz"


def backbone_fraction(sim: Simulation) -> float:
    """Fraction of particles left after removing, iteratively, those with fewer than
    ``d + 1`` contacts (the fewest that hold a particle in place against translations;
    jammed rods are hypostatic, so the rotational count would be too strict)."""
    s = sim.state
    d_f = s.dimension
    ij, _ = sim.contact_table()
    alive = np.ones(len(ij), dtype=bool)
    gone = np.zeros(s.n, dtype=bool)
    while True:
        counts = np.bincount(ij[alive].ravel(), minlength=s.n)
        new = (counts < d_f + 1) & ~gone
        if not new.any():
            return float(np.count_nonzero(~gone)) / s.n
        gone |= new
        alive &= ~(gone[ij[:, 0]] | gone[ij[:, 1]])


def residuals(sim: Simulation) -> dict:
    """Residual forces and torques of the packing relative to its mean contact force and
    mean contact torque ``|F_c| R`` (rattlers included; units cancel)."""
    ij, rec = sim.contact_table()
    f = np.linalg.norm(sim.f, axis=1)
    t = np.linalg.norm(sim.torque, axis=1)
    if len(rec) == 0:
        return {"mean_contact_force": 0.0, "force_residual_mean": float("nan"),
                "force_residual_max": float("nan"), "torque_residual_mean": float("nan"),
                "torque_residual_max": float("nan")}
    fc = np.linalg.norm(rec[:, 7:10], axis=1)
    lever = sim.state.radius[ij[:, 0]]
    mean_f = float(fc.mean())
    mean_t = float((fc * lever).mean())
    return {"mean_contact_force": mean_f, "force_residual_mean": float(f.mean() / mean_f),
            "force_residual_max": float(f.max() / mean_f),
            "torque_residual_mean": float(t.mean() / mean_t),
            "torque_residual_max": float(t.max() / mean_t)}


def _within_balance_tol(r: dict) -> bool:
    """Every residual of a :func:`residuals` record below :data:`BALANCE_TOL`."""
    worst = max(r["force_residual_max"], r["torque_residual_max"])
    return bool(np.isfinite(worst) and worst < BALANCE_TOL)


def balanced_to_tol(sim: Simulation) -> bool:
    """Whether every residual force and torque of the packing is below
    :data:`BALANCE_TOL` of its mean contact force and torque (:func:`residuals`)."""
    return _within_balance_tol(residuals(sim))


def is_converged(result: dict, energy_target: float) -> bool:
    """Whether a ``jammed.json`` record is a converged mechanically stable state: ``U/L^d``
    within a factor 2 of ``energy_target``, the energy settled at a minimum
    (``energy_settled``, see :func:`relax`; records written before that rule lack it and
    are not converged) and the forces balanced (``force_balanced``, or every residual
    force and torque below :data:`BALANCE_TOL` of the mean contact force and torque)."""
    e = result["energy_density"]
    if not energy_target / 2 <= e <= 2 * energy_target:
        return False
    if not result.get("energy_settled", False):
        return False
    if result.get("force_balanced", False):
        return True
    return _within_balance_tol(result)


class Relaxation(NamedTuple):
    """Outcome of :func:`relax`."""

    #: every force and torque below ``f_tol``
    balanced: bool
    #: the relaxation ended at a minimum (the energy stopped falling, or the forces reached
    #: ``f_tol``) or ``done`` held, rather than running out of rounds
    stopped: bool
    #: FIRE and L-BFGS iterations together
    iterations: int


def relax(sim: Simulation, f_tol: float, max_relax: int, done=None, *,
          energy_rtol: float = ENERGY_RTOL, balance: bool = True,
          max_rounds: int = RELAX_ROUNDS) -> Relaxation:
    """Relax ``sim`` at fixed box to a minimum of its energy. FIRE first, until the
    residuals are below :data:`BALANCE_TOL` (checked every :data:`CHECK_EVERY`
    iterations) or ``max_relax`` iterations; then rounds (at most ``max_rounds``) of
    ``max_relax`` / :data:`LBFGS_SHARE` L-BFGS iterations (:func:`pysim.minimize.lbfgs`)
    followed by the same FIRE run, until the energy has stopped falling: for
    :data:`SETTLE_ROUNDS` rounds in a row it fell by less than ``energy_rtol`` of itself
    and (with ``balance``) ended balanced to :data:`BALANCE_TOL`. Stops at once when every
    force and torque is below ``f_tol`` or ``done(sim)`` holds (checked with the FIRE stops
    and before anything runs). ``balance=False`` is for energies with kinks (3-D rods with
    the closest-point law: a minimum on the kink of a near-parallel contact keeps torques
    of the order of the contact torques, which no minimiser removes). Returns a
    :class:`Relaxation`."""
    iterations = 0

    def stop(t: Simulation) -> bool:
        return (done is not None and done(t)) or balanced_to_tol(t)

    def fire() -> bool:
        nonlocal iterations
        it, fmax, tmax = sim.minimize(f_tol=f_tol, max_iter=max_relax, until=stop,
                                      check_every=CHECK_EVERY)
        iterations += int(it)
        return fmax < f_tol and tmax < f_tol

    def finished() -> bool:
        return balanced or (done is not None and done(sim))

    sim.compute_forces()
    balanced = bool(max(np.linalg.norm(sim.f, axis=1).max(initial=0.0),
                        np.linalg.norm(sim.torque, axis=1).max(initial=0.0)) < f_tol)
    if finished():
        return Relaxation(balanced, True, iterations)
    balanced = fire()
    calm = 0
    for _ in range(max_rounds):
        if finished():
            return Relaxation(balanced, True, iterations)
        e0 = sim.thermo().pe
        with threadpool_limits(limits=1):  # BLAS threads only slow L-BFGS' vectors
            it, fmax, tmax = lbfgs(sim, f_tol, max(1, max_relax // LBFGS_SHARE))
        iterations += int(it)
        balanced = fmax < f_tol and tmax < f_tol
        if not finished():
            balanced = fire()
        fell = e0 - sim.thermo().pe
        calm = (calm + 1 if fell <= energy_rtol * e0 and (not balance or balanced_to_tol(sim))
                else 0)
        if calm >= SETTLE_ROUNDS:
            return Relaxation(balanced, True, iterations)
    return Relaxation(balanced, finished(), iterations)


def next_trial(drv: dict, e: float, target: float, max_bisections: int) -> float | None:
    """The bisection's next packing fraction, or ``None`` when it is done.

    ``drv`` holds the bracket (``lo``: the densest unjammed fraction, ``None`` when there
    is none yet; ``hi``: the least dense jammed one, ``None`` while searching upwards)
    and the ``bisections`` so far; ``e`` is the energy density of the jammed packing held.
    Done when ``e`` is within a factor 2 of ``target``, after ``max_bisections``, or when
    the bracket is narrower than :data:`PHI_TOL` with ``e`` at most :data:`REOPEN_ENERGY`
    (an energy jump inside the bracket). A bracket that closes above
    :data:`REOPEN_ENERGY`, or on a jammed packing whose relaxation never settled
    (``drv["settled"]`` false: it was still sliding, as a rod tip passing the end of
    another spine does under ``end_bonds_distinct``) while the lower end came from a
    trial, is opened again (counted in ``drv["reopened"]``), on the side where the
    search can go on:

    * ``lo`` from a trial of the bisection (``drv["lo_trial"]``): the jammed packing
      unjams on the smallest expansion, the edge of its basin. The bracket is opened
      above (``hi = None``), and the trials compress the unjammed packing in steps that
      start at :data:`PHI_TOL` and double, until one jams.
    * ``lo`` from the compression (another packing): the jammed packing may stay jammed
      well below it. The bracket is opened below (``lo = None``).

    Without a lower bound the next trial is the middle of ``[0.9 hi, hi]``; otherwise the
    middle of ``[lo, hi]``.
    """
    if target / 2 <= e <= 2 * target or drv["bisections"] >= max_bisections:
        return None
    closed = (drv["lo"] is not None and drv["hi"] is not None
              and drv["hi"] - drv["lo"] < PHI_TOL)
    if closed:
        # a held packing still sliding (its relaxation never settled) is no end of the
        # bracket either: expansions of it unjam, and so does it, relaxed longer
        sliding = not drv.get("settled", True) and drv.get("lo_trial", False)
        if e <= REOPEN_ENERGY and not sliding:
            return None
        drv["reopened"] = drv.get("reopened", 0) + 1
        if drv.get("lo_trial", False):
            drv["hi"] = None
            drv["step"] = PHI_TOL
        else:
            drv["lo"] = None
    if drv["hi"] is None:
        goal = drv["lo"] + drv["step"]
        drv["step"] *= 2
        return goal
    lo = drv["lo"] if drv["lo"] is not None else 0.9 * drv["hi"]
    return 0.5 * (lo + drv["hi"])


def run(case: dict, init: dict, out_dir, progress: bool = True, resume: bool = False,
        checkpoint_every: float = 300.0) -> dict:
    """Run the protocol; returns a summary (``phi_j``, ``energy_density``, residuals)."""
    p = case["protocol"]
    files = RunFiles(out_dir, init["ids"])
    # the relaxations' law; the compression may have its own (protocol.compress_spine_contact)
    law = case["contact"].get("spine_contact", "closest")
    if resume:
        sim, drv = files.resume()
    else:
        sim = simulation_from_case(case, init, check_dt=False)
        if p.get("compress_spine_contact", law) != law:
            sim.set_spine_contact(p["compress_spine_contact"])
        files.start()
        drv = {"phase": "compress", "lo": None, "hi": None, "bisections": 0}
    s = sim.state
    k_n = case["contact"]["k_n"]
    d_min = float(2 * s.radius.min()) if not resume else drv["d_min"]
    drv["d_min"] = d_min
    target = p["energy_target"]
    f_tol = p["force_tol"] * k_n / d_min
    every = int(case.get("output", {}).get("thermo_every", 1000))
    t0 = time.perf_counter()
    bar = tqdm(disable=not progress, unit="relax", desc="pysim jammed", dynamic_ncols=True)

    def jammed(trial: Simulation, e: float) -> bool:
        """Relaxed energy above half the target and a contact backbone holding most
        particles: FIRE can leave a few rods caught on the kink of the spine-distance
        law with tiny overlaps below jamming, which is no jammed packing."""
        return e > target / 2 and backbone_fraction(trial) >= 0.5

    def relaxed_energy(trial: Simulation) -> tuple[float, bool, bool]:
        """:func:`relax` the trial packing to a minimum, stopping early once its energy is
        below a quarter of the target (unjammed, whatever comes next). Returns ``U/L^d``,
        whether the forces are balanced to ``f_tol`` and whether the relaxation stopped
        (a minimum, or unjammed) rather than ran out of rounds."""
        def unjammed(t: Simulation) -> bool:
            return energy_density(t, d_min) < target / 4

        balanced, stopped, _ = relax(trial, f_tol, p["max_relax"], unjammed,
                                     max_rounds=TRIAL_ROUNDS)
        return energy_density(trial, d_min), balanced, stopped

    def record(sim_):
        files.thermo(sim_.thermo().row())
        files.dump(sim_)

    with files.guard(bar):
        if not resume:
            files.dump(sim)
        while drv["phase"] == "compress":
            sim.run_overdamped(every, k_d=p["k_d"], kappa=p["rate"])
            th = sim.thermo()
            files.thermo(th.row())
            phi = s.packing_fraction()
            if phi > p["phi_max"]:
                raise BlowUpError(f"no jamming below phi_max = {p['phi_max']} (phi = {phi:.4f}); "
                                  "raise phi_max or check the case")
            if th.pressure * d_min ** (s.dimension - 1) / k_n < p["pressure_start"]:
                continue
            # relax a copy: the compression itself goes on from the unrelaxed packing
            trial = _copy(sim)
            if trial.model.spine_contact != law:
                trial.set_spine_contact(law)
            e, balanced, settled = relaxed_energy(trial)
            bar.update(1)
            bar.set_postfix(phi=f"{phi:.4f}", U=f"{e:.2e}", refresh=False)
            if jammed(trial, e):
                drv.update(phase="bisect", hi=phi, balanced=balanced, settled=settled)
                sim = trial
                s = sim.state
                record(sim)
            else:
                drv["lo"] = phi
            files.checkpoint(sim, drv)
        # sim holds the jammed packing at phi_hi, low that of the last unjammed trial;
        # each trial expands sim, or compresses low while the bracket is open above
        low_file = files.dir / BISECT_BASE
        low = checkpoint.load(low_file)[0] if resume and low_file.exists() else None
        while drv["phase"] == "bisect":
            goal = next_trial(drv, energy_density(sim, d_min), target, p["max_bisections"])
            if goal is None:
                drv["phase"] = "done"
                break
            trial = _copy(low if drv["hi"] is None and low is not None else sim)
            trial.rescale_box((trial.state.packing_fraction() / goal) ** (1.0 / s.dimension))
            e, balanced, settled = relaxed_energy(trial)
            drv["bisections"] += 1
            bar.update(1)
            bar.set_postfix(phi=f"{goal:.6f}", U=f"{e:.2e}", refresh=False)
            if jammed(trial, e):
                drv.update(hi=trial.state.packing_fraction(), balanced=balanced,
                           settled=settled)
                sim = trial
                s = sim.state
                record(sim)
            else:
                drv.update(lo=trial.state.packing_fraction(), lo_trial=True)
                s.step = trial.state.step  # keep the step count growing
                low = trial
                checkpoint.save(low, low_file)
            files.checkpoint(sim, drv)
        low_file.unlink(missing_ok=True)
    e = energy_density(sim, d_min)
    balanced = bool(drv.get("balanced", False))
    result = {"phi_j": s.packing_fraction(), "energy_density": e, "converged": False,
              "force_balanced": balanced,
              "energy_settled": bool(drv.get("settled", False)), "bisections": drv["bisections"],
              "reopened": drv.get("reopened", 0), **residuals(sim)}
    result["converged"] = is_converged(result, target)
    io.atomic_write_text(files.dir / "jammed.json", json.dumps(result, indent=2) + "\n")
    # the state at full precision: the dumps keep 10 digits, which moves contacts of
    # 1e-7 D overlap by 1 % and opens the shallowest (analysis.modes needs it exact)
    checkpoint.save(sim, files.dir / STABLE_STATE)
    files.finalize()
    return {"steps": s.step, "wall_seconds": time.perf_counter() - t0, **result,
            "resumed": bool(resume)}


def _copy(sim: Simulation) -> Simulation:
    """An independent copy of a simulation (through the checkpoint format in memory)."""
    import tempfile
    from pathlib import Path

    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "copy.npz"
        checkpoint.save(sim, path)
        return checkpoint.load(path)[0]
