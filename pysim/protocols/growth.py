"""Growth to jamming (science.md section 4, the 3-D random-packing study).

0. **Contract** (only with ``contraction``): from the random start at ``phi_init``,
   mechanical contraction to ``contraction.phi`` (:mod:`pysim.protocols.contraction`),
   the start of Wouterse, Luding and Philipse; growth then starts from rest there.
1. **Grow**: from the random start at ``phi_init`` every ``D`` and ``L`` grows as
   ``exp(rate t)`` (aspect ratio fixed) under velocity Verlet with the case's damping,
   until ``phi_grow``; thermo rows and dumps as in the compression driver.
2. **Relax / increment**: relax to a minimum of the elastic energy (:func:`_relax`: FIRE,
   then rounds of L-BFGS and FIRE of ``max_relax`` iterations until the energy has
   settled, or is below ``energy_tol / 4`` per particle; with ``relaxation.method: md``
   damped dynamics instead, :func:`_relax_md`). A relaxed packing whose
   elastic energy per particle is below ``energy_tol * k_n D^2`` is *unjammed*,
   otherwise *jammed*. While unjammed, grow by ``increment`` (rescaling the particles)
   and relax again, up to ``phi_max``; a jammed packing at ``phi_grow`` is shrunk by
   ``increment`` steps instead. FIRE alone cannot decide this for rods: on the
   ill-conditioned landscape near jamming it crawls, and every FIRE run of the rod
   growths that ended "jammed" had stopped at its iteration cap, with the energy still
   falling (docs/studies/random_packings.md, growth's "jammed").
3. **Bisect** between the last unjammed (``phi_lo``) and the first jammed (``phi_hi``)
   packing fraction, always restarting from the relaxed unjammed packing, until
   ``phi_hi - phi_lo < tolerance``; ``phi_J = phi_hi``.

Every relaxed packing is a frame of ``particles.dump``/``contacts.dump`` and a row of
``cycles.dat`` (``step phi pe_per_particle pressure n_contacts jammed iterations residual
settled``), which is what the analysis of ``<C>(phi)``, ``P(C)`` and the order along the
way reads. The driver checkpoints after every relaxation and resumes bit-identically.
"""
from __future__ import annotations

import math
import time

import numpy as np
from tqdm import tqdm

from pysim import checkpoint
from pysim.protocols.contraction import contract
from pysim.protocols.compress import max_overlap, model_from_case, state_from_init
from pysim.protocols.jammed import relax, residuals
from pysim.protocols.output import RunFiles
from pysim.simulation import Simulation

CYCLES_HEADER = ("# step phi pe_per_particle pressure n_contacts jammed iterations residual "
                 "settled\n")


class GrowthLimitError(RuntimeError):
    """The cycles would grow the packing past ``protocol.phi_max`` without jamming."""


def _relax(sim: Simulation, p: dict, k_n: float, d_mean: float) -> tuple[float, bool, int,
                                                                       float, bool]:
    """Relax to a minimum of the elastic energy at fixed box (:func:`jammed.relax`: FIRE,
    then rounds of L-BFGS and FIRE until the energy fell by less than ``settle_rtol`` of
    itself in three rounds in a row), stopping early once the energy per particle is
    below a quarter of ``energy_tol`` (unjammed, whatever comes next).

    Returns the elastic energy per particle (units of ``k_n D^2``), whether that is
    jammed (at least ``energy_tol``), the FIRE and L-BFGS iterations, the residual (the
    largest force on a particle over the mean contact force, 0 when nothing touches) and
    whether the relaxation *settled* (ended at a minimum or unjammed) rather than ran out
    of rounds with the energy still falling, a packing then taken as jammed without
    proof. The residual of a settled jammed packing need not be small: 3-D rods can
    settle on the kink of the closest-point law at a near-parallel contact."""
    scale = sim.state.n * k_n * d_mean**2
    f_tol = p["force_tol"] * k_n * d_mean

    def unjammed(t: Simulation) -> bool:
        return t.thermo().pe / scale < p["energy_tol"] / 4

    _, settled, it = relax(sim, f_tol, p["max_relax"], unjammed,
                           energy_rtol=p["settle_rtol"], balance=False)
    sim.state.step += it  # minimiser iterations count as steps, so steps stay unique
    e = sim.thermo().pe / scale
    residual = residuals(sim)["force_residual_max"]  # NaN when nothing touches
    return (e, e >= p["energy_tol"], int(it), residual if np.isfinite(residual) else 0.0,
            bool(settled))


def _relax_md(sim: Simulation, p: dict, k_n: float, d_mean: float) -> tuple[float, bool, int,
                                                                          float, bool]:
    """Relax by the equations of motion (Wouterse, Luding and Philipse, Sec. 2.1): the
    case's contact damping and background viscosity at ``relaxation.dt``, from the
    current velocities, checked every ``check_time``. Ends *unjammed* once the elastic
    energy per particle is below ``energy_tol / 4`` (units of ``k_n D^2``: the paper's
    test, "no longer possible to relax to zero potential energy"; near jamming the
    grains collide all the time, so no overlap at all means the packing is calm);
    *settled* once the total energy ``E = KE + PE`` fell by less than ``settle_rtol E``
    per check three checks in a row; otherwise after ``max_time`` (not settled). Returns what
    :func:`_relax` returns, the steps run in place of its iterations; the growth's time
    step is restored."""
    r = p["relaxation"]
    scale = sim.state.n * k_n * d_mean**2
    dt_grow = sim.dt
    sim.dt = r.get("dt", dt_grow)
    n_check = max(1, round(r["check_time"] / sim.dt))
    n_max = max(n_check, round(r["max_time"] / sim.dt))
    th = sim.thermo()
    e_prev, steps, calm, settled = th.ke + th.pe, 0, 0, False
    try:
        while steps < n_max and not settled:
            sim.run(n_check)
            steps += n_check
            th = sim.thermo()
            e = th.ke + th.pe
            calm = calm + 1 if e_prev - e < p["settle_rtol"] * e else 0
            settled = th.pe / scale < p["energy_tol"] / 4 or calm >= 3
            e_prev = e
    finally:
        sim.dt = dt_grow
    e_pe = th.pe / scale
    residual = residuals(sim)["force_residual_max"]  # NaN when nothing touches
    return (e_pe, e_pe >= p["energy_tol"], int(steps),
            residual if np.isfinite(residual) else 0.0, bool(settled))


def run(case: dict, init: dict, out_dir, progress: bool = True, resume: bool = False,
        checkpoint_every: float = 300.0) -> dict:
    """Run the growth protocol; returns a summary with ``phi_j`` and ``phi_j_low``."""
    p = case["protocol"]
    files = RunFiles(out_dir, init["ids"], extra={"cycles.dat": CYCLES_HEADER})
    lo_path = files.dir / "checkpoint_unjammed.npz"
    if resume:
        sim, drv = files.resume()
    else:
        state = state_from_init(case, init)
        sim = Simulation(state, model_from_case(case), dt=p["dt"],
                         skin=0.2 * 2.0 * float(np.max(state.radius)),
                         max_overlap=max_overlap(case))
        files.start()
        drv = {"phase": "contract" if "contraction" in p else "grow", "lo": None,
               "hi": None, "increment": p["increment"], "grow_from": 0,
               "phi_start": p["phi_init"]}
    s = sim.state
    k_n = case["contact"]["k_n"]
    outp = case.get("output", {})
    thermo_every = int(outp.get("thermo_every", 1000))
    dump_every = int(outp.get("dump_every", 4000))
    t0 = time.perf_counter()
    last_ckpt = t0
    if drv["phase"] == "contract":
        if s.step == 0:
            files.dump(sim)
        mcm = p["contraction"]
        with tqdm(total=math.ceil((mcm["phi"] - s.packing_fraction()) / mcm["increment"]),
                  disable=not progress, unit="step", desc="pysim contraction",
                  mininterval=1.0, dynamic_ncols=True) as cbar:
            def contracted(sim_, iterations):
                files.thermo(sim_.thermo().row())
                cbar.update(1)
                cbar.set_postfix(phi=f"{sim_.state.packing_fraction():.4f}", refresh=False)

            contract(sim, mcm["phi"], mcm["increment"], k_n, p["force_tol"],
                     p["energy_tol"], p["max_relax"], on_step=contracted)
        files.dump(sim)
        drv.update(phase="grow", grow_from=s.step, phi_start=s.packing_fraction())
        files.checkpoint(sim, drv)
        last_ckpt = time.perf_counter()
    # older checkpoints lack the growth's start: they grew from phi_init at step 0
    grow_from = drv.get("grow_from", 0)
    n_grow = grow_from + round(math.log(p["phi_grow"] / drv.get("phi_start", p["phi_init"]))
                               / (s.dimension * p["rate"] * p["dt"]))
    bar = tqdm(total=n_grow - grow_from, initial=min(s.step, n_grow) - grow_from,
               disable=not progress, unit="step", mininterval=1.0, desc="pysim growth",
               dynamic_ncols=True)

    def d_now():
        return float(np.mean(2 * s.radius))

    # no relaxation block: minimise (cases without it keep their hash and checkpoints)
    relax_cycle = _relax_md if p.get("relaxation", {}).get("method") == "md" else _relax

    def record(e, jammed, iterations, residual, settled):
        th = sim.thermo()
        files.thermo(th.row())
        files.dump(sim)
        files.write("cycles.dat", f"{s.step} {th.phi:.12g} {e:.6g} {th.pressure:.10g} "
                                  f"{th.n_contacts} {int(jammed)} {iterations} {residual:.4g} "
                                  f"{int(settled)}\n")
        bar.set_postfix(phi=f"{th.phi:.5f}", e=f"{e:.2g}", jammed=int(jammed), refresh=False)

    with files.guard(bar):
        if drv["phase"] == "grow":
            if s.step == 0:
                files.dump(sim)
            while s.step < n_grow:
                nxt = min(n_grow, (s.step // thermo_every + 1) * thermo_every,
                          (s.step // dump_every + 1) * dump_every)
                before = s.step
                sim.run(nxt - s.step, growth_rate=p["rate"])
                bar.update(s.step - before)
                if s.step % thermo_every == 0:
                    files.thermo(sim.thermo().row())
                if s.step % dump_every == 0:
                    files.dump(sim)
                if time.perf_counter() - last_ckpt > checkpoint_every:
                    files.checkpoint(sim, drv)
                    last_ckpt = time.perf_counter()
            drv["phase"] = "cycles"
            e, jammed, it, res, settled = relax_cycle(sim, p, k_n, d_now())
            record(e, jammed, it, res, settled)
            phi = s.packing_fraction()
            if jammed:
                drv["hi"] = phi
            else:
                drv["lo"] = phi
                checkpoint.save(sim, lo_path)
            files.checkpoint(sim, drv)
        while drv["lo"] is None or drv["hi"] is None or drv["hi"] - drv["lo"] >= p["tolerance"]:
            phi = s.packing_fraction()
            if drv["hi"] is None:  # unjammed so far: grow by the increment
                target = phi + drv["increment"]
                if target > p["phi_max"]:
                    raise GrowthLimitError(
                        f"growth reached phi = {phi:.4f} without jamming and the next "
                        f"increment passes protocol.phi_max = {p['phi_max']}; "
                        f"raise phi_max (the box must then hold more particles)")
            elif drv["lo"] is None:  # jammed from the start: shrink by the increment
                target = phi - drv["increment"]
            else:  # bisect from the relaxed unjammed packing
                target = 0.5 * (drv["lo"] + drv["hi"])
                step, t = s.step, s.time
                sim, _ = checkpoint.load(lo_path)
                s = sim.state
                s.step, s.time = step, t
                phi = s.packing_fraction()
            sim.rescale_particles((target / phi) ** (1.0 / s.dimension))
            e, jammed, it, res, settled = relax_cycle(sim, p, k_n, d_now())
            record(e, jammed, it, res, settled)
            phi = s.packing_fraction()
            if jammed:
                drv["hi"] = phi if drv["hi"] is None else min(drv["hi"], phi)
            else:
                drv["lo"] = phi if drv["lo"] is None else max(drv["lo"], phi)
                checkpoint.save(sim, lo_path)
            files.checkpoint(sim, drv)
    files.finalize()
    lo_path.unlink(missing_ok=True)
    wall = time.perf_counter() - t0
    return {"steps": s.step, "wall_seconds": wall, "phi_j": drv["hi"], "phi_j_low": drv["lo"],
            "resumed": bool(resume), "neighbor_rebuilds": sim.rebuilds}
