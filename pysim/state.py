"""Particle state of a pysim run.

Units are whatever the case uses consistently (the quick profiles use particle
diameter ``D = 1``, density ``rho = 1`` and spring stiffness ``k_n``); pysim never
converts units.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np


def sphere_mass(radius: np.ndarray, density: float) -> np.ndarray:
    """Mass of solid spheres, ``m = rho * 4/3 pi R^3`` (mass units)."""
    radius = np.asarray(radius, dtype=np.float64)
    return density * 4.0 / 3.0 * np.pi * radius**3


@dataclass
class State:
    """Dynamical state of N particles in an orthorhombic box ``[0, box)``.

    Arrays (float64, C-contiguous):

    * ``x``      (N, 3) positions of the particle centres, wrapped into the box on
      periodic axes (length units). 2-D runs keep ``z = 0``.
    * ``v``      (N, 3) translational velocities (length / time).
    * ``omega``  (N, 3) angular velocities (1 / time).
    * ``radius`` (N,)   radii ``R`` (length).
    * ``length`` (N,)   spine lengths ``L`` (0 for spheres).
    * ``mass``   (N,)   masses.
    * ``box``    (3,)   box edge lengths; the box spans ``[0, box[k])``.
    * ``periodic`` (3,) bool, periodic axes.

    ``step`` and ``time`` count integration steps and simulated time since the start
    of the run.
    """

    x: np.ndarray
    v: np.ndarray
    omega: np.ndarray
    radius: np.ndarray
    length: np.ndarray
    mass: np.ndarray
    box: np.ndarray
    periodic: np.ndarray = field(default_factory=lambda: np.ones(3, dtype=np.bool_))
    step: int = 0
    time: float = 0.0

    @classmethod
    def spheres(cls, x, radius, box, density=1.0, v=None, periodic=(True, True, True)):
        """Build a state of spheres at rest (unless ``v`` is given)."""
        x = np.ascontiguousarray(x, dtype=np.float64)
        n = x.shape[0]
        if x.ndim != 2 or x.shape[1] != 3:
            raise ValueError(f"positions must have shape (N, 3), got {x.shape}")
        radius = np.ascontiguousarray(np.broadcast_to(radius, (n,)), dtype=np.float64)
        if np.any(radius <= 0):
            raise ValueError(f"radii must be > 0, got min {radius.min()}")
        box = np.ascontiguousarray(box, dtype=np.float64).reshape(3)
        v = np.zeros((n, 3)) if v is None else np.ascontiguousarray(v, dtype=np.float64)
        return cls(
            x=x,
            v=v,
            omega=np.zeros((n, 3)),
            radius=radius,
            length=np.zeros(n),
            mass=sphere_mass(radius, density),
            box=box,
            periodic=np.asarray(periodic, dtype=np.bool_),
        )

    @property
    def n(self) -> int:
        """Number of particles."""
        return self.x.shape[0]

    def volume(self) -> float:
        """Box volume (length^3)."""
        return float(np.prod(self.box))

    def particle_volume(self) -> float:
        """Total particle volume, spherocylinders ``pi R^2 L + 4/3 pi R^3`` (length^3)."""
        r, l = self.radius, self.length
        return float(np.sum(np.pi * r**2 * l + 4.0 / 3.0 * np.pi * r**3))

    def packing_fraction(self) -> float:
        """Global packing fraction ``phi = sum V_i / V_box``."""
        return self.particle_volume() / self.volume()

    def kinetic_energy(self) -> float:
        """Translational plus rotational kinetic energy of spheres (energy units).

        Uses the solid-sphere moment ``I = 2/5 m R^2``.
        """
        ke_t = 0.5 * np.sum(self.mass * np.sum(self.v**2, axis=1))
        inertia = 0.4 * self.mass * self.radius**2
        ke_r = 0.5 * np.sum(inertia * np.sum(self.omega**2, axis=1))
        return float(ke_t + ke_r)
