"""Contacts: from tables or geometry, contact numbers, rattlers, contact types.

``C_i`` is the number of contacts of particle ``i``; the mean contact number is
``<C> = 2 N_c / N``. Rattlers carry no load; they are removed iteratively, because
removing one can leave a neighbour under the threshold, and the contact number is then
counted on the remaining backbone, ``z = 2 N_c' / N'``. Rules (science.md sections 4, 5):

* ``rule="threshold"``: fewer than ``c_min`` contacts (3-D frictionless spheres
  ``c_min = d + 1 = 4``; for 3-D rods, for which science.md gives no rule, we use
  ``d_f + 1 = 6``; frictional grains of any shape ``c_min = d``: see
  :func:`default_c_min`);
* ``rule="2d"``: 0 or 1 contacts, or 2 contacts unless they lie on opposite flat sides
  of the rod (disks have no flat side, so they need 3); frictionless grains only.

Contact *types* classify each end of a contact as a **tip** (the closest point of the
spine is one of its ends, the contact point projects at or beyond ``|t| = L/2``) or a
**side**: tip-tip, tip-side, side-side (spheres are all tip).

2-D counting: two parallel spines in side-to-side contact constrain two degrees of
freedom; for isostaticity such a contact counts as two bonds (``z_bonds``, the ``z`` of
science.md) while contact-geometry statistics count it once (``z_tilde``).

Wall contacts (rows whose ``j`` is a wall id ``<= 0``, :mod:`analysis.walls`) count for
their grain and never become rattlers. Glued-sphere rods: :func:`glued_bodies` and
:func:`merge_glued_contacts` turn sphere-sphere contacts into body-body contacts.
"""
from __future__ import annotations

import numpy as np

from analysis.base import Observable
from analysis.frame import Contacts, Frame
from analysis.walls import split_wall_contacts

TIP_TIP, TIP_SIDE, SIDE_SIDE = 0, 1, 2
TYPE_NAMES = ("tip-tip", "tip-side", "side-side")


def contact_counts(n: int, i: np.ndarray, j: np.ndarray) -> np.ndarray:
    """``C`` (n,) contacts per particle for 0-based pair indices ``i``, ``j``."""
    return (np.bincount(i, minlength=n) + np.bincount(j, minlength=n)).astype(np.int64)


def contact_number_distribution(frame: Frame, contacts: Contacts) -> np.ndarray:
    """``P(C)`` of one frame (Wouterse, Luding & Philipse, Fig. 3): the fraction of the
    ``N`` particles with ``C = 0, 1, ..., max C`` contacts, where ``C`` counts the other
    particles a particle touches with a positive overlap (a pair listed twice counts
    once); rattlers are included, wall rows (``j <= 0``) left out. The mean of the
    distribution is ``<C> = 2 N_c / N`` over those pairs. (:class:`ContactNumber`'s
    ``distribution`` counts rows and walls too.)"""
    pp, _walls = split_wall_contacts(frame, contacts)
    touch = np.asarray(pp.overlap) > 0
    a = frame.index_of(pp.i[touch])
    b = frame.index_of(pp.j[touch])
    pairs = np.unique(np.column_stack([np.minimum(a, b), np.maximum(a, b)]), axis=0)
    c = contact_counts(frame.n, pairs[:, 0], pairs[:, 1])
    return np.bincount(c, minlength=1) / frame.n if frame.n else np.zeros(1)


def remove_rattlers(n: int, i: np.ndarray, j: np.ndarray, c_min: int,
                    fixed: np.ndarray | None = None) -> np.ndarray:
    """Boolean mask (n,) of rattlers: particles left with fewer than ``c_min`` contacts
    after iteratively removing such particles and their contacts. ``fixed`` (n,) adds
    contacts that never disappear (walls)."""
    i = np.asarray(i, dtype=np.int64)
    j = np.asarray(j, dtype=np.int64)
    extra = np.zeros(n, np.int64) if fixed is None else np.asarray(fixed, np.int64)
    rattler = np.zeros(n, dtype=bool)
    alive = np.ones(len(i), dtype=bool)
    while True:
        c = contact_counts(n, i[alive], j[alive]) + extra
        new = (c < c_min) & ~rattler
        if not new.any():
            return rattler
        rattler |= new
        alive &= ~(rattler[i] | rattler[j])


def default_c_min(frame: Frame, friction: float = 0.0) -> int:
    """Threshold rule's ``c_min`` for a frame (rattlers have fewer contacts).

    Frictionless (``friction == 0``): ``d_f + 1`` with ``d_f`` the blocked degrees of
    freedom of one particle (3-D spheres 3 -> 4, 3-D rods 5 -> 6; 2-D disks 2 -> 3, 2-D
    rods 3 -> 4; for 2-D prefer ``rule="2d"``): normal forces only push, and ``d_f + 1``
    of them are the fewest that can balance each other in ``d_f`` dimensions.

    Frictional (``friction > 0``): ``d`` for every shape (3-D 3, 2-D 2). A contact with
    friction carries a force anywhere in its Coulomb cone (``d`` components), and every
    rigid-body degree of freedom of the grain is coupled, rotation about a rod's own axis
    included: force and torque balance are ``d (d + 1) / 2`` equations. Fewer than ``d``
    contacts cannot hold a grain: in 3-D two forces in equilibrium lie on the line through
    their contact points and cannot resist a torque about that line; in 2-D one
    contact carries no force at all. ``d`` contacts in general position can (two forces
    along the chord, within their cones, in 2-D; any force and torque from three points
    in 3-D). The threshold stays below the frictional isostatic mean ``z = d + 1``
    (generalised isostaticity: Shundyak, van Hecke & van Saarloos, PRE 75, 010301(R),
    2007; frictional spheres approach ``z_J = 4`` at large friction: Silbert, Soft Matter
    6, 2918, 2010), as the frictionless ``d_f + 1`` stays below ``2 d_f``: a threshold of
    ``d + 1`` strips packings near that mean (measured in docs/analysis.md). For rods
    the same counting holds (the papers of this project give no rattler rule for
    frictional spherocylinders). ``analysis.c_min`` in a study's configuration overrides
    the rule.
    """
    if friction > 0:
        return frame.dim
    rods = bool(np.any(frame.length > 0))
    d_f = {(3, False): 3, (3, True): 5, (2, False): 2, (2, True): 3}[(frame.dim, rods)]
    return d_f + 1


def _side_offsets(frame: Frame, rows: np.ndarray, point: np.ndarray):
    """Axial ``t`` and signed perpendicular (2-D) offsets of contact points from centres."""
    rel = frame.minimum_image(point - frame.x[rows])
    t = np.sum(rel * frame.axis[rows], axis=1)
    perp = np.column_stack([-frame.axis[rows, 1], frame.axis[rows, 0], np.zeros(len(rows))])
    return t, np.sum(rel * perp, axis=1)


def is_tip(frame: Frame, rows: np.ndarray, point: np.ndarray, tol: float = 1e-6) -> np.ndarray:
    """Whether the contact at ``point`` sits on a cap of particle ``rows``:
    ``|(p - x) . u| >= L/2 - tol R`` (always true for spheres)."""
    t, _ = _side_offsets(frame, rows, point)
    return np.abs(t) >= 0.5 * frame.length[rows] - tol * frame.radius[rows]


def contact_types(frame: Frame, contacts: Contacts, tol: float = 1e-6) -> np.ndarray:
    """Type code per contact (C,): :data:`TIP_TIP`, :data:`TIP_SIDE`, :data:`SIDE_SIDE`
    (particle-particle contacts only; see :func:`is_tip` for ``tol``)."""
    a = frame.index_of(contacts.i)
    b = frame.index_of(contacts.j)
    side = (~is_tip(frame, a, contacts.point, tol)).astype(int) + \
        (~is_tip(frame, b, contacts.point, tol)).astype(int)
    return side  # 0 tips -> tip-tip, 1 side -> tip-side, 2 sides -> side-side


def contact_angles(frame: Frame, contacts: Contacts) -> np.ndarray:
    """Angle ``varphi`` (rad, in ``[0, pi/2]``) of each contact around each particle it
    touches, measured from the spine: ``cos varphi = |(p - x_i) . u_i| / |p - x_i|`` for
    the contact point ``p`` and the centre ``x_i`` (minimum image), both ends of every
    particle-particle contact that sits on a rod (``L > 0``; spheres and disks have no
    spine and are left out, as are wall rows). The spine's two directions and its two
    sides are equivalent, hence the folding to a quarter turn. Contacts spread evenly
    around very short rods give ``P(varphi) = 2/pi`` (2-D) and ``sin varphi`` (3-D); on a
    rod, points on the flat sides lie above the cap-side junction
    ``varphi_c = arctan(2R/L)`` and cap points below it (up to the overlap).
    """
    pp, _walls = split_wall_contacts(frame, contacts)
    a = frame.index_of(pp.i)
    b = frame.index_of(pp.j)
    rows = np.concatenate([a, b])
    point = np.concatenate([pp.point, pp.point])
    rod = frame.length[rows] > 0
    rows, point = rows[rod], point[rod]
    rel = frame.minimum_image(point - frame.x[rows])
    norm = np.linalg.norm(rel, axis=1)
    along = np.abs(np.sum(rel * frame.axis[rows], axis=1))
    cos = np.divide(along, norm, out=np.ones_like(norm), where=norm > 0)
    return np.arccos(np.clip(cos, 0.0, 1.0))


def parallel_side_contacts(frame: Frame, contacts: Contacts, angle_tol: float = 1e-6,
                           tol: float = 1e-6) -> np.ndarray:
    """Side-side contacts of parallel spines (|u_i x u_j| < sin(angle_tol)), (C,) bool."""
    a = frame.index_of(contacts.i)
    b = frame.index_of(contacts.j)
    cross = np.linalg.norm(np.cross(frame.axis[a], frame.axis[b]), axis=1)
    rods = (frame.length[a] > 0) & (frame.length[b] > 0)
    return rods & (cross < np.sin(angle_tol)) & (contact_types(frame, contacts, tol) == SIDE_SIDE)


def end_bond_counts(frame: Frame, contacts: Contacts, apart: float = 0.25) -> np.ndarray:
    """Bonds per particle-particle contact (C,) by Marschall & Teitel's (2018) rule for a
    side-to-side contact: two bonds where the pair overlaps along a flat side of each,
    otherwise one. The bonds are the end bonds (each end of one spine against the closest
    point of the other, their Fig. 6; pysim's ``spine_contact: end_bonds``) that overlap,
    ``|r_b| < R_i + R_j`` (or touch within the row's own gap, for tables of contacts
    found with a tolerance). Two overlapping bonds are one contact when their points lie
    within ``apart`` times the shorter spine of each other on either spine: a tip against
    a tip, a tilted pair touching near two ends, or a tip against the middle of a side,
    whose cap reaches both ends of a very short spine (overlap above about
    ``L^2 / (8 (R_i + R_j))``) though it touches that side at one point. Unlike
    :func:`parallel_side_contacts` no angle enters: a pair tilted by less than about
    ``overlap / (L/2)`` has both ends in contact. Overlaps near jamming are small, so
    this needs positions to more digits than their ratio to the box (the dumps keep 10)."""
    from analysis.geometry import end_bond_params

    a = frame.index_of(contacts.i)
    b = frame.index_of(contacts.j)
    d = frame.minimum_image(frame.x[b] - frame.x[a])
    ui, uj = frame.axis[a], frame.axis[b]
    hi, hj = 0.5 * frame.length[a], 0.5 * frame.length[b]
    reach = frame.radius[a] + frame.radius[b]
    s, t = end_bond_params(d, ui, hi, uj, hj)
    # a row of a geometric table may touch at a gap (overlap down to -tolerance): its
    # bonds count at that gap too
    limit = reach + np.maximum(-np.asarray(contacts.overlap, float), 0.0) + 1e-12 * reach
    touch = np.empty((len(a), 4), bool)
    for k in range(4):
        r = d + t[:, k, None] * uj - s[:, k, None] * ui
        touch[:, k] = np.einsum("ij,ij->i", r, r) < limit**2
    near = apart * 2.0 * np.minimum(hi, hj)
    count = np.zeros(len(a), np.int64)
    for k in range(4):
        same = np.zeros(len(a), bool)
        for m in range(k):
            same |= touch[:, m] & ((np.abs(s[:, k] - s[:, m]) <= near) |
                                   (np.abs(t[:, k] - t[:, m]) <= near))
        count += touch[:, k] & ~same
    return np.clip(count, 1, 2)


def flat_side_contact_fraction(frame: Frame, contacts: Contacts,
                               among: np.ndarray | None = None) -> float:
    """Fraction of the rods (``L > 0``; of those in the mask ``among`` when given) with a
    contact point on one of their flat sides, ``|(p - x) . u| < L/2`` (Marschall & Teitel
    2018, Sec. III.C: 96.3 % at alpha = 0.01); particle-particle contacts only. NaN
    without rods."""
    pp, _walls = split_wall_contacts(frame, contacts)
    rows = np.concatenate([frame.index_of(pp.i), frame.index_of(pp.j)])
    point = np.concatenate([pp.point, pp.point])
    t, _ = _side_offsets(frame, rows, point)
    flat = np.zeros(frame.n, bool)
    flat[rows[np.abs(t) < 0.5 * frame.length[rows]]] = True
    rods = frame.length > 0
    if among is not None:
        rods &= np.asarray(among, bool)
    return float(flat[rods].mean()) if rods.any() else float("nan")


def remove_rattlers_2d(frame: Frame, contacts: Contacts, tol: float = 1e-6) -> np.ndarray:
    """Rattler mask (N,) by the 2-D rule: 0 or 1 contacts, or 2 contacts unless both sit
    on the flat sides (not the caps) and on opposite sides of the spine; iterated. Wall
    rows (``j <= 0``) count and are never removed."""
    pp, walls = split_wall_contacts(frame, contacts)
    n = frame.n
    a = frame.index_of(pp.i)
    b = frame.index_of(pp.j)
    w = frame.index_of(walls.i)
    # every contact end: owner row, partner row (-1: wall), side flag and perpendicular sign
    owner = np.concatenate([a, b, w])
    partner = np.concatenate([b, a, np.full(len(w), -1)])
    point = np.concatenate([pp.point, pp.point, walls.point])
    t, perp = _side_offsets(frame, owner, point)
    flat = (np.abs(t) < 0.5 * frame.length[owner] - tol * frame.radius[owner]) & \
        (frame.length[owner] > 0)
    sign = np.sign(perp)
    rattler = np.zeros(n, bool)
    while True:
        alive = ~rattler[owner] & ((partner < 0) | ~rattler[np.maximum(partner, 0)])
        c = np.bincount(owner[alive], minlength=n)
        new = (c <= 1) & ~rattler
        two = np.flatnonzero((c == 2) & ~rattler)
        if len(two):
            sel = alive & np.isin(owner, two)
            o, f, s = owner[sel], flat[sel], sign[sel]
            order = np.argsort(o, kind="stable")
            o, f, s = o[order], f[order], s[order]
            opposite = f[0::2] & f[1::2] & (s[0::2] * s[1::2] < 0)
            new[o[0::2][~opposite]] = True
        if not new.any():
            return rattler
        rattler |= new


class ContactNumber(Observable):
    """Contact numbers of one frame, with and without rattlers.

    Parameters: ``rule`` ``"threshold"`` (fewer than ``c_min`` contacts), ``"2d"``
    (science.md's 2-D rule) or ``"auto"`` (the default: ``"2d"`` for frictionless 2-D
    frames unless ``c_min`` is given, otherwise the threshold with ``c_min``, by default
    :func:`default_c_min`: 4 for frictionless 3-D spheres, 6 for frictionless 3-D rods,
    ``d`` for frictional grains); ``friction``: the packing's Coulomb coefficient ``mu``
    (the case's ``contact.friction``), which picks the default rule;
    ``double_parallel``: count side contacts as two bonds in ``z_bonds`` (default: in
    2-D frames only), by ``bond_rule`` ``"overlap"`` (the default: both end bonds of the
    pair overlap, :func:`end_bond_counts`, Marschall & Teitel's constraint count) or
    ``"parallel"`` (side-side contacts of spines parallel within ``angle_tol``,
    :func:`parallel_side_contacts`); ``tol``, ``angle_tol`` of the tip and parallel tests.

    Results: ``per_particle`` (N,) ``C_i`` (walls included), ``z`` mean ``<C>`` (particle
    contacts ``2 N_c / N`` plus wall contacts ``N_w / N``), ``rattlers`` (N,) bool,
    ``n_rattlers``, ``z_rattler_free`` (each contact once; = ``z_tilde``), ``z_bonds``
    (rattler-free, parallel side-side contacts twice: the isostatic count ``z`` of
    science.md), ``distribution`` ``P(C)`` indexed by ``C``, and
    ``distribution_rattler_free`` (over non-rattlers, contacts among them).
    """

    _results = ("per_particle", "z", "rattlers", "n_rattlers", "z_rattler_free", "z_tilde",
                "z_bonds", "distribution", "distribution_rattler_free")

    def __init__(self, c_min: int | None = None, rule: str = "auto",
                 double_parallel: bool | None = None, tol: float = 1e-6, angle_tol: float = 1e-6,
                 friction: float = 0.0, bond_rule: str = "overlap"):
        if c_min is not None and c_min < 0:
            raise ValueError(f"c_min must be >= 0, got {c_min}")
        if rule not in ("threshold", "2d", "auto"):
            raise ValueError(f"rule must be 'auto', 'threshold' or '2d', got {rule!r}")
        if not friction >= 0:
            raise ValueError(f"friction must be a number >= 0, got {friction}")
        if bond_rule not in ("overlap", "parallel"):
            raise ValueError(f"bond_rule must be 'overlap' or 'parallel', got {bond_rule!r}")
        self.bond_rule = bond_rule
        self.c_min, self.rule, self.double_parallel = c_min, rule, double_parallel
        self.tol, self.angle_tol, self.friction = tol, angle_tol, float(friction)

    def describe(self, frame: Frame) -> str:
        """The rattler rule this observable applies to ``frame``, in words (for messages)."""
        if self._rule(frame) == "2d":
            return "the 2-D rule (0 or 1 contacts, or 2 not on opposite flat sides)"
        return f"fewer than {self._c_min(frame)} contacts"

    def _rule(self, frame: Frame) -> str:
        if self.rule != "auto":
            return self.rule
        frictionless_2d = frame.dim == 2 and self.c_min is None and self.friction == 0
        return "2d" if frictionless_2d else "threshold"

    def _c_min(self, frame: Frame) -> int:
        return default_c_min(frame, self.friction) if self.c_min is None else self.c_min

    def compute(self, frame: Frame, contacts: Contacts):
        if contacts is None:
            raise ValueError("ContactNumber needs a contact table (or geometric_contacts(frame))")
        n = frame.n
        pp, walls = split_wall_contacts(frame, contacts)
        a = frame.index_of(pp.i)
        b = frame.index_of(pp.j)
        fixed = np.bincount(frame.index_of(walls.i), minlength=n)
        c = contact_counts(n, a, b) + fixed
        if self._rule(frame) == "2d":
            ratt = remove_rattlers_2d(frame, contacts, self.tol)
        else:
            ratt = remove_rattlers(n, a, b, self._c_min(frame), fixed)
        keep = ~(ratt[a] | ratt[b])
        keep_w = ~ratt[frame.index_of(walls.i)]
        n_bb = int(np.count_nonzero(~ratt))
        double = self.double_parallel if self.double_parallel is not None else frame.dim == 2
        bonds = np.ones(len(a), np.int64)
        if double and len(a) and self.bond_rule == "overlap":
            bonds = end_bond_counts(frame, pp)
        elif double and len(a):
            bonds += parallel_side_contacts(frame, pp, self.angle_tol, self.tol)
        n_once = 2.0 * np.count_nonzero(keep) + np.count_nonzero(keep_w)
        n_bonds = 2.0 * np.sum(bonds[keep]) + np.count_nonzero(keep_w)
        z_rf = n_once / n_bb if n_bb else 0.0
        c_rf = contact_counts(n, a[keep], b[keep])[~ratt] + fixed[~ratt]
        self._set(per_particle=c, z=(2.0 * len(a) + walls.n) / n if n else 0.0, rattlers=ratt,
                  n_rattlers=int(ratt.sum()), z_rattler_free=z_rf, z_tilde=z_rf,
                  z_bonds=n_bonds / n_bb if n_bb else 0.0,
                  distribution=np.bincount(c) / n if n else np.zeros(1),
                  distribution_rattler_free=np.bincount(c_rf) / n_bb if n_bb else np.zeros(1))
        return self


class ContactTypes(Observable):
    """Tip-tip, tip-side and side-side contacts (particle-particle rows only).

    Results: ``types`` (C,) codes (:data:`TIP_TIP`, :data:`TIP_SIDE`, :data:`SIDE_SIDE`),
    ``counts`` (3,), ``fractions`` (3,) in the order of :data:`TYPE_NAMES`,
    ``parallel_side`` (C,) bool: side-side contacts of parallel spines.
    """

    _results = ("types", "counts", "fractions", "parallel_side")

    def __init__(self, tol: float = 1e-6, angle_tol: float = 1e-6):
        self.tol, self.angle_tol = tol, angle_tol

    def compute(self, frame: Frame, contacts: Contacts):
        pp, _ = split_wall_contacts(frame, contacts)
        types = contact_types(frame, pp, self.tol)
        counts = np.bincount(types, minlength=3)
        self._set(types=types, counts=counts,
                  fractions=counts / counts.sum() if counts.sum() else np.full(3, np.nan),
                  parallel_side=parallel_side_contacts(frame, pp, self.angle_tol, self.tol))
        return self


# -- contacts from positions -----------------------------------------------------------------
def geometric_contacts(frame: Frame, tolerance: float = 0.0) -> Contacts:
    """Contacts from positions alone: pairs whose spines are closer than
    ``R_i + R_j + tolerance`` (minimum image on periodic axes). Forces are unknown (zero);
    overlaps ``delta = R_i + R_j - d`` may be negative down to ``-tolerance``.

    Spheres use centre distances (scipy cKDTree); spherocylinders the closest points of
    their spines (:func:`analysis.geometry.spine_closest`). Normal from the closest point on ``i``
    to that on ``j``; contact point ``p_i + (R_i - delta/2) n``.
    """
    if tolerance < 0:
        raise ValueError(f"tolerance must be >= 0, got {tolerance}")
    if frame.n < 2:
        return Contacts.empty(frame.step)
    if np.any(frame.length > 0):
        return _rod_contacts(frame, tolerance)
    rmax = float(frame.radius.max())
    a, b = pairs_within(frame, 2.0 * rmax + tolerance)
    d = frame.minimum_image(frame.x[b] - frame.x[a])
    r = np.linalg.norm(d, axis=1)
    overlap = frame.radius[a] + frame.radius[b] - r
    keep = overlap > -tolerance
    return _table(frame, a[keep], b[keep], frame.x[a[keep]], d[keep], r[keep], overlap[keep])


def _table(frame, a, b, pa, d, r, overlap):
    order = np.lexsort((b, a))
    a, b, pa, d, r, overlap = a[order], b[order], pa[order], d[order], r[order], overlap[order]
    n = d / np.where(r > 0, r, 1.0)[:, None]
    point = pa + (frame.radius[a] - 0.5 * overlap)[:, None] * n
    return Contacts(step=frame.step, i=frame.ids[a], j=frame.ids[b], point=point, normal=n,
                    overlap=overlap, force=np.zeros_like(n))


def _rod_contacts(frame: Frame, tolerance: float) -> Contacts:
    from analysis.geometry import spine_closest

    reach = 0.5 * frame.length + frame.radius
    srt = np.sort(reach)
    a, b = pairs_within(frame, float(srt[-1] + srt[-2]) + tolerance)
    xb = frame.x[a] + frame.minimum_image(frame.x[b] - frame.x[a])
    s, t = spine_closest(frame.x[a], frame.axis[a], frame.length[a], xb, frame.axis[b],
                         frame.length[b])
    pa = frame.x[a] + s[:, None] * frame.axis[a]
    d = xb + t[:, None] * frame.axis[b] - pa
    r = np.linalg.norm(d, axis=1)
    # spines that cross (d = 0): the normal is along u_i x u_j (any perpendicular if parallel)
    zero = r == 0
    if np.any(zero):
        c = np.cross(frame.axis[a[zero]], frame.axis[b[zero]])
        flat = np.linalg.norm(c, axis=1) == 0
        c[flat] = np.cross(frame.axis[a[zero]][flat], [1.0, 0.0, 0.0])
        c[np.linalg.norm(c, axis=1) == 0] = [0.0, 1.0, 0.0]
        d[zero] = 1e-300 * c / np.linalg.norm(c, axis=1)[:, None]
        r[zero] = np.linalg.norm(d[zero], axis=1)
    overlap = frame.radius[a] + frame.radius[b] - r
    keep = overlap > -tolerance
    return _table(frame, a[keep], b[keep], pa[keep], d[keep], r[keep], overlap[keep])


def pairs_within(frame: Frame, cutoff: float):
    """Index pairs ``a < b`` whose centres are closer than ``cutoff`` (minimum image on
    periodic axes).

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
    if len(lo) == 0:
        return lo, hi
    uniq = np.unique(np.column_stack([lo, hi]), axis=0)
    return uniq[:, 0], uniq[:, 1]


_pairs_within = pairs_within  # the name used before


# -- glued-sphere rods -------------------------------------------------------------------------
def glued_bodies(frame: Frame, body) -> tuple[Frame, np.ndarray]:
    """Rods made of glued equal spheres as one frame of spherocylinders.

    ``body`` (N,) labels each sphere with its body id (e.g. the LAMMPS molecule id).
    Returns the body frame (ids = sorted body labels; centre = mean of the sphere
    centres, unwrapped by minimum image; axis = principal axis of the sphere centres,
    oriented from the body's first sphere to its last in row order; spine length ``L`` =
    extent of the sphere centres along it; radius = the largest sphere radius) and the
    body row of every sphere (N,).
    """
    body = np.asarray(body)
    if body.shape != (frame.n,):
        raise ValueError(f"body must label each of the {frame.n} spheres, got shape {body.shape}")
    labels, row = np.unique(body, return_inverse=True)
    m = len(labels)
    first = np.full(m, frame.n)
    np.minimum.at(first, row, np.arange(frame.n))
    last = np.full(m, -1)
    np.maximum.at(last, row, np.arange(frame.n))
    rel = frame.minimum_image(frame.x - frame.x[first[row]])
    count = np.bincount(row, minlength=m).astype(float)
    mean = np.zeros((m, 3))
    np.add.at(mean, row, rel)
    mean /= count[:, None]
    dev = rel - mean[row]
    gyr = np.zeros((m, 3, 3))
    np.add.at(gyr, row, dev[:, :, None] * dev[:, None, :])
    _, vec = np.linalg.eigh(gyr)
    axis = vec[:, :, -1]
    single = count == 1
    axis[single] = [0.0, 0.0, 1.0]
    span = rel[last] - rel[first]
    flip = np.sum(span * axis, axis=1) < 0
    axis[flip] *= -1
    proj = np.sum(dev * axis[row], axis=1)
    pmax = np.full(m, -np.inf)
    pmin = np.full(m, np.inf)
    np.maximum.at(pmax, row, proj)
    np.minimum.at(pmin, row, proj)
    radius = np.zeros(m)
    np.maximum.at(radius, row, frame.radius)
    centre = frame.x[first] + mean
    bodies = Frame(step=frame.step, ids=labels.astype(np.int64), types=np.ones(m, np.int64),
                   x=centre, radius=radius, axis=axis, length=np.where(single, 0.0, pmax - pmin),
                   box_lo=frame.box_lo.copy(), box=frame.box.copy(), periodic=frame.periodic.copy(),
                   dimension=frame.dimension)
    return bodies, row


def merge_glued_contacts(frame: Frame, contacts: Contacts, body) -> tuple[Contacts, np.ndarray]:
    """Body-body contacts of glued-sphere rods from their sphere-sphere contacts.

    Contacts inside one body are dropped; the contacts between two bodies become one row:
    ``i < j`` body ids, force = sum of the forces on ``i``, point = force-weighted mean of
    the points (plain mean when all forces vanish; minimum image), normal = normalised
    sum of the normals, overlap = the largest. Wall rows (``j <= 0``) are
    merged per (body, wall id). Returns the table and the number of sphere contacts merged
    into each row.
    """
    body = np.asarray(body)
    labels, row = np.unique(body, return_inverse=True)
    pp, walls = split_wall_contacts(frame, contacts)
    bi = row[frame.index_of(pp.i)]
    bj = row[frame.index_of(pp.j)]
    inter = bi != bj
    bi, bj = bi[inter], bj[inter]
    normal, force, point, overlap = (pp.normal[inter], pp.force[inter], pp.point[inter],
                                     pp.overlap[inter])
    swap = bi > bj
    bi, bj = np.where(swap, bj, bi), np.where(swap, bi, bj)
    normal = np.where(swap[:, None], -normal, normal)
    force = np.where(swap[:, None], -force, force)
    # wall rows: keyed by (body, -1 - wall index) so that they sort after particle pairs
    wb = row[frame.index_of(walls.i)]
    wids, wk = np.unique(walls.j, return_inverse=True)
    keys = np.column_stack([np.concatenate([bi, wb]),
                            np.concatenate([bj, len(labels) + wk])])
    normal = np.concatenate([normal, walls.normal])
    force = np.concatenate([force, walls.force])
    point = np.concatenate([point, walls.point])
    overlap = np.concatenate([overlap, walls.overlap])
    if len(keys) == 0:
        return Contacts.empty(contacts.step), np.zeros(0, np.int64)
    uniq, g = np.unique(keys, axis=0, return_inverse=True)
    g = g.ravel()
    m = len(uniq)
    mult = np.bincount(g, minlength=m)
    f_sum = np.zeros((m, 3))
    np.add.at(f_sum, g, force)
    n_sum = np.zeros((m, 3))
    np.add.at(n_sum, g, normal)
    first = np.full(m, len(g))
    np.minimum.at(first, g, np.arange(len(g)))
    rel = frame.minimum_image(point - point[first[g]])
    fmag = np.linalg.norm(force, axis=1)
    wsum = np.bincount(g, weights=fmag, minlength=m)
    wt = np.where(wsum[g] > 0, fmag / np.where(wsum[g] > 0, wsum[g], 1.0), 1.0 / mult[g])
    p_sum = np.zeros((m, 3))
    np.add.at(p_sum, g, rel * wt[:, None])
    ov = np.full(m, -np.inf)
    np.maximum.at(ov, g, overlap)
    nn = np.linalg.norm(n_sum, axis=1)
    normal_m = n_sum / np.where(nn > 0, nn, 1.0)[:, None]
    jb = uniq[:, 1]
    is_wall = jb >= len(labels)
    j_ids = np.empty(m, np.int64)
    j_ids[~is_wall] = labels[jb[~is_wall]]
    j_ids[is_wall] = wids[jb[is_wall] - len(labels)]
    out = Contacts(contacts.step, labels[uniq[:, 0]].astype(np.int64), j_ids.astype(np.int64),
                   point[first] + p_sum, normal_m, ov, f_sum)
    return out, mult
