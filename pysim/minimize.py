"""Energy minimisation by L-BFGS (scipy) at fixed box, for frictionless pair contacts.

FIRE (:func:`pysim.integrators.fire_chunk`) is robust far from a minimum but crawls on
the ill-conditioned energy landscape of a packing at jamming: on a 2-D packing of 1024
rods (alpha 3) it left a residual force of 85 % of the mean contact force after 200 000
iterations, which L-BFGS brought below 0.1 % in 3000. :func:`lbfgs` minimises the
elastic energy ``U`` (the ``pe`` of :func:`pysim.integrators.forces`) over the positions
and the spine directions.

Coordinates: the centres ``x_i`` and, for rods (``L > 0``), a free vector ``w_i`` with
``u_i = w_i/|w_i|``, scaled by the half-length ``l_i = L_i/2`` so that both parts
have units of length and a unit step of either moves the spine's ends by about the same
distance. (Scaled by ``max(L_i/2, R_i)``, the stiffness of a rotation, ``~ k (L/2)^2``, fell
below that of a translation by ``(L/2R)^2``: 1e-4 at alpha 0.01, where a jammed-looking
2-D packing of 256 rods lost 1 % of its energy per 2000 iterations for 80 000 iterations;
scaled by ``L/2`` it unjammed in 10 000.) All coordinates
are then divided by the length ``h`` of the first move, which L-BFGS makes one unit of
its coordinates long, and the energy by a constant; the choices of
:data:`FIRST_MOVES` are tried in turn while the line search gives up at once: near
jamming it gives up with one choice on some packings and with another on others
(measured, not understood), and a line search that gave up looked like a minimum to
the relaxation (:func:`pysim.protocols.jammed.relax`).

The gradient is exact: ``dU/dx_i = -F_i`` and, from
``tau = -u x dU/du``, ``dU/dw_i = (u_i x tau_i)/|w_i|``. In 2-D only the in-plane
components move. Pair lists are kept as in a run (:func:`pysim.integrators.maybe_rebuild`).
"""
from __future__ import annotations

import numpy as np
from scipy.optimize import minimize

from pysim import integrators as itg
from pysim.rotation import quaternions_from_axes


def lbfgs(sim, f_tol: float, max_iter: int = 10_000, memory: int = 10):
    """Minimise the elastic energy of ``sim`` at fixed box by L-BFGS until every force and
    torque is below ``f_tol`` in magnitude (the rule of FIRE), or ``max_iter`` iterations,
    or until L-BFGS can make no further progress: its line search compares energies, so
    it cannot resolve forces much below ``sqrt(eps k_n U)`` (``eps`` = 2.2e-16; 1e-12 for
    a packing at ``U`` = 1e-8, where FIRE, which uses forces alone, goes on). Only pair
    contacts without friction, walls or body forces have an energy to minimise.
    Velocities are zeroed. Returns ``(iterations, max |F|, max |tau|)`` of the final state,
    whose forces ``sim.f``, ``sim.torque`` and energy are up to date."""
    s = sim.state
    if sim.model.friction or sim.model.f_coh > 0:
        raise ValueError(f"L-BFGS minimises the elastic energy: friction (mu = {sim.model.mu}) "
                         f"and cohesion (f_coh = {sim.model.f_coh}) must be 0; use FIRE")
    if sim.n_walls or np.any(sim.sys[itg.GX:itg.GZ + 1] != 0.0):
        raise ValueError("L-BFGS minimises the pair-contact energy only: this simulation has "
                         "walls or gravity; use FIRE")
    if f_tol <= 0 or max_iter < 1:
        raise ValueError(f"f_tol = {f_tol} and max_iter = {max_iter} must be positive")
    dim = s.dimension
    n = s.n
    rods = np.flatnonzero(sim.half > 0.0)
    scale = sim.half[rods][:, None]
    nx = n * dim
    free = (itg.GAMMA_BG, itg.GAMMA_ROT, *range(itg.EPS_X, itg.GROWTH + 1))
    saved = sim.sys[list(free)].copy()
    sim.sys[list(free)] = 0.0
    s.v[:] = 0.0
    s.omega[:] = 0.0
    last = {"z": None, "fmax": np.inf, "tmax": np.inf}

    def energy(zs):
        z = h * zs  # lengths
        s.x[:, :dim] = z[:nx].reshape(n, dim)
        itg.wrap(s.x, s.box, s.periodic)
        w = z[nx:].reshape(len(rods), dim) / scale
        norm = np.linalg.norm(w, axis=1)
        if len(rods):
            s.u[rods, :dim] = w / norm[:, None]
            s.u[rods, dim:] = 0.0  # 2-D: spines exactly in the plane
        sim._set_pairs(itg.maybe_rebuild(s.x, s.u, s.box, s.periodic, sim.r_int, sim.half,
                                         sim.sys, *sim._pairs(), sim.x_ref, sim.u_ref,
                                         sim.box_ref)[:7])
        sim.compute_forces()
        last.update(z=zs.copy(), fmax=float(np.sqrt(np.max(np.sum(sim.f**2, axis=1)))),
                    tmax=float(np.sqrt(np.max(np.sum(sim.torque**2, axis=1)))))
        grad = np.empty_like(z)
        grad[:nx] = -sim.f[:, :dim].ravel()
        if len(rods):
            gw = np.cross(s.u[rods], sim.torque[rods]) / norm[:, None]
            grad[nx:] = (gw[:, :dim] / scale).ravel()
        last["grad_norm"] = float(np.linalg.norm(grad))
        return c * sim._pe, (c * h) * grad

    def at(z):
        if last["z"] is None or not np.array_equal(z, last["z"]):
            energy(z)
        return last["fmax"] < f_tol and last["tmax"] < f_tol

    def stop(z):
        if at(z):
            raise StopIteration

    y = np.concatenate([s.x[:, :dim].ravel(), (s.u[rods, :dim] * scale).ravel()])
    h = 1.0
    c = 1.0
    iterations = 0
    try:
        if not at(y):
            overlap = _mean_overlap(sim)
            norm = last["grad_norm"]  # of the energy in lengths, from at(y)
            for move in FIRST_MOVES:
                # one unit of length, the energy scaled to unit gradient per mean overlap;
                # or a move of some mean overlap, the energy as it is
                h = 1.0 if move is None else move * overlap
                c = 1.0 / (norm * overlap) if move is None and norm > 0 else 1.0
                last["z"] = None
                res = minimize(energy, y / h, jac=True, method="L-BFGS-B", callback=stop,
                               options=dict(maxiter=int(max_iter) - iterations,
                                            maxfun=10 * int(max_iter), maxcor=int(memory),
                                            gtol=0.0, ftol=0.0))
                iterations += int(res.nit)
                done = at(res.x)
                y = h * res.x
                if done or res.nit >= GAVE_UP or iterations >= max_iter:
                    break
    finally:
        if len(rods):  # forces need the spines only; the quaternions follow them once
            s.q[rods] = quaternions_from_axes(s.u[rods])
        sim.sys[list(free)] = saved
        s.v[:] = 0.0
        s.omega[:] = 0.0
    sim._check("L-BFGS")
    return iterations, last["fmax"], last["tmax"]


#: L-BFGS' first moves tried in turn while its line search gives up within
#: :data:`GAVE_UP` iterations: one unit of length with the energy scaled to a gradient of
#: one over the mean overlap (``None``), then 1 and 1e-3 of the mean overlap with the
#: energy as it is (near jamming some packings need the first, others a later one)
FIRST_MOVES = (None, 1.0, 1e-3)
#: L-BFGS runs of fewer iterations than this (without reaching ``f_tol``) gave up
GAVE_UP = 10


def _mean_overlap(sim) -> float:
    """Mean overlap of the touching contacts (1 when nothing overlaps)."""
    _, rec = sim.contact_table()
    touching = rec[:, 6] > 0.0
    return float(rec[touching, 6].mean()) if touching.any() else 1.0
