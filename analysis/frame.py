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
    * ``dimension`` 2 or 3, or ``None`` (the default) to infer it: a frame is 2-D when
      every centre has ``z = 0`` and every rod's spine lies in the x-y plane (2-D packings
      are stored that way, docs/formats.md); see :attr:`dim`.

    In 2-D the "volume" of a particle is its area ``A_p = 2 L R + pi R^2`` and that of
    the box its x-y area (:meth:`particle_measures`, :attr:`measure`); the vertical
    (gravity) axis is ``z`` in 3-D and ``y`` in 2-D (:attr:`vertical`).
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
    dimension: int | None = None

    @classmethod
    def from_arrays(cls, x, radius, box, axis=None, length=None, periodic=True,
                    box_lo=0.0, ids=None, step=0, dimension=None) -> "Frame":
        """A frame from plain arrays (ids 1..N unless given; spheres unless ``axis`` and
        ``length`` are given; ``radius``, ``length``, ``periodic``, ``box_lo`` broadcast)."""
        x = np.atleast_2d(np.asarray(x, dtype=np.float64))
        n = len(x)
        if x.shape[1] == 2:  # 2-D input: store with z = 0
            x = np.column_stack([x, np.zeros(n)])
            dimension = 2 if dimension is None else dimension
        if axis is None:
            axis = np.tile([0.0, 0.0, 1.0], (n, 1))
        axis = np.atleast_2d(np.asarray(axis, dtype=np.float64))
        if axis.shape[1] == 2:
            axis = np.column_stack([axis, np.zeros(n)])
        axis = np.broadcast_to(axis, (n, 3)).copy()
        norm = np.linalg.norm(axis, axis=1)
        if np.any(norm == 0):
            raise ValueError("axis vectors must be non-zero")
        axis /= norm[:, None]
        box = np.asarray(box, dtype=np.float64)
        if box.shape == (2,):
            box = np.r_[box, 1.0]
        return cls(step=step, ids=np.arange(1, n + 1) if ids is None else np.asarray(ids, np.int64),
                   types=np.ones(n, np.int64), x=x,
                   radius=np.broadcast_to(np.asarray(radius, np.float64), (n,)).copy(),
                   axis=axis, length=np.broadcast_to(np.asarray(0.0 if length is None else length,
                                                                np.float64), (n,)).copy(),
                   box_lo=np.broadcast_to(np.asarray(box_lo, np.float64), (3,)).copy(),
                   box=np.broadcast_to(box, (3,)).copy(),
                   periodic=np.broadcast_to(np.asarray(periodic, bool), (3,)).copy(),
                   dimension=dimension)

    @property
    def n(self) -> int:
        return len(self.ids)

    @property
    def dim(self) -> int:
        """Spatial dimension: ``dimension`` when set, else 2 when all centres have
        ``z = 0`` and all rod spines lie in the x-y plane, else 3."""
        if self.dimension is not None:
            if self.dimension not in (2, 3):
                raise ValueError(f"Frame.dimension must be 2, 3 or None, got {self.dimension}")
            return int(self.dimension)
        if self.n == 0:
            return 3
        flat = np.all(self.x[:, 2] == 0.0)
        rods = self.length > 0
        in_plane = np.all(np.abs(self.axis[rods, 2]) < 1e-9)  # rounding of quaternions
        return 2 if flat and in_plane else 3

    @property
    def vertical(self) -> int:
        """Index of the vertical (gravity) axis: 2 (z) in 3-D, 1 (y) in 2-D."""
        return self.dim - 1

    @property
    def measure(self) -> float:
        """Box volume in 3-D, box area (x-y) in 2-D (length^d)."""
        return float(np.prod(self.box[:self.dim]))

    def particle_measures(self) -> np.ndarray:
        """Particle volumes (3-D) or areas ``A_p = 2 L R + pi R^2`` (2-D)."""
        if self.dim == 2:
            return 2.0 * self.length * self.radius + np.pi * self.radius**2
        return self.particle_volumes()

    def minimum_image(self, d: np.ndarray) -> np.ndarray:
        """Separation vectors ``d`` (..., 3) folded to the minimum image on periodic axes."""
        d = np.asarray(d, dtype=np.float64)
        # only periodic axes have a (non-zero) period: a 2-D frame's z edge may be 0
        safe = np.where(self.periodic & (self.box > 0), self.box, 1.0)
        shift = np.where(self.periodic & (self.box > 0), safe * np.floor(d / safe + 0.5), 0.0)
        return d - shift

    def ends(self) -> tuple[np.ndarray, np.ndarray]:
        """Spine ends ``x -/+ (L/2) u`` (N, 3) each (both equal the centre for spheres)."""
        h = 0.5 * self.length[:, None] * self.axis
        return self.x - h, self.x + h

    def extent(self, axis: int) -> tuple[np.ndarray, np.ndarray]:
        """Lowest and highest coordinate along ``axis`` of each particle's surface:
        ``x_a -/+ (|u_a| L/2 + R)``."""
        half = 0.5 * self.length * np.abs(self.axis[:, axis]) + self.radius
        return self.x[:, axis] - half, self.x[:, axis] + half

    def subset(self, rows) -> "Frame":
        """The frame restricted to the given rows (boolean mask or indices)."""
        rows = np.asarray(rows)
        return Frame(self.step, self.ids[rows], self.types[rows], self.x[rows],
                     self.radius[rows], self.axis[rows], self.length[rows], self.box_lo.copy(),
                     self.box.copy(), self.periodic.copy(), self.dimension)

    @property
    def volume(self) -> float:
        """Box volume (length^3; the product of all three edges, see :attr:`measure`)."""
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

    def canonical(self) -> "Contacts":
        """The same contacts with ``i < j`` in every row (normal and force flipped where
        a row is swapped; walls, whose ``j`` is a wall id <= 0, are kept as they are) and
        rows sorted by ``(i, j)``: engines list a pair in either order."""
        swap = (self.i > self.j) & (self.j > 0)
        i = np.where(swap, self.j, self.i)
        j = np.where(swap, self.i, self.j)
        sign = np.where(swap, -1.0, 1.0)[:, None]
        order = np.lexsort((j, i))
        return Contacts(self.step, i[order], j[order], self.point[order],
                        (sign * self.normal)[order], self.overlap[order],
                        (sign * self.force)[order])

    def subset(self, rows) -> "Contacts":
        """The contacts at the given rows (boolean mask or indices)."""
        rows = np.asarray(rows)
        return Contacts(self.step, self.i[rows], self.j[rows], self.point[rows],
                        self.normal[rows], self.overlap[rows], self.force[rows])

    @classmethod
    def concatenate(cls, parts) -> "Contacts":
        """One table holding the rows of several (the step of the first)."""
        parts = list(parts)
        if not parts:
            return cls.empty()
        return cls(parts[0].step, *(np.concatenate([getattr(p, k) for p in parts])
                                    for k in ("i", "j", "point", "normal", "overlap", "force")))

    @classmethod
    def empty(cls, step: int = 0) -> "Contacts":
        z = np.zeros((0, 3))
        return cls(step, np.zeros(0, np.int64), np.zeros(0, np.int64), z, z.copy(),
                   np.zeros(0), z.copy())
