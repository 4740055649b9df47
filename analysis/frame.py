"""The data model every observable works on, whoever produced the files.

* :class:`Frame`    particles of one output step (positions, radii, axes, box);
* :class:`Contacts` the contact table of the same step (pairs, points, normals,
  overlaps, forces on the first particle).

Both are plain arrays; all analysis functions take these or the arrays themselves.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

FORMAT_VERSION = 1


@dataclass
class Frame:
    """Particles at one step. Arrays are sorted by ``ids``.

    * ``ids`` (N,) int particle ids (as in the dump); ``types`` (N,) int
    * ``x`` (N, 3) centre positions; ``radius`` (N,) radii ``R``
    * ``axis`` (N, 3) unit spine directions (``+z`` for spheres); ``length`` (N,) ``L``
    * ``box_lo`` (3,), ``box`` (3,) edge lengths; ``periodic`` (3,) bool
    """

    step: int
    ids: np.ndarray
    types: np.ndarray
    x: np.ndarray
    radius: np.ndarray
    axis: np.ndarray
    length: np.ndarray
    box_lo: np.ndarray
    box: np.ndarray
    periodic: np.ndarray

    @property
    def n(self) -> int:
        return len(self.ids)

    @property
    def volume(self) -> float:
        """Box volume (length^3)."""
        return float(np.prod(self.box))

    def particle_volumes(self) -> np.ndarray:
        """Spherocylinder volumes ``V = pi D^2 L/4 + pi D^3/6`` (science.md section 1)."""
        d = 2.0 * self.radius
        return np.pi * d**2 * self.length / 4.0 + np.pi * d**3 / 6.0

    def index_of(self, ids) -> np.ndarray:
        """Row indices of the given particle ids (raises KeyError for unknown ids)."""
        ids = np.asarray(ids, dtype=np.int64)
        pos = np.searchsorted(self.ids, ids)
        pos = np.clip(pos, 0, len(self.ids) - 1)
        bad = self.ids[pos] != ids
        if np.any(bad):
            raise KeyError(f"particle ids {ids[bad][:5].tolist()} are not in frame {self.step}")
        return pos


@dataclass
class Contacts:
    """Contacts at one step; ``i``, ``j`` are particle ids.

    * ``point`` (C, 3) contact points; ``normal`` (C, 3) unit normals from i to j
    * ``overlap`` (C,) ``delta``; ``force`` (C, 3) contact force on i (on j: ``-force``)
    """

    step: int
    i: np.ndarray
    j: np.ndarray
    point: np.ndarray
    normal: np.ndarray
    overlap: np.ndarray
    force: np.ndarray

    @property
    def n(self) -> int:
        return len(self.i)

    @classmethod
    def empty(cls, step: int = 0) -> "Contacts":
        z = np.zeros((0, 3))
        return cls(step, np.zeros(0, np.int64), np.zeros(0, np.int64), z, z.copy(),
                   np.zeros(0), z.copy())
