"""Caged particles of a frame: do a particle's own contacts arrest it?

Wouterse, Luding & Philipse (Sec. 3.1, Figs. 6 and 7) call a particle caged when its
contacts with its neighbours block its motion: the translations of a sphere, the
translations and rotations perpendicular to the axis of a rod ("for the caging of rods
only the blocking of translations and rotations perpendicular to the axis of symmetry
were checked"); rattlers are not removed. The decision for a set of frictionless point
contacts is that of :mod:`analysis.caging` (a contact at ``r`` from the centre with
outward normal ``m`` forbids the rigid motions ``q = (V, omega)`` with ``a . q > 0``,
``a = (m, r x m)``), here with the particle's real contacts:

* every row of the contact table with a positive overlap (C counts those too); a row
  ``(i, j)`` with normal ``n`` (from ``i`` to ``j``) at point ``p`` acts on ``i`` with
  outward normal ``n`` and lever ``p - x_i``, and on ``j`` with ``-n`` and ``p - x_j``
  (minimum image of the periodic box); wall rows (``j <= 0``) act on ``i`` alone;
* rows are written in the particle's body frame (3-D spine along ``z``, 2-D along
  ``x``), so that the blocked degrees of freedom are those of
  :func:`analysis.caging.default_dofs`; rotations are in units of ``ell = L/2 + R`` (the
  column ``r x m / ell``: the decision does not change under a positive scaling of a
  column, and all entries are then of order one);
* exact geometry is restored where the table's rounding (10 digits) would blur it, because
  the signs of that noise in a degree of freedom left free can decide a cage (a large
  free motion times a tiny entry): the rotations frictionless contacts can never block
  get a zero column, all of them for a sphere or disk (``r`` is parallel to ``m``) and
  the spin about a 3-D spine (every normal meets the axis; rounding leaves about 1e-8);
  and a contact on the flat side of a rod (its point projects inside the spine, ``|r .
  u| < L/2``) gets a normal exactly perpendicular to the spine (the closest point of the
  spine is then interior; rounding leaves about 1e-10 along ``u``, while on the caps of
  real packings ``|m . u|`` stays above 1e-4), so that the axial translation, free by
  default, is not coupled to the others by noise.
"""
from __future__ import annotations

import numpy as np

from analysis.base import Observable
from analysis.caging import _dof_index, constraint_rows, decide_caged, default_dofs
from analysis.frame import Contacts, Frame


def contact_ends(frame: Frame, contacts: Contacts):
    """Every contact as seen by each particle it touches: ``(owner, lever, normal)``
    with ``owner`` (M,) frame rows, ``lever`` (M, 3) contact point minus the owner's
    centre (minimum image) and ``normal`` (M, 3) the outward normal of the owner (the
    table's normal for ``i``, its negative for ``j``). Rows with ``overlap <= 0`` are
    left out; wall rows (``j <= 0``) give one end, on ``i``."""
    touch = np.asarray(contacts.overlap) > 0
    i = frame.index_of(contacts.i[touch])
    j_id = contacts.j[touch]
    pp = j_id > 0
    j = frame.index_of(j_id[pp])
    point = contacts.point[touch]
    normal = contacts.normal[touch]
    owner = np.concatenate([i, j])
    pts = np.concatenate([point, point[pp]])
    nrm = np.concatenate([normal, -normal[pp]])
    lever = frame.minimum_image(pts - frame.x[owner])
    return owner, lever, nrm


def body_frames(frame: Frame) -> np.ndarray:
    """Orthonormal body axes (N, 3, 3), rows ``(e1, e2, u)`` in 3-D with ``u`` the spine;
    in 2-D ``(u, u_perp, z)`` (the spine along the first axis, as the 2-D caging
    degrees of freedom have it)."""
    u = frame.axis / np.linalg.norm(frame.axis, axis=1)[:, None]
    n = frame.n
    out = np.zeros((n, 3, 3))
    if frame.dim == 2:
        # disks carry the +z axis of spheres; any in-plane direction serves them
        flat = np.linalg.norm(u[:, :2], axis=1)
        out[:, 0, 0] = np.where(flat > 0, u[:, 0] / np.where(flat > 0, flat, 1.0), 1.0)
        out[:, 0, 1] = np.where(flat > 0, u[:, 1] / np.where(flat > 0, flat, 1.0), 0.0)
        out[:, 1, 0], out[:, 1, 1] = -out[:, 0, 1], out[:, 0, 0]
        out[:, 2, 2] = 1.0
        return out
    # any unit vector perpendicular to u: the blocked set is symmetric about the spine
    helper = np.where((np.abs(u[:, 0]) < 0.9)[:, None], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0])
    e1 = np.cross(u, helper)
    e1 /= np.linalg.norm(e1, axis=1)[:, None]
    out[:, 0], out[:, 1], out[:, 2] = e1, np.cross(u, e1), u
    return out


def body_rows(frame: Frame, owner: np.ndarray, lever: np.ndarray,
              normal: np.ndarray) -> np.ndarray:
    """Constraint rows (M, 6) in 3-D, (M, 3) in 2-D of contact ends (:func:`contact_ends`)
    in their owner's body frame, rotations in units of ``L/2 + R``, unblockable rotation
    columns zero (module docstring)."""
    axes = body_frames(frame)[owner]
    r = np.einsum("mab,mb->ma", axes, lever)
    m = np.einsum("mab,mb->ma", axes, normal)
    rod = frame.length[owner] > 0
    ell = 0.5 * frame.length[owner] + frame.radius[owner]
    along = 0 if frame.dim == 2 else 2  # the spine's body axis
    side = rod & (np.abs(r[:, along]) < 0.5 * frame.length[owner])
    m[side, along] = 0.0
    m[side] /= np.linalg.norm(m[side], axis=1)[:, None]
    if frame.dim == 2:
        rows = constraint_rows(r[:, :2], m[:, :2])
        rows[:, 2] = np.where(rod, rows[:, 2] / ell, 0.0)
        return rows
    rows = constraint_rows(r, m)
    rows[:, 3:5] = np.where(rod[:, None], rows[:, 3:5] / ell[:, None], 0.0)
    rows[:, 5] = 0.0
    return rows


def caged_particles(frame: Frame, contacts: Contacts, block_axial: bool = False):
    """``(caged, how)``: (N,) bool, whether each particle's contacts in this frame cage
    it (module docstring; rods also in their axial translation with ``block_axial``,
    the paper's Fig. 11), and (N,) the test of :func:`analysis.caging.decide_caged` that
    decided (``"count"``, ``"sign"``, ``"nnls"``, ``"lp"``)."""
    dim = frame.dim
    owner, lever, normal = contact_ends(frame, contacts)
    rows = body_rows(frame, owner, lever, normal)
    order = np.argsort(owner, kind="stable")
    rows = rows[order]
    count = np.bincount(owner, minlength=frame.n)
    start = np.concatenate([[0], np.cumsum(count)])
    blocked = {rod: _dof_index(dim, float(rod), default_dofs(dim, float(rod), block_axial))
               for rod in (False, True)}
    caged = np.zeros(frame.n, bool)
    how = np.full(frame.n, "count", dtype=object)
    for p in range(frame.n):
        b = blocked[bool(frame.length[p] > 0)]
        if count[p] <= len(b):  # decide_caged's counting bound, without the call
            continue
        caged[p], how[p] = decide_caged(rows[start[p]:start[p + 1]], b)
    return caged, how


class CagedParticles(Observable):
    """Caged particles of one frame (Wouterse, Luding & Philipse, Figs. 6 and 7).

    Parameters: ``block_axial`` (rods: also block the translation along the spine; the
    paper's Figs. 6, 7 leave it free). ``compute(frame, contacts)``.

    Results: ``caged`` (N,) bool, ``n_caged``, ``noncaged_fraction`` (non-caged particles
    over all ``N``, rattlers included), ``decided_by`` ``{test: particles}``
    (:func:`analysis.caging.decide_caged`).
    """

    _results = ("caged", "n_caged", "noncaged_fraction", "decided_by")

    def __init__(self, block_axial: bool = False):
        self.block_axial = bool(block_axial)

    def compute(self, frame: Frame, contacts: Contacts | None = None):
        if contacts is None:
            raise ValueError("CagedParticles needs the frame's contact table")
        caged, how = caged_particles(frame, contacts, self.block_axial)
        n_caged = int(np.count_nonzero(caged))
        tests, counts = np.unique(how.astype(str), return_counts=True)
        self._set(caged=caged, n_caged=n_caged,
                  noncaged_fraction=1.0 - n_caged / frame.n if frame.n else float("nan"),
                  decided_by={str(t): int(c) for t, c in zip(tests, counts)})
        return self
