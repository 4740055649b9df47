"""Container walls: geometric wall contacts and the wall convention of contact tables.

Convention: in a :class:`analysis.frame.Contacts` table a **wall contact** is a row whose
``j`` is a wall id ``<= 0`` (particle ids are ``1..N``; we use ``-1, -2, ...``);
``point``, ``normal`` (from the grain towards the wall), ``overlap`` and ``force`` (on
the grain ``i``) have their usual meaning. The observables count such rows as contacts
of ``i`` that never become rattlers (:mod:`analysis.contacts`), and add their branch
vectors to the grain stress (:mod:`analysis.stress`).

A grain touches a plane or a cylinder wall when an end of its spine is within ``R`` of
it; when both ends are (a grain lying flat) there are two wall contacts
(science.md section 2). The closest point of a spine to a plane, and its farthest point
from a cylinder axis, is always an end, so checking the ends is exact.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from analysis.frame import Contacts, Frame


@dataclass(frozen=True)
class PlaneWall:
    """The plane through ``point`` with unit ``normal`` pointing into the container."""

    point: tuple
    normal: tuple
    wall_id: int = -1

    def gap(self, p: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Distance of points ``p`` (M, 3) from the plane and the unit direction from
        the points towards the wall (M, 3)."""
        m = np.asarray(self.normal, dtype=np.float64)
        m = m / np.linalg.norm(m)
        dist = (p - np.asarray(self.point, dtype=np.float64)) @ m
        return dist, np.broadcast_to(-m, p.shape)


@dataclass(frozen=True)
class CylinderWall:
    """The inside of a cylinder of ``radius`` whose axis is parallel to coordinate
    ``axis`` (default z) through ``center`` (the other two coordinates, in order)."""

    center: tuple
    radius: float
    axis: int = 2
    wall_id: int = -2

    def gap(self, p: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        others = [k for k in range(3) if k != self.axis]
        rho = np.zeros_like(p)
        rho[:, others] = p[:, others] - np.asarray(self.center, dtype=np.float64)
        r = np.linalg.norm(rho, axis=1)
        n = rho / np.where(r > 0, r, 1.0)[:, None]
        n[r == 0, others[0]] = 1.0
        return self.radius - r, n


def wall_contacts(frame: Frame, walls, tolerance: float = 0.0) -> Contacts:
    """Contacts of grains with ``walls`` (a wall or a list): one row per spine end
    closer than ``R + tolerance`` to a wall (spheres: one end). Forces are unknown
    (zero); ``overlap = R - gap`` may be negative down to ``-tolerance``."""
    if isinstance(walls, (PlaneWall, CylinderWall)):
        walls = [walls]
    lo, hi = frame.ends()
    parts = []
    for w in walls:
        for end, use in ((lo, np.ones(frame.n, bool)), (hi, frame.length > 0)):
            gap, n = w.gap(end)
            overlap = frame.radius - gap
            keep = use & (overlap > -tolerance)
            rows = np.flatnonzero(keep)
            point = end[rows] + (frame.radius[rows] - 0.5 * overlap[rows])[:, None] * n[rows]
            parts.append(Contacts(frame.step, frame.ids[rows],
                                  np.full(len(rows), w.wall_id, dtype=np.int64), point,
                                  np.array(n[rows]), overlap[rows], np.zeros((len(rows), 3))))
    out = Contacts.concatenate(parts)
    out.step = frame.step
    return out


def split_wall_contacts(frame: Frame, contacts: Contacts) -> tuple[Contacts, Contacts]:
    """``(particle-particle, wall)`` rows of a table: wall rows are those with ``j <= 0``;
    every ``i`` and every other ``j`` must be a particle id of ``frame`` (KeyError)."""
    is_wall = contacts.j <= 0
    frame.index_of(contacts.i)
    frame.index_of(contacts.j[~is_wall])
    return contacts.subset(~is_wall), contacts.subset(is_wall)
