"""Mechanical contraction to a packing fraction (the start of Wouterse, Luding and
Philipse's growth runs: "a random sphere gas ... is contracted with the MCM to a volume
fraction of 0.49").

The mechanical contraction method of Williams and Philipse shrinks the periodic box in
small steps and, after each, moves the particles until no two overlap. Here the
particles grow instead of the box shrinking (the same configuration in units of the box),
each step raises the packing fraction by ``increment`` (the last step lands on the
target), and the overlaps are removed by minimising the elastic energy with FIRE and
L-BFGS (:func:`pysim.protocols.jammed.relax`): the particles move down the gradient of
the overlap energy, i.e. apart along the contact normals, until the energy per particle is
below ``energy_tol * k_n D^2`` (overlaps of order ``sqrt(energy_tol) D``). Velocities are
zero at the end. A step whose overlaps cannot be removed means the contraction has
jammed below the target, and the run stops with :class:`ContractionJammedError`.
"""
from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np

from pysim.protocols.jammed import relax
from pysim.simulation import Simulation


class ContractionJammedError(RuntimeError):
    """The overlaps of a contraction step could not be removed before the target."""


def contract(sim: Simulation, phi_to: float, increment: float, k_n: float, f_tol: float,
             energy_tol: float, max_relax: int,
             on_step: Callable[[Simulation, int], None] | None = None) -> int:
    """Contract ``sim`` from its packing fraction to ``phi_to`` in steps of ``increment``
    (packing fraction), removing the overlaps after each step (module docstring).
    ``f_tol`` (force, units of ``k_n D``) stops a relaxation early; ``energy_tol`` is the
    overlap-free criterion, elastic energy per particle in units of ``k_n D^2``.
    ``on_step(sim, iterations)`` is called after every overlap-free step. Returns the
    minimiser iterations spent (they also advance ``sim.state.step``)."""
    s = sim.state
    phi = phi_start = s.packing_fraction()
    if not phi < phi_to < 1:
        raise ValueError(f"contraction target phi = {phi_to} must lie between the start's "
                         f"phi = {phi:.4f} and 1")
    if not increment > 0:
        raise ValueError(f"contraction increment must be > 0, got {increment}")
    total = 0
    n_steps = math.ceil((phi_to - phi) / increment - 1e-9)
    for k in range(1, n_steps + 1):
        # targets from the start, so rounding cannot add a step
        target = phi_to if k == n_steps else phi_start + k * increment
        sim.rescale_particles((target / phi) ** (1.0 / s.dimension))
        d_mean = float(np.mean(2 * s.radius))
        scale = s.n * k_n * d_mean**2

        def overlap_free(t: Simulation) -> bool:
            return t.thermo().pe / scale < energy_tol

        _, _, it = relax(sim, f_tol * k_n * d_mean, max_relax, overlap_free, balance=False)
        s.step += it
        total += int(it)
        if not overlap_free(sim):
            raise ContractionJammedError(
                f"the contraction jammed at phi = {target:.4f}: its overlaps (elastic energy "
                f"{sim.thermo().pe / scale:.3g} k_n D^2 per particle) could not be removed "
                f"before protocol.contraction.phi = {phi_to}; lower it")
        s.v[:] = 0.0
        s.omega[:] = 0.0
        phi = s.packing_fraction()
        if on_step is not None:
            on_step(sim, int(it))
    return total
