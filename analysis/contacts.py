"""Contact numbers and rattlers.

``C_i`` is the number of contacts of particle ``i``; the mean contact number is
``<C> = 2 N_c / N``. Rattlers (3-D frictionless spheres: fewer than ``d + 1 = 4``
contacts) carry no load; they are removed iteratively, because removing one can
leave a neighbour under the threshold, and ``z`` is then counted on the remaining
backbone: ``z = 2 N_c' / N'``.
"""
from __future__ import annotations

import numpy as np

from analysis.base import Observable
from analysis.frame import Contacts, Frame


def contact_counts(n: int, i: np.ndarray, j: np.ndarray) -> np.ndarray:
    """``C`` (n,) contacts per particle for 0-based pair indices ``i``, ``j``."""
    return (np.bincount(i, minlength=n) + np.bincount(j, minlength=n)).astype(np.int64)


def remove_rattlers(n: int, i: np.ndarray, j: np.ndarray, c_min: int) -> np.ndarray:
    """Boolean mask (n,) of rattlers: particles left with fewer than ``c_min`` contacts
    after iteratively removing such particles and their contacts."""
    i = np.asarray(i, dtype=np.int64)
    j = np.asarray(j, dtype=np.int64)
    rattler = np.zeros(n, dtype=bool)
    alive = np.ones(len(i), dtype=bool)
    while True:
        c = contact_counts(n, i[alive], j[alive])
        new = (c < c_min) & ~rattler
        if not new.any():
            return rattler
        rattler |= new
        alive &= ~(rattler[i] | rattler[j])


class ContactNumber(Observable):
    """Contact numbers of one frame, with and without rattlers.

    ``c_min`` is the smallest contact count of a load-bearing particle (3-D spheres 4;
    see science.md for rods and 2-D). Results: ``per_particle`` (N,) ``C_i``,
    ``z`` mean ``<C>``, ``rattlers`` (N,) bool, ``n_rattlers``, ``z_rattler_free``,
    ``distribution`` ``P(C)`` as an array indexed by ``C``.
    """

    _results = ("per_particle", "z", "rattlers", "n_rattlers", "z_rattler_free", "distribution")

    def __init__(self, c_min: int = 4):
        if c_min < 0:
            raise ValueError(f"c_min must be >= 0, got {c_min}")
        self.c_min = c_min

    def compute(self, frame: Frame, contacts: Contacts):
        n = frame.n
        a = frame.index_of(contacts.i)
        b = frame.index_of(contacts.j)
        c = contact_counts(n, a, b)
        ratt = remove_rattlers(n, a, b, self.c_min)
        keep = ~(ratt[a] | ratt[b])
        n_bb = int(np.count_nonzero(~ratt))
        z_rf = 2.0 * np.count_nonzero(keep) / n_bb if n_bb else 0.0
        self._set(per_particle=c, z=2.0 * len(a) / n if n else 0.0, rattlers=ratt,
                  n_rattlers=int(ratt.sum()), z_rattler_free=z_rf,
                  distribution=np.bincount(c) / n if n else np.zeros(1))
        return self


def geometric_contacts(frame: Frame, tolerance: float = 0.0) -> Contacts:
    """Contacts of spheres from positions alone: pairs with centre distance below
    ``R_i + R_j + tolerance`` (minimum image on periodic axes). Forces are unknown
    (zero); overlaps may be negative down to ``-tolerance``. Uses scipy's cKDTree.

    Spherocylinders (``length > 0``) need the segment geometry of issue 4 and are
    refused here.
    """
    if np.any(frame.length > 0):
        raise NotImplementedError("geometric contacts of spherocylinders are not implemented yet")
    rmax = float(frame.radius.max())
    a, b = _pairs_within(frame, 2.0 * rmax + tolerance)
    d = frame.x[b] - frame.x[a]
    d -= frame.box * np.floor(d / frame.box + 0.5) * frame.periodic
    r = np.linalg.norm(d, axis=1)
    overlap = frame.radius[a] + frame.radius[b] - r
    keep = overlap > -tolerance
    a, b, d, r, overlap = a[keep], b[keep], d[keep], r[keep], overlap[keep]
    order = np.lexsort((b, a))
    a, b, d, r, overlap = a[order], b[order], d[order], r[order], overlap[order]
    n = d / r[:, None]
    point = frame.x[a] + (frame.radius[a] - 0.5 * overlap)[:, None] * n
    return Contacts(step=frame.step, i=frame.ids[a], j=frame.ids[b], point=point, normal=n,
                    overlap=overlap, force=np.zeros_like(n))


def _pairs_within(frame: Frame, cutoff: float):
    """Index pairs ``a < b`` closer than ``cutoff`` (minimum image on periodic axes).

    cKDTree handles all-periodic boxes natively; with some walls, ghost copies of the
    particles within ``cutoff`` of a periodic face are added instead.
    """
    from scipy.spatial import cKDTree

    x = frame.x - frame.box_lo
    if np.all(frame.periodic):
        x = np.mod(x, frame.box)
        x[x >= frame.box] = 0.0  # mod may round up to the box length
        pairs = cKDTree(x, boxsize=frame.box).query_pairs(cutoff, output_type="ndarray")
        return pairs[:, 0], pairs[:, 1]
    x = np.where(frame.periodic, np.mod(x, frame.box), x)
    pts, owner = [x], [np.arange(frame.n)]
    for axis in np.flatnonzero(frame.periodic):
        cur = np.concatenate(pts)
        own = np.concatenate(owner)
        for sign in (-1.0, 1.0):
            near = cur[:, axis] < cutoff if sign > 0 else cur[:, axis] > frame.box[axis] - cutoff
            shifted = cur[near].copy()
            shifted[:, axis] += sign * frame.box[axis]
            pts.append(shifted)
            owner.append(own[near])
    allx = np.concatenate(pts)
    own = np.concatenate(owner)
    pairs = cKDTree(allx).query_pairs(cutoff, output_type="ndarray")
    a, b = own[pairs[:, 0]], own[pairs[:, 1]]
    keep = a != b
    lo, hi = np.minimum(a[keep], b[keep]), np.maximum(a[keep], b[keep])
    uniq = np.unique(np.column_stack([lo, hi]), axis=0)
    return uniq[:, 0], uniq[:, 1]
