"""Force and torque balance of a packing: how mechanically stable is it?

From the contact table alone (any engine), the net contact force and torque on each
particle,

    F_i = sum_c s_ic f_c,        tau_i = sum_c (p_c - x_i) x s_ic f_c,

with ``f_c`` the force on the first particle of contact ``c``, ``s_ic = +1`` for it and
``-1`` for the second, ``p_c`` the contact point (minimum image). The residuals are
reported over the rattler-free backbone (:mod:`analysis.contacts`) relative to the mean
contact force ``<|f|>`` and the mean contact torque ``<|f| R>`` (science.md, 2-D
mechanically stable states), so they are dimensionless and 0 for a perfectly balanced
packing.

**Parallel side-side contacts.** Two parallel spines in side contact touch along a
segment, and the spine-distance law has a kink there: the energy is a maximum of two
smooth branches (the contact point jumps from one end of the overlapping projection to the
other as the relative angle changes sign), so a minimiser stops *at* the kink with a torque
that flips sign with the angle. A state on the kink is balanced when some placement of each
such contact's force along its overlap, between the two ends, cancels the torques: that is
why science.md counts the contact as two bonds at the ends of the overlap. With
``split_parallel`` the torque residual is also reported after choosing these placements by
bounded linear least squares (:func:`scipy.optimize.lsq_linear`): each side-side contact
whose two overlap ends are both within contact distance (within ``kink_tol`` of the
overlap) may move its point by ``s`` along the spine, ``s`` between the overlap ends,
which adds ``s (u x f)`` to the torque on one particle and ``-s (u x f)`` on the other
(forces are unchanged).
"""
from __future__ import annotations

import numpy as np
from scipy.optimize import lsq_linear
from scipy.sparse import coo_matrix, vstack

from analysis.base import Observable
from analysis.contacts import SIDE_SIDE, ContactNumber, contact_types
from analysis.frame import Contacts, Frame
from analysis.walls import split_wall_contacts


def net_loads(frame: Frame, contacts: Contacts) -> tuple[np.ndarray, np.ndarray]:
    """Net contact force ``F_i`` (N, 3) and torque ``tau_i`` (N, 3) on every particle
    (pair contacts act on both particles, wall rows on their grain only)."""
    pp, walls = split_wall_contacts(frame, contacts)
    n = frame.n
    f = np.zeros((n, 3))
    t = np.zeros((n, 3))
    for rows, table, sign in ((frame.index_of(pp.i), pp, 1.0), (frame.index_of(pp.j), pp, -1.0),
                              (frame.index_of(walls.i), walls, 1.0)):
        force = sign * table.force
        arm = frame.minimum_image(table.point - frame.x[rows])
        np.add.at(f, rows, force)
        np.add.at(t, rows, np.cross(arm, force))
    return f, t


def kink_contacts(frame: Frame, contacts: Contacts, kink_tol: float = 1.0,
                  tol: float = 1e-6) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Side-side pair contacts sitting on the kink of the spine-distance law.

    For each side-side contact (``contacts`` must hold pair rows only) take the
    overlapping projection of the two spines on the first one's axis, ``[t_lo, t_hi]``;
    the contact is on the kink when the spine gap at both ends of it is below
    ``R_i + R_j + kink_tol * delta`` (``delta`` the contact's overlap). Returns the rows
    (indices into ``contacts``) and, for each, the range ``[s_lo, s_hi]`` by which its
    point may move along ``u_i`` while staying on the overlap.
    """
    if contacts.n == 0 or not np.any(frame.length > 0):
        return np.zeros(0, np.int64), np.zeros(0), np.zeros(0)
    a = frame.index_of(contacts.i)
    b = frame.index_of(contacts.j)
    rows = np.flatnonzero(contact_types(frame, contacts, tol) == SIDE_SIDE)
    a, b = a[rows], b[rows]
    ua, ub = frame.axis[a], frame.axis[b]
    ha, hb = 0.5 * frame.length[a], 0.5 * frame.length[b]
    rel = frame.minimum_image(frame.x[b] - frame.x[a])
    sign = np.sign(np.sum(ua * ub, axis=1))
    sign[sign == 0] = 1.0
    ub = ub * sign[:, None]
    c = np.sum(rel * ua, axis=1)  # centre of b along a's axis
    cos = np.sum(ua * ub, axis=1)
    lo = np.maximum(-ha, c - hb * np.abs(cos))
    hi = np.minimum(ha, c + hb * np.abs(cos))
    reach = frame.radius[a] + frame.radius[b] + kink_tol * np.maximum(contacts.overlap[rows], 0)
    ok = hi > lo
    for t_end in (lo, hi):
        p = t_end[:, None] * ua  # the point of a's spine, relative to x_a
        # closest point of b's spine to it
        tb = np.clip(np.sum((p - rel) * ub, axis=1), -hb, hb)
        gap = np.linalg.norm(p - rel - tb[:, None] * ub, axis=1)
        ok &= gap < reach
    tc = np.sum(frame.minimum_image(contacts.point[rows] - frame.x[a]) * ua, axis=1)
    return rows[ok], (lo - tc)[ok], (hi - tc)[ok]


class ForceBalance(Observable):
    """Residual forces and torques of the rattler-free backbone (see the module doc):
    the net load of every contact on each backbone particle, contacts with rattlers
    included, relative to the mean force of the pair contacts that touch the backbone.

    Parameters: ``split_parallel`` (default True) also solves for the placement of the
    forces of kinked parallel side-side contacts; ``kink_tol`` (:func:`kink_contacts`);
    ``rattler_rule``, ``c_min``, ``friction`` as :class:`analysis.contacts.ContactNumber`.

    Results: ``force`` (N,) ``|F_i| / <|f|>``, ``torque`` (N,) ``|tau_i| / <|f| R>``
    (rattlers NaN), their backbone means and maxima ``force_mean``, ``force_max``,
    ``torque_mean``, ``torque_max``; with the split ``torque_split_mean``,
    ``torque_split_max`` (NaN without), ``n_kink`` the kinked side-side contacts,
    ``mean_force`` ``<|f|>``, ``n_backbone``.
    """

    _results = ("force", "torque", "force_mean", "force_max", "torque_mean", "torque_max",
                "torque_split_mean", "torque_split_max", "n_kink", "mean_force", "n_backbone")

    def __init__(self, split_parallel: bool = True, kink_tol: float = 1.0,
                 rattler_rule: str = "auto", c_min: int | None = None, friction: float = 0.0):
        if kink_tol < 0:
            raise ValueError(f"kink_tol must be >= 0, got {kink_tol}")
        self.split_parallel, self.kink_tol = split_parallel, kink_tol
        self.rattler_rule, self.c_min, self.friction = rattler_rule, c_min, friction

    def compute(self, frame: Frame, contacts: Contacts):
        if contacts is None:
            raise ValueError("ForceBalance needs a contact table with forces")
        nan = float("nan")
        ratt = ContactNumber(self.c_min, rule=self.rattler_rule,
                             friction=self.friction).compute(frame, contacts).rattlers
        keep = ~ratt
        pp, _ = split_wall_contacts(frame, contacts)
        a = frame.index_of(pp.i)
        b = frame.index_of(pp.j)
        live = keep[a] | keep[b]  # pair contacts that load the backbone
        fmag = np.linalg.norm(pp.force, axis=1)[live]
        if not keep.any() or len(fmag) == 0 or fmag.mean() == 0:
            self._set(force=np.full(frame.n, nan), torque=np.full(frame.n, nan),
                      force_mean=nan, force_max=nan, torque_mean=nan, torque_max=nan,
                      torque_split_mean=nan, torque_split_max=nan, n_kink=0,
                      mean_force=0.0, n_backbone=int(keep.sum()))
            return self
        # every contact loads its particles, a rattler's too: the rattler rule may
        # remove a particle that carries two opposite forces (2-D: a rod with two
        # contacts not both on its flat sides), and without them its neighbours would
        # look unbalanced (a stable 2-D rod state showed 1.9 times the mean force)
        f, t = net_loads(frame, contacts)
        mean_f = float(fmag.mean())
        lever = np.where(keep[a], frame.radius[a], frame.radius[b])[live]
        mean_t = float((fmag * lever).mean())
        fr = np.where(keep, np.linalg.norm(f, axis=1) / mean_f, nan)
        tr = np.where(keep, np.linalg.norm(t, axis=1) / mean_t, nan)
        split_mean = split_max = nan
        n_kink = 0
        if self.split_parallel:
            pp_on, _ = split_wall_contacts(frame, contacts)
            rows, s_lo, s_hi = kink_contacts(frame, pp_on, self.kink_tol)
            n_kink = len(rows)
            t2 = t.copy()
            if n_kink:
                ra = frame.index_of(pp_on.i[rows])
                rb = frame.index_of(pp_on.j[rows])
                lever = np.cross(frame.axis[ra], pp_on.force[rows])  # torque per unit shift
                k = np.arange(n_kink)
                m = vstack([coo_matrix((np.concatenate([lever[:, c], -lever[:, c]]),
                                        (np.concatenate([ra, rb]), np.concatenate([k, k]))),
                                       shape=(frame.n, n_kink)) for c in range(3)]).tocsr()
                sol = lsq_linear(m, -t.T.ravel(), bounds=(np.minimum(s_lo, 0),
                                                          np.maximum(s_hi, 0)))
                t2 += (m @ sol.x).reshape(3, -1).T
            t2r = np.linalg.norm(t2, axis=1)[keep] / mean_t
            split_mean, split_max = float(t2r.mean()), float(t2r.max())
        self._set(force=fr, torque=tr, force_mean=float(np.nanmean(fr)),
                  force_max=float(np.nanmax(fr)), torque_mean=float(np.nanmean(tr)),
                  torque_max=float(np.nanmax(tr)), torque_split_mean=split_mean,
                  torque_split_max=split_max, n_kink=n_kink, mean_force=mean_f,
                  n_backbone=int(keep.sum()))
        return self
