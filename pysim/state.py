"""Particle state of a pysim run, and the mass properties of spherocylinders.

Units are whatever the case uses consistently (the quick profiles use particle
diameter ``D = 1``, density ``rho = 1``); pysim never converts units. Symbols follow
science.md: radius ``R``, diameter ``D = 2R``, spine length ``L``, aspect ratio
``alpha = L/D``.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from pysim.rotation import axes, quaternions_from_axes


# -- mass properties ------------------------------------------------------------------------
def volume(radius, length) -> np.ndarray:
    """Spherocylinder volume ``V = pi D^2 L/4 + pi D^3/6`` (length^3)."""
    d = 2.0 * np.asarray(radius, dtype=np.float64)
    return np.pi * d**2 * np.asarray(length) / 4.0 + np.pi * d**3 / 6.0


def area(radius, length) -> np.ndarray:
    """2-D spherocylinder (stadium) area ``A_p = 2 L R + pi R^2`` (length^2)."""
    r = np.asarray(radius, dtype=np.float64)
    return 2.0 * np.asarray(length) * r + np.pi * r**2


def inertia_3d(radius, length, density):
    """Principal moments ``(I_perp, I_axis)`` of solid spherocylinders (science.md):
    ``I_perp = pi rho (D^2 L^3/48 + 3 D^4 L/64 + D^5/60 + D^3 L^2/24)``,
    ``I_axis = pi rho (D^4 L/32 + D^5/60)``."""
    d = 2.0 * np.asarray(radius, dtype=np.float64)
    l = np.asarray(length, dtype=np.float64)
    i_perp = np.pi * density * (d**2 * l**3 / 48 + 3 * d**4 * l / 64 + d**5 / 60 + d**3 * l**2 / 24)
    i_axis = np.pi * density * (d**4 * l / 32 + d**5 / 60)
    return i_perp, i_axis


def inertia_2d(radius, length, density):
    """Moment about the normal of a 2-D spherocylinder of areal density ``rho``:
    ``I = m R^2 (3 pi + 24 a + 6 pi a^2 + 8 a^3) / (6 pi + 24 a)``, ``a = A/R = L/(2R)``."""
    r = np.asarray(radius, dtype=np.float64)
    a = np.asarray(length, dtype=np.float64) / (2.0 * r)
    m = density * area(radius, length)
    return m * r**2 * (3 * np.pi + 24 * a + 6 * np.pi * a**2 + 8 * a**3) / (6 * np.pi + 24 * a)


def sphere_mass(radius: np.ndarray, density: float) -> np.ndarray:
    """Mass of solid spheres, ``m = rho * 4/3 pi R^3`` (mass units)."""
    return density * volume(radius, 0.0)


@dataclass
class State:
    """Dynamical state of N spherocylinders in an orthorhombic box ``[0, box)``.

    Arrays (float64, C-contiguous):

    * ``x``      (N, 3) centre positions, wrapped into the box on periodic axes (length).
      2-D runs keep ``z = 0`` and every spine in the x-y plane.
    * ``v``      (N, 3) translational velocities (length / time).
    * ``q``      (N, 4) unit quaternions ``(w, x, y, z)``, body to lab; the spine is the
      body z axis.
    * ``u``      (N, 3) spine directions ``R(q) e_z`` (kept in step with ``q``).
    * ``omega``  (N, 3) angular velocities in the lab frame (1 / time).
    * ``radius`` (N,) ``R``; ``length`` (N,) spine length ``L`` (0 for spheres).
    * ``mass``   (N,); ``inertia`` (N, 2) principal moments ``(I_perp, I_axis)``.
    * ``box``    (3,) edge lengths; ``periodic`` (3,) bool.

    ``dimension`` is 2 or 3. ``step`` and ``time`` count from the start of the run.
    """

    x: np.ndarray
    v: np.ndarray
    q: np.ndarray
    u: np.ndarray
    omega: np.ndarray
    radius: np.ndarray
    length: np.ndarray
    mass: np.ndarray
    inertia: np.ndarray
    box: np.ndarray
    periodic: np.ndarray = field(default_factory=lambda: np.ones(3, dtype=np.bool_))
    dimension: int = 3
    density: float = 1.0
    step: int = 0
    time: float = 0.0

    @classmethod
    def create(cls, x, radius, length, box, axis=None, density=1.0, v=None, omega=None,
               periodic=(True, True, True), dimension=3):
        """Build a state; ``axis`` (N, 3) spine directions (default ``+z``, or ``+x`` in
        2-D). Masses and inertia follow from ``density`` (per area in 2-D)."""
        x = np.ascontiguousarray(x, dtype=np.float64)
        if x.ndim != 2 or x.shape[1] != 3:
            raise ValueError(f"positions must have shape (N, 3), got {x.shape}")
        n = x.shape[0]
        if dimension not in (2, 3):
            raise ValueError(f"dimension must be 2 or 3, got {dimension}")
        radius = np.ascontiguousarray(np.broadcast_to(radius, (n,)), dtype=np.float64)
        length = np.ascontiguousarray(np.broadcast_to(length, (n,)), dtype=np.float64)
        if np.any(radius <= 0):
            raise ValueError(f"radii must be > 0, got min {radius.min()}")
        if np.any(length < 0):
            raise ValueError(f"spine lengths must be >= 0, got min {length.min()}")
        if not density > 0:
            raise ValueError(f"density must be > 0, got {density}")
        if axis is None:
            axis = np.tile([1.0, 0.0, 0.0] if dimension == 2 else [0.0, 0.0, 1.0], (n, 1))
        axis = np.asarray(axis, dtype=np.float64)
        if dimension == 2:
            if np.any(x[:, 2] != 0) or np.any(axis[:, 2] != 0):
                raise ValueError("2-D states need z = 0 and spines in the x-y plane")
            m = density * area(radius, length)
            ip = inertia_2d(radius, length, density)
            inertia = np.column_stack([ip, ip])
        else:
            m = density * volume(radius, length)
            inertia = np.column_stack(inertia_3d(radius, length, density))
        q = np.ascontiguousarray(quaternions_from_axes(axis))
        u = np.empty((n, 3))
        axes(q, u)
        v = np.zeros((n, 3)) if v is None else np.ascontiguousarray(v, dtype=np.float64).copy()
        omega = np.zeros((n, 3)) if omega is None else np.ascontiguousarray(omega, dtype=np.float64).copy()
        box = np.ascontiguousarray(box, dtype=np.float64).reshape(3).copy()
        return cls(x=x.copy(), v=v, q=q, u=u, omega=omega, radius=radius.copy(),
                   length=length.copy(), mass=np.ascontiguousarray(m), inertia=inertia,
                   box=box, periodic=np.asarray(periodic, dtype=np.bool_).copy(),
                   dimension=dimension, density=float(density))

    @classmethod
    def spheres(cls, x, radius, box, density=1.0, v=None, periodic=(True, True, True)):
        """Build a 3-D state of spheres (``L = 0``)."""
        n = np.asarray(x).shape[0]
        return cls.create(x, radius, np.zeros(n), box, density=density, v=v, periodic=periodic)

    @property
    def n(self) -> int:
        """Number of particles."""
        return self.x.shape[0]

    def volume(self) -> float:
        """Box volume (length^3), or area in 2-D (length^2)."""
        return float(np.prod(self.box[: self.dimension]))

    def particle_volume(self) -> float:
        """Total particle volume (area in 2-D)."""
        if self.dimension == 2:
            return float(np.sum(area(self.radius, self.length)))
        return float(np.sum(volume(self.radius, self.length)))

    def packing_fraction(self) -> float:
        """Global packing fraction ``phi = sum V_i / V_box``."""
        return self.particle_volume() / self.volume()

    def kinetic_energy(self) -> float:
        """Translational plus rotational kinetic energy ``sum m v^2/2 + omega.I.omega/2``."""
        ke_t = 0.5 * np.sum(self.mass * np.sum(self.v**2, axis=1))
        w_par = np.sum(self.omega * self.u, axis=1)
        w2 = np.sum(self.omega**2, axis=1)
        ke_r = 0.5 * np.sum(self.inertia[:, 0] * (w2 - w_par**2) + self.inertia[:, 1] * w_par**2)
        return float(ke_t + ke_r)

    def momentum(self) -> np.ndarray:
        """Total linear momentum (3,)."""
        return (self.mass[:, None] * self.v).sum(axis=0)

    def angular_momentum(self, x=None) -> np.ndarray:
        """Total angular momentum about the origin, ``sum x × m v + I omega`` (3,);
        pass unwrapped positions ``x`` for a periodic system."""
        x = self.x if x is None else x
        orbital = np.cross(x, self.mass[:, None] * self.v).sum(axis=0)
        w_par = np.sum(self.omega * self.u, axis=1)[:, None] * self.u
        spin = self.inertia[:, :1] * (self.omega - w_par) + self.inertia[:, 1:] * w_par
        return orbital + spin.sum(axis=0)
