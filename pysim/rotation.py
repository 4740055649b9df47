"""Quaternions and the exact free rotation of an axisymmetric body.

Orientations are unit quaternions ``q = (w, x, y, z)`` rotating body coordinates into
lab coordinates; the body symmetry (spine) axis is the body ``z`` axis, so the spine
direction is ``u = R(q) e_z``.

Free rotation of a symmetric top (moments ``I_perp``, ``I_perp``, ``I_axis``) with
constant lab angular momentum ``L`` is exactly: a rotation about ``L`` by
``|L| t / I_perp`` (the precession of ``u``) composed with a spin about the body axis by
``(L . u)(1/I_axis - 1/I_perp) t``. :func:`free_rotate` applies that flow, so the
rotational drift of the integrator is exact and only the torque kicks are split.
"""
from __future__ import annotations

import numpy as np

from pysim.jit import njit, pnjit, prange


@njit
def quat_mul(a0, a1, a2, a3, b0, b1, b2, b3):
    """Hamilton product ``a b`` of two quaternions given as components."""
    return (a0 * b0 - a1 * b1 - a2 * b2 - a3 * b3,
            a0 * b1 + a1 * b0 + a2 * b3 - a3 * b2,
            a0 * b2 - a1 * b3 + a2 * b0 + a3 * b1,
            a0 * b3 + a1 * b2 - a2 * b1 + a3 * b0)


@njit
def axis_from(w, x, y, z):
    """Spine direction ``R(q) e_z`` of the quaternion ``(w, x, y, z)``."""
    return 2.0 * (x * z + w * y), 2.0 * (y * z - w * x), 1.0 - 2.0 * (x * x + y * y)


@njit
def axis_of(q, i, u):
    """Spine direction ``u[i] = R(q[i]) e_z`` (in place)."""
    u[i, 0], u[i, 1], u[i, 2] = axis_from(q[i, 0], q[i, 1], q[i, 2], q[i, 3])


@pnjit
def axes(q, u):
    """All spine directions from all quaternions (in place; on threads)."""
    for i in prange(q.shape[0]):
        axis_of(q, i, u)


@njit
def rotate_top(w, x, y, z, l0, l1, l2, ux, uy, uz, i_perp, i_axis, dt):
    """Orientation ``(w, x, y, z)`` advanced by ``dt`` of free symmetric-top motion with
    lab angular momentum ``L = (l0, l1, l2)``; ``(ux, uy, uz)`` is the current spine axis.
    Returns the new unit quaternion."""
    ln = np.sqrt(l0 * l0 + l1 * l1 + l2 * l2)
    if ln > 0.0:
        half = 0.5 * ln * dt / i_perp
        sh = np.sin(half) / ln
        w, x, y, z = quat_mul(np.cos(half), l0 * sh, l1 * sh, l2 * sh, w, x, y, z)
    if i_axis != i_perp:
        spin = (l0 * ux + l1 * uy + l2 * uz) * (1.0 / i_axis - 1.0 / i_perp) * dt
        if spin != 0.0:
            # body-frame rotation about e_z: right multiplication
            w, x, y, z = quat_mul(w, x, y, z, np.cos(0.5 * spin), 0.0, 0.0, np.sin(0.5 * spin))
    norm = np.sqrt(w * w + x * x + y * y + z * z)
    return w / norm, x / norm, y / norm, z / norm


@njit
def free_rotate(q, i, l0, l1, l2, ux, uy, uz, i_perp, i_axis, dt):
    """:func:`rotate_top` applied to ``q[i]`` in place."""
    q[i, 0], q[i, 1], q[i, 2], q[i, 3] = rotate_top(q[i, 0], q[i, 1], q[i, 2], q[i, 3], l0, l1,
                                                    l2, ux, uy, uz, i_perp, i_axis, dt)


def quaternions_from_axes(u: np.ndarray) -> np.ndarray:
    """Unit quaternions (N, 4) that rotate ``e_z`` onto the unit vectors ``u`` (N, 3)
    (the shortest-arc rotation; the spin about the axis is zero)."""
    u = np.asarray(u, dtype=np.float64)
    u = u / np.linalg.norm(u, axis=1, keepdims=True)
    q = np.empty((len(u), 4))
    # rotation axis e_z x u = (-u_y, u_x, 0), angle acos(u_z)
    w = 1.0 + u[:, 2]
    q[:, 0] = w
    q[:, 1] = -u[:, 1]
    q[:, 2] = u[:, 0]
    q[:, 3] = 0.0
    anti = w < 1e-12  # u = -e_z: rotate by pi about x
    q[anti] = [0.0, 1.0, 0.0, 0.0]
    return q / np.linalg.norm(q, axis=1, keepdims=True)


def inertia_lab_inverse(omega_or_torque, u, i_perp, i_axis):
    """``I^-1 a`` for an axisymmetric body with axis ``u``: ``a/I_perp + (1/I_axis -
    1/I_perp)(a.u)u`` (NumPy, for tests and diagnostics)."""
    a = np.asarray(omega_or_torque, dtype=np.float64)
    return a / i_perp[:, None] + ((1 / i_axis - 1 / i_perp) * np.sum(a * u, axis=1))[:, None] * u
