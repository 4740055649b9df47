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
