"""Closed-form results the measurements are compared with (science.md sections 1, 5).

Aspect ratio ``alpha = L / D`` everywhere; lengths in units of your choice (functions
taking ``D`` default to ``D = 1``).

* :func:`volume`, :func:`area_2d` - particle volume ``pi D^2 L/4 + pi D^3/6`` and
  2-D area ``2 L R + pi R^2``;
* :func:`excluded_volume` - Onsager's orientationally averaged excluded volume of two
  equal spherocylinders ``4/3 pi D^3 + 2 pi L D^2 + pi/2 D L^2``;
* :func:`rce_packing_fraction`, :func:`rce_contact_number` - the random contact
  equation ``phi = <C> V / V_excl`` and its inverse; :func:`thin_rod_limit`
  ``phi alpha = <C>/2``;
* :func:`aligned_phi_max` - densest packing of aligned spherocylinders
  ``pi/6 (3 alpha + 2) / (sqrt(3) alpha + sqrt(2))``;
* :func:`degrees_of_freedom`, :func:`isostatic_z` - ``z_iso = 2 d_f``: 3-D spheres 6,
  3-D rods 10, 2-D rods 6, 2-D disks 4;
* :func:`alpha_from` - conversions of the studies' aspect-ratio conventions.
"""
from __future__ import annotations

import numpy as np


def _alpha(alpha):
    a = np.asarray(alpha, dtype=np.float64)
    if np.any(a < 0):
        raise ValueError(f"aspect ratio alpha = L/D must be >= 0, got {alpha}")
    return a


def volume(alpha, diameter=1.0):
    """Spherocylinder volume ``V = pi D^2 L/4 + pi D^3/6`` with ``L = alpha D``."""
    a = _alpha(alpha)
    d = np.asarray(diameter, dtype=np.float64)
    return np.pi * d**3 * a / 4.0 + np.pi * d**3 / 6.0


def area_2d(alpha, diameter=1.0):
    """2-D spherocylinder (stadium) area ``A_p = 2 L R + pi R^2`` with ``L = alpha D``."""
    a = _alpha(alpha)
    r = 0.5 * np.asarray(diameter, dtype=np.float64)
    return 2.0 * a * 2 * r * r + np.pi * r**2


def excluded_volume(alpha, diameter=1.0):
    """Onsager's orientationally averaged excluded volume of two equal spherocylinders,
    ``V_excl = 4/3 pi D^3 + 2 pi L D^2 + pi/2 D L^2`` (spheres: ``8 V``)."""
    a = _alpha(alpha)
    d = np.asarray(diameter, dtype=np.float64)
    ln = a * d
    return 4.0 / 3.0 * np.pi * d**3 + 2.0 * np.pi * ln * d**2 + 0.5 * np.pi * d * ln**2


def rce_packing_fraction(contact_number, alpha):
    """Random contact equation ``phi = <C> V / V_excl`` (independent of ``D``)."""
    return np.asarray(contact_number, dtype=np.float64) * volume(alpha) / excluded_volume(alpha)


def rce_contact_number(phi, alpha):
    """Inverse of the random contact equation: ``<C> = phi V_excl / V``."""
    return np.asarray(phi, dtype=np.float64) * excluded_volume(alpha) / volume(alpha)


def thin_rod_limit(contact_number, alpha):
    """Packing fraction of the thin-rod limit of the random contact equation,
    ``phi = <C> / (2 alpha)`` (``phi alpha = <C>/2``), for ``alpha > 0``."""
    a = _alpha(alpha)
    if np.any(a == 0):
        raise ValueError("the thin-rod limit needs alpha > 0")
    return np.asarray(contact_number, dtype=np.float64) / (2.0 * a)


def aligned_phi_max(alpha):
    """Densest packing of aligned spherocylinders
    ``phi_max = pi/6 (3 alpha + 2) / (sqrt(3) alpha + sqrt(2))`` (FCC ``pi/(3 sqrt 2)``
    at ``alpha = 0``; 0.8787 at ``alpha = 4``)."""
    a = _alpha(alpha)
    return np.pi / 6.0 * (3.0 * a + 2.0) / (np.sqrt(3.0) * a + np.sqrt(2.0))


def degrees_of_freedom(dim: int, rod: bool) -> int:
    """Degrees of freedom ``d_f`` a frictionless contact network must block per particle:
    3-D spheres 3, 3-D rods 5 (no rotation about the spine), 2-D disks 2, 2-D rods 3."""
    table = {(3, False): 3, (3, True): 5, (2, False): 2, (2, True): 3}
    if (dim, bool(rod)) not in table:
        raise ValueError(f"dim must be 2 or 3, got {dim}")
    return table[(dim, bool(rod))]


def isostatic_z(dim: int, rod: bool) -> int:
    """Isostatic contact number ``z_iso = 2 d_f`` (frictionless): 3-D spheres 6, 3-D
    rods 10, 2-D rods 6, 2-D disks 4."""
    return 2 * degrees_of_freedom(dim, rod)


def alpha_from(value, convention: str):
    """Aspect ratio ``alpha = L/D`` from the studies' conventions: ``"A/R"`` (2-D
    jamming; half-length over radius: the same number), ``"lambda/delta"`` (tapping:
    the same number), ``"d"`` (cohesive deposits: total length over width,
    ``d = 1 + L/D``)."""
    v = np.asarray(value, dtype=np.float64)
    if convention in ("A/R", "lambda/delta", "L/D"):
        return v
    if convention == "d":
        if np.any(v < 1):
            raise ValueError(f"total length over width d must be >= 1, got {value}")
        return v - 1.0
    raise ValueError(f"unknown convention {convention!r}; valid: 'L/D', 'A/R', "
                     "'lambda/delta', 'd'")


def phi_max_aligned(alpha):
    """Densest packing of equal spherocylinders (aligned, hexagonal layers stacked so
    that the caps nest as in fcc): ``phi_max = (pi/6 + pi alpha/4) / (sqrt(3)/2 (alpha +
    sqrt(2/3)))``; ``pi / sqrt(18)`` for spheres, ``pi / sqrt(12)`` for infinitely long
    rods."""
    a = _alpha(alpha)
    return (np.pi / 6 + np.pi * a / 4) / (np.sqrt(3) / 2 * (a + np.sqrt(2.0 / 3.0)))
