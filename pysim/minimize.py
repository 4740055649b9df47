"""Energy minimisation by L-BFGS (scipy) at fixed box, for frictionless pair contacts.

FIRE (:func:`pysim.integrators.fire_chunk`) is robust far from a minimum but crawls on
the ill-conditioned energy landscape of a packing at jamming, where L-BFGS brings the
residual forces far lower in far fewer iterations (docs/performance.md). :func:`lbfgs`
minimises the elastic energy ``U`` (the ``pe`` of :func:`pysim.integrators.forces`) over
the positions and the spine directions.

Coordinates: the centres ``x_i`` and, for rods (``L > 0``), a free vector ``w_i`` with
``u_i = w_i/|w_i|``, scaled by the half-length ``l_i = L_i/2`` so that both parts
have units of length and a unit step of either moves the spine's ends by about the same
distance. (Scaled by ``max(L_i/2, R_i)``, the stiffness of a rotation, ``~ k (L/2)^2``, fell
below that of a translation by ``(L/2R)^2``, 1e-4 at alpha 0.01, and packings of such
rods crept instead of relaxing: docs/performance.md.) All coordinates
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
from pysim.jit import njit
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
    if sim.n_walls or np.any(sim.params["gravity"] != 0.0):
        raise ValueError("L-BFGS minimises the pair-contact energy only: this simulation has "
                         "walls or gravity; use FIRE")
    if f_tol <= 0 or max_iter < 1:
        raise ValueError(f"f_tol = {f_tol} and max_iter = {max_iter} must be positive")
    dim = s.dimension
    n = s.n
    rods = np.flatnonzero(sim.half > 0.0)
    scale = sim.half[rods][:, None]
    scale_r = np.ascontiguousarray(scale[:, 0])
    nx = n * dim
    saved = sim.params.copy()
    for name in FREE_PARAMS:
        sim.params[name] = 0.0
    s.v[:] = 0.0
    s.omega[:] = 0.0
    last = {"z": None, "fmax": np.inf, "tmax": np.inf}

    w_norm = np.empty(len(rods))  # |w_k| of the rods' free vectors

    def energy(zs):
        set_coordinates(zs, h, s.x, s.u, rods, scale_r, dim, s.box, s.periodic, w_norm)
        sim._set_pairs(itg.maybe_rebuild(s.x, s.u, s.box, s.periodic, sim.r_int, sim.half,
                                         sim.params, sim.cache, sim._pairs(), sim._ref())[0])
        sim.compute_forces()
        grad = np.empty_like(zs)
        fmax, tmax = gradient(sim.f, sim.torque, s.u, rods, w_norm, scale_r, dim, grad)
        last.update(z=zs.copy(), fmax=fmax, tmax=tmax, grad_norm=float(np.linalg.norm(grad)))
        grad *= c * h
        return c * sim._pe, grad

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
        for name in FREE_PARAMS:
            sim.params[name] = saved[name]
        s.v[:] = 0.0
        s.omega[:] = 0.0
    sim._check("L-BFGS")
    return iterations, last["fmax"], last["tmax"]


#: the parameters that L-BFGS sets to zero while it runs (they would add forces without an
#: energy) and restores after
FREE_PARAMS = ("gamma_bg", "gamma_rot", "strain_rate", "growth")

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


@njit
def set_coordinates(zs, h, x, u, rods, scale, dim, box, periodic, norm):
    """Positions and spine directions from L-BFGS' coordinates ``zs`` (in units of ``h``):
    ``x_i = h z`` (wrapped into the box) and, for rod ``k`` (particle ``rods[k]``),
    ``w = h z / l_k``, ``u = w / |w|`` (out-of-plane components 0 in 2-D); ``norm[k]``
    receives ``|w|``. The same arithmetic, in the same order, as NumPy's vector forms."""
    n = x.shape[0]
    nx = n * dim
    for i in range(n):
        for k in range(dim):
            x[i, k] = h * zs[i * dim + k]
    itg.wrap(x, box, periodic)
    w = np.empty(3)
    for r in range(rods.shape[0]):
        s2 = 0.0
        for k in range(dim):
            w[k] = h * zs[nx + r * dim + k] / scale[r]
            s2 += w[k] * w[k]
        nr = np.sqrt(s2)
        norm[r] = nr
        i = rods[r]
        for k in range(dim):
            u[i, k] = w[k] / nr
        for k in range(dim, 3):
            u[i, k] = 0.0


@njit
def gradient(f, torque, u, rods, norm, scale, dim, grad):
    """``grad`` of the energy in L-BFGS' coordinates before their scaling: ``-F_i`` for the
    centres and ``(u x tau) / (|w| l)`` for the rods' free vectors (module docstring).
    Returns ``(max |F|, max |tau|)`` over all particles."""
    n = f.shape[0]
    nx = n * dim
    fmax = 0.0
    tmax = 0.0
    for i in range(n):
        for k in range(dim):
            grad[i * dim + k] = -f[i, k]
        fmax = max(fmax, f[i, 0] * f[i, 0] + f[i, 1] * f[i, 1] + f[i, 2] * f[i, 2])
        tmax = max(tmax, torque[i, 0] * torque[i, 0] + torque[i, 1] * torque[i, 1]
                   + torque[i, 2] * torque[i, 2])
    c = np.empty(3)
    for r in range(rods.shape[0]):
        i = rods[r]
        c[0] = u[i, 1] * torque[i, 2] - u[i, 2] * torque[i, 1]
        c[1] = u[i, 2] * torque[i, 0] - u[i, 0] * torque[i, 2]
        c[2] = u[i, 0] * torque[i, 1] - u[i, 1] * torque[i, 0]
        for k in range(dim):
            grad[nx + r * dim + k] = c[k] / norm[r] / scale[r]
    return np.sqrt(fmax), np.sqrt(tmax)
