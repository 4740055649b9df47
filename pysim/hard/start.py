"""The start of a hard-sphere run: nominal diameters of mean 1 in a periodic cube, at
Poisson positions (independent uniform centres, overlapping: Baranau & Tallarek 2014,
Sec. I, "each packing is created from an individual Poisson configuration of points"),
and thermal velocities.

The box has side ``L = (sum pi D_i^nom^3 / 6 / phi_nominal)^(1/3)``: ``phi_nominal`` is
the packing fraction at which the diameters equal their nominal values (``r = 1``).
The paper does not give it; it sets the length in which the compression rate ``gamma =
dr/dt`` is counted (with ``phi_nominal`` near the final density, ``gamma`` is the growth
speed of a diameter in units of its final size).
"""
from __future__ import annotations

import numpy as np


def box_side(dn, phi_nominal: float) -> float:
    """Side of the cube in which the nominal diameters ``dn`` fill ``phi_nominal``."""
    return float((np.sum(np.pi / 6.0 * np.asarray(dn) ** 3) / phi_nominal) ** (1.0 / 3.0))


def poisson(n: int, side: float, rng) -> np.ndarray:
    """``n`` independent uniform points in ``[0, side)^3``."""
    return rng.uniform(0.0, side, size=(n, 3))


def velocity_rng(seed: int):
    """The generator of a run's initial velocities: its own stream of the case's seed,
    apart from the one the start's diameters and positions come from."""
    return np.random.default_rng([int(seed), 1])
