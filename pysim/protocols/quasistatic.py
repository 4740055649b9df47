"""Quasistatic compression: affine steps in the packing fraction, each relaxed to a minimum.

The discrete form of a compression in its quasistatic limit (Marschall & Teitel 2018,
Sec. II: their overdamped compression is "a continuous-in-time analog" of compressing by a
small ``dphi`` and minimising the energy before the next step). From the random
zero-energy start at ``phi_init`` the box shrinks affinely by ``dphi_coarse`` per step and
the packing is relaxed (:func:`pysim.protocols.jammed.relax`: FIRE and L-BFGS until the
energy settles, stopping early once ``U/L^d`` is below ``energy_zero``). The first coarse
step whose relaxed packing keeps energy is undone, and the compression goes on from the
last unjammed packing in steps of ``dphi`` until the contact pressure reaches
``pressure_final`` (units of ``k_n / D^(d-1)``). Each kept relaxation is one row of
``thermo.dat`` and one frame of the dumps (``step`` counts the relaxations, plus the
Heun steps of overdamped ones), so
``p(phi)`` of the run is what the paper fits: its first linear rise extrapolated to
``p = 0`` gives the sample's ``phi_J`` (:mod:`analysis.jamming`).

``relaxation: minimise`` (the default) relaxes with the minimisers; ``relaxation:
overdamped`` runs the paper's own dynamics at a fixed box instead (overdamped Heun steps
with substrate drag ``k_d``, :meth:`Simulation.run_overdamped` at ``kappa = 0``) until
``U/L^d`` is below ``energy_zero`` or falls by less than ``settle_rtol`` of itself over
``check_every`` steps, so that the packing follows the path of a compression at
vanishing rate rather than FIRE's inertial one. A relaxation cut off after ``max_steps``
with ``U/L^d`` still above ``energy_zero`` counts as jammed (``max_steps`` Heun steps
per ``dphi`` is a compression at about ``dphi / (2 phi max_steps dt)``). The relaxations use
``contact.spine_contact``; a run checkpoints after every relaxation and resumes from the
last one.
"""
from __future__ import annotations

import time

from tqdm import tqdm

from pysim.protocols.compress import simulation_from_case
from pysim.protocols.jammed import _copy, energy_density, relax
from pysim.protocols.output import RunFiles
from pysim.simulation import BlowUpError, Simulation


def relax_overdamped(sim: Simulation, k_d: float, zero: float, d_min: float,
                     check_every: int, settle_rtol: float, max_steps: int) -> bool:
    """Overdamped Heun steps at a fixed box until ``U/L^d < zero`` (unjammed) or it fell
    by less than ``settle_rtol`` of itself over ``check_every`` steps (settled). Returns
    whether it stopped so rather than after ``max_steps``."""
    e_prev = energy_density(sim, d_min)
    done = 0
    while done < max_steps:
        if e_prev < zero:
            return True
        sim.run_overdamped(check_every, k_d=k_d, kappa=0.0)
        done += check_every
        e = energy_density(sim, d_min)
        if e_prev - e <= settle_rtol * e_prev:
            return True
        e_prev = e
    return e_prev < zero


def step(sim: Simulation, goal: float, protocol: dict, f_tol: float, d_min: float) -> float:
    """Shrink the box affinely to packing fraction ``goal`` and relax it by the
    protocol's ``relaxation``; returns ``U/L^d`` (lengths in units of ``d_min``). Either
    relaxation stops as soon as ``U/L^d < energy_zero``. (The case check refuses the
    minimisers for rods under the closest-point law: they stall on its kink.)"""
    s = sim.state
    zero = protocol["energy_zero"]
    sim.rescale_box((s.packing_fraction() / goal) ** (1.0 / s.dimension))
    if protocol["relaxation"] == "overdamped":
        relax_overdamped(sim, protocol["k_d"], zero, d_min, protocol["check_every"],
                         protocol["settle_rtol"], protocol["max_steps"])
    else:
        relax(sim, f_tol, protocol["max_relax"], lambda t: energy_density(t, d_min) < zero)
    return energy_density(sim, d_min)


def run(case: dict, init: dict, out_dir, progress: bool = True, resume: bool = False,
        checkpoint_every: float = 0.0) -> dict:
    """Run the protocol; returns a summary (steps, wall time, final ``phi`` and
    pressure, where the fine steps started). ``checkpoint_every`` is unused: the run
    checkpoints after every relaxation."""
    p = case["protocol"]
    files = RunFiles(out_dir, init["ids"])
    if resume:
        sim, drv = files.resume()
    else:
        sim = simulation_from_case(case, init, check_dt=False)
        files.start()
        drv = {"phase": "coarse", "d_min": float(2 * sim.state.radius.min())}
    d_min = drv["d_min"]
    k_n = case["contact"]["k_n"]
    f_tol = p["force_tol"] * k_n / d_min
    zero = p["energy_zero"]
    t0 = time.perf_counter()
    bar = tqdm(disable=not progress, unit="relax", desc="pysim quasistatic", dynamic_ncols=True)

    def pressure(sim_: Simulation) -> float:
        """Contact pressure in units of ``k_n / D^(d-1)``."""
        return sim_.thermo().pressure * d_min ** (sim_.state.dimension - 1) / k_n

    def keep(sim_: Simulation):
        """Record a relaxed packing as the next row and frame, and checkpoint it."""
        sim_.state.step += 1
        files.thermo(sim_.thermo().row())
        files.dump(sim_)
        files.checkpoint(sim_, drv)

    with files.guard(bar):
        if not resume:
            sim.compute_forces()
            files.thermo(sim.thermo().row())
            files.dump(sim)
            files.checkpoint(sim, drv)
        while True:
            s = sim.state
            phi = s.packing_fraction()
            if pressure(sim) >= p["pressure_final"]:
                break
            fine = drv["phase"] == "fine"
            goal = phi + (p["dphi"] if fine else p.get("dphi_coarse", p["dphi"]))
            if goal > p["phi_max"]:
                raise BlowUpError(f"the pressure stayed below pressure_final = "
                                  f"{p['pressure_final']} up to phi_max = {p['phi_max']} "
                                  f"(phi = {phi:.4f}); raise phi_max or check the case")
            trial = sim if fine else _copy(sim)
            e = step(trial, goal, p, f_tol, d_min)
            bar.update(1)
            bar.set_postfix(phi=f"{goal:.4f}", U=f"{e:.2e}", refresh=False)
            if not fine and e >= zero:
                # the coarse step jammed: go on from the last unjammed packing in fine steps
                drv.update(phase="fine", phi_fine=phi)
                files.checkpoint(sim, drv)
                continue
            sim = trial
            keep(sim)
    files.finalize()
    s = sim.state
    return {"steps": s.step, "wall_seconds": time.perf_counter() - t0,
            "phi_final": s.packing_fraction(), "pressure_final": pressure(sim),
            "phi_fine": drv.get("phi_fine"), "resumed": bool(resume)}
