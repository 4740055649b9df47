"""Vibrational modes of a mechanically stable 2-D packing (science.md, 2-D jamming study,
stretch goal): the Hessian of the elastic energy with its stiffness and stress parts, the
dynamical matrix, its density of states, the participation ratio and the character of
each mode.

Degrees of freedom (:func:`dofs`, rows ``(particle row, component)``): the centre
``x, y`` (components 0, 1) and, for rods, the spine angle ``theta`` (component 2;
frictionless disks have no rotational stiffness). The energy is a sum over **bonds**
(science.md's soft harmonic law, ``V(delta) = k_n/2 (delta/d)^2``, ``d = R_i + R_j``):
one per touching pair of disks, and for rods the four end bonds of a pair (each end of
one spine against the closest point of the other, pysim's ``spine_contact: end_bonds``,
:func:`pysim.contacts.end_bond`). For a bond between spine points ``p_i = x_i + s u_i``
and ``p_j = x_j + t u_j``, ``r = p_j - p_i``, ``D = |r|``, ``n = r/D``, ``J = dr/dq``
and ``P = 1 - n n^T``:

    delta = R_i + R_j - D,   grad delta = -n^T J,
    grad grad D = J^T P J / D + n . d^2 r/dq^2   (d^2 r/d theta_i^2 = s u_i,
                                                   d^2 r/d theta_j^2 = -t u_j),

and where the closest point (``t``, or ``s``) lies inside its spine it slides with the
packing, which subtracts ``D_qm D_mq / D_mm`` (``m`` its parameter; envelope theorem).
``H = H_k + H_s`` with the **stiffness part** ``H_k = sum_b V'' grad delta grad delta^T``
and the **stress part** ``H_s = sum_b V' grad grad delta``, proportional to the bond
forces ``V' = k_n delta / d^2``. The dynamical matrix is ``D = M^(-1/2) H M^(-1/2)``,
its eigenvalues ``omega^2``: with ``M`` the masses and moments of inertia
(:func:`dof_masses`), or, as Marschall & Teitel (2018) define it, the Hessian in the
coordinates ``(x, y, A theta)`` (:func:`dof_lengths`), which moves rotational modes by
orders of magnitude for nearly round rods. Units: those
of the positions and of ``k_n``; angles in radians.
"""
from __future__ import annotations

import numpy as np

from analysis.frame import Frame

_PERP = np.array([[0.0, -1.0], [1.0, 0.0]])  # z x (a vector in the plane)


def dofs(frame: Frame, keep: np.ndarray | None = None) -> np.ndarray:
    """The degrees of freedom ``(n_dof, 2)``: rows ``(particle row, component)``,
    component 0 = x, 1 = y, 2 = spine angle (rods only), for the particles in ``keep``
    (boolean mask, all by default), in particle order."""
    keep = np.ones(frame.n, bool) if keep is None else np.asarray(keep, bool)
    rows = []
    for i in np.flatnonzero(keep):
        rows += [(i, 0), (i, 1)] + ([(i, 2)] if frame.length[i] > 0 else [])
    return np.array(rows, dtype=np.int64).reshape(-1, 2)


def _bonds(frame: Frame, i: int, j: int, end_bonds: bool, distinct: bool = False):
    """The bonds of pair ``(i, j)``: tuples ``(s, t, sliding)`` with ``sliding`` 0 (none),
    1 (``s`` inside spine i) or 2 (``t`` inside spine j). ``distinct``: a bond joining the
    same two spine points as an earlier one is left out (``spine_contact:
    end_bonds_distinct``, :func:`pysim.contacts.kinematics.repeats_bond`)."""
    hi, hj = 0.5 * frame.length[i], 0.5 * frame.length[j]
    if not end_bonds:
        if hi > 0 or hj > 0:
            raise ValueError("the Hessian of rods is implemented for end bonds "
                             "(contact.spine_contact: end_bonds): the closest-point law "
                             "has a kink at parallel contacts")
        return [(0.0, 0.0, 0)]
    from analysis.geometry import end_bond_params

    d = frame.minimum_image(frame.x[j] - frame.x[i])
    s, t = end_bond_params(d, frame.axis[i], hi, frame.axis[j], hj)
    s, t = s[0], t[0]
    keep = [k for k in range(4)
            if not (distinct and any(s[m] == s[k] and t[m] == t[k] for m in range(k)))]
    # a closest point inside its spine slides with the packing (2: on j, 1: on i)
    return [(float(s[k]), float(t[k]),
             (2 if abs(t[k]) < hj else 0) if k < 2 else (1 if abs(s[k]) < hi else 0))
            for k in keep]


def hessian_parts(frame: Frame, pairs: np.ndarray, dof: np.ndarray, k_n: float = 1.0,
                  end_bonds: bool = True, distinct: bool = False
                  ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(H_k, H_s, grad U)`` of the harmonic bonds of the touching ``pairs`` (rows of
    particle-row pairs; pairs that do not touch add nothing): the stiffness and stress
    parts of the Hessian over ``dof`` and the energy gradient (minus the generalised forces
    ``F_x, F_y, tau_z``), in units of ``k_n`` / length^2, ``k_n`` / length. ``end_bonds``:
    whether pairs touch through the four end bonds, as pysim's pairs do under
    ``spine_contact: end_bonds`` in a packing with rods (then every pair, disks too);
    ``distinct``: a bond that joins the same two points as another counts once
    (``spine_contact: end_bonds_distinct``)."""
    col = np.full((frame.n, 3), -1, dtype=np.int64)
    col[dof[:, 0], dof[:, 1]] = np.arange(len(dof))
    hk = np.zeros((len(dof), len(dof)))
    hs = np.zeros_like(hk)
    grad = np.zeros(len(dof))
    for i, j in np.asarray(pairs, dtype=np.int64).reshape(-1, 2):
        dsep = frame.minimum_image(frame.x[j] - frame.x[i])[:2]
        ui, uj = frame.axis[i, :2], frame.axis[j, :2]
        rsum = frame.radius[i] + frame.radius[j]
        local = np.array([col[i, 0], col[i, 1], col[i, 2], col[j, 0], col[j, 1], col[j, 2]])
        ok = np.flatnonzero(local >= 0)
        for s, t, sliding in _bonds(frame, i, j, end_bonds, distinct):
            r = dsep + t * uj - s * ui
            dist = float(np.hypot(r[0], r[1]))
            delta = rsum - dist
            if delta <= 0:
                continue
            n = r / dist
            jac = np.zeros((2, 6))  # dr/dq over (x_i, y_i, theta_i, x_j, y_j, theta_j)
            jac[:, 0:2] = -np.eye(2)
            jac[:, 3:5] = np.eye(2)
            jac[:, 2] = -s * (_PERP @ ui)
            jac[:, 5] = t * (_PERP @ uj)
            proj = np.eye(2) - np.outer(n, n)
            dqq = jac.T @ proj @ jac / dist
            dqq[2, 2] += s * float(n @ ui)
            dqq[5, 5] -= t * float(n @ uj)
            if sliding:
                m = -ui if sliding == 1 else uj
                dqm = m @ proj @ jac / dist
                dqm[2 if sliding == 1 else 5] += float(n @ (_PERP @ m))
                dqq -= np.outer(dqm, dqm) / (float(m @ proj @ m) / dist)
            g = -(n @ jac)  # grad delta
            v1 = k_n * delta / rsum**2  # V'
            v2 = k_n / rsum**2  # V''
            sel = np.ix_(local[ok], local[ok])
            hk[sel] += v2 * np.outer(g[ok], g[ok])
            hs[sel] -= v1 * dqq[np.ix_(ok, ok)]
            grad[local[ok]] += v1 * g[ok]
    return hk, hs, grad


def dof_masses(mass: np.ndarray, inertia: np.ndarray, dofs: np.ndarray) -> np.ndarray:
    """Mass of each degree of freedom: ``m_i`` for centres, ``I_i`` (about the axis
    normal to the plane) for angles."""
    return np.where(dofs[:, 1] < 2, mass[dofs[:, 0]], inertia[dofs[:, 0]])


def dof_lengths(half_length: np.ndarray, dofs: np.ndarray) -> np.ndarray:
    """Weights of Marschall & Teitel's (2018) dynamical matrix, Eq. 23, for
    :func:`normal_modes`: it is the Hessian in the coordinates ``(x, y, A theta)`` with no
    masses, so 1 for centres and ``A_i^2`` (``A_i`` the spine half-length) for angles."""
    return np.where(dofs[:, 1] < 2, 1.0, np.asarray(half_length, float)[dofs[:, 0]] ** 2)


def normal_modes(hessian: np.ndarray, masses: np.ndarray):
    """Eigenvalues ``omega^2`` (ascending) and mass-weighted unit eigenvectors (columns) of
    ``D = M^(-1/2) H M^(-1/2)``, ``H`` symmetrised first."""
    w = 1.0 / np.sqrt(masses)
    d = 0.5 * (hessian + hessian.T) * w[:, None] * w[None, :]
    return np.linalg.eigh(d)


def participation_ratio(vecs: np.ndarray, dofs: np.ndarray) -> np.ndarray:
    """Participation ratio of each mode (column of ``vecs``),
    ``PR = (sum_i |e_i|^2)^2 / (N' sum_i |e_i|^4)`` with ``|e_i|^2`` summed over particle
    ``i``'s degrees of freedom and ``N'`` the particles: 1 for a mode spread evenly, 1/N'
    for one on a single particle."""
    owner = np.unique(dofs[:, 0], return_inverse=True)[1]
    npart = owner.max() + 1
    per = np.zeros((npart, vecs.shape[1]))
    np.add.at(per, owner, vecs**2)
    return per.sum(axis=0) ** 2 / (npart * (per**2).sum(axis=0))


def mode_character(vecs: np.ndarray, dofs: np.ndarray, axis: np.ndarray) -> np.ndarray:
    """``(n_modes, 3)`` fractions of each mass-weighted unit mode in rotations, in
    translations parallel to the particle's spine and perpendicular to it (they sum to
    1; disks count as translations split by their stored ``axis``)."""
    rot = dofs[:, 1] == 2
    out = np.zeros((vecs.shape[1], 3))
    out[:, 0] = (vecs[rot] ** 2).sum(axis=0)
    xs = np.flatnonzero(dofs[:, 1] == 0)
    ys = np.flatnonzero(dofs[:, 1] == 1)
    u = axis[dofs[xs, 0], :2]
    par = u[:, 0:1] * vecs[xs] + u[:, 1:2] * vecs[ys]
    perp = -u[:, 1:2] * vecs[xs] + u[:, 0:1] * vecs[ys]
    out[:, 1] = (par**2).sum(axis=0)
    out[:, 2] = (perp**2).sum(axis=0)
    return out


def mode_table(omega2: np.ndarray, vecs: np.ndarray, dofs: np.ndarray,
               axis: np.ndarray) -> dict:
    """Per-mode columns for a table: ``omega`` (``sqrt`` of ``omega^2``, negative where
    ``omega^2 < 0``), ``omega2``, ``pr`` and the ``rotational``, ``parallel`` and
    ``perpendicular`` fractions."""
    ch = mode_character(vecs, dofs, axis)
    return {"omega": np.sign(omega2) * np.sqrt(np.abs(omega2)), "omega2": omega2,
            "pr": participation_ratio(vecs, dofs), "rotational": ch[:, 0],
            "parallel": ch[:, 1], "perpendicular": ch[:, 2]}


def bands(omega2: np.ndarray, n_bands: int, zero: float, floor: bool = False) -> np.ndarray:
    """Band of each mode (0 the lowest): the modes ordered by frequency, split at the
    ``n_bands - 1`` widest gaps of ``log omega``. Marschall & Teitel (2018, Sec. III.D)
    find two bands at alpha = 0.01 and three at alpha = 1 and 4, separated by gaps of
    decades. Modes at or below ``zero`` (``omega^2 <= zero``: the translations and
    modes within the eigensolver's resolution) have no measurable frequency: they are
    band -1, or, with ``floor``, band 0, below ``n_bands - 1`` bands split among the
    others. The paper's lowest band at alpha >= 1 (rods sliding along their spines,
    ``omega ~ 1e-8`` at ``U/L^2 = 1e-15``) lies there; its three fractions sum to one,
    so its lowest band holds the translations as well."""
    if n_bands < 1:
        raise ValueError(f"n_bands must be at least 1, got {n_bands}")
    omega2 = np.asarray(omega2, float)
    out = np.full(omega2.shape, 0 if floor else -1, np.int64)
    live = np.flatnonzero(omega2 > zero)
    split = n_bands - 1 if floor else n_bands
    if split == 0:
        return out
    if len(live) < split:
        raise ValueError(f"{len(live)} nonzero modes cannot form {split} bands")
    order = live[np.argsort(omega2[live], kind="stable")]
    gaps = np.diff(np.log(omega2[order]))  # log omega^2 = 2 log omega: same order of gaps
    cuts = np.sort(np.argsort(gaps, kind="stable")[::-1][: split - 1]) + 1
    out[order] = np.searchsorted(cuts, np.arange(len(order)), side="right") + (1 if floor else 0)
    return out


def band_means(omega2: np.ndarray, sizes, zero: float, skip: int = 0) -> np.ndarray:
    """Mean frequency ``omega`` of consecutive groups of modes in ascending order of
    ``omega^2``, after the lowest ``skip`` (the translations): the first ``sizes[0]``
    modes, the next ``sizes[1]``, ...: the bands of a stable state followed to a
    compressed one, where its gaps narrow and the bands merge (Marschall & Teitel 2018,
    Figs. 14, 18, 20). A group with more than half its modes at or below ``zero``
    (``omega^2 <= zero``, below the eigensolver's resolution) has no measured mean, nor
    has an empty group: NaN; otherwise such modes count as ``omega = 0``."""
    w2 = np.sort(np.asarray(omega2, float))[skip:]
    edges = np.concatenate([[0], np.cumsum(sizes)]).astype(int)
    if edges[-1] > len(w2) or np.any(np.diff(edges) < 0):
        raise ValueError(f"band sizes {list(sizes)} do not fit {len(w2)} modes")
    omega = np.where(w2 > zero, np.sqrt(np.abs(w2)), 0.0)
    out = []
    for a, b in zip(edges[:-1], edges[1:]):
        resolved = int(np.sum(w2[a:b] > zero))
        out.append(omega[a:b].mean() if b > a and 2 * resolved >= b - a else np.nan)
    return np.array(out)
