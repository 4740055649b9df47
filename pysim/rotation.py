"""Quaternions and the exact free rotation of an axisymmetric body.

Orientations are unit quaternions ``q = (w, x, y, z)`` rotating body coordinates into
lab coordinates; the body symmetry (spine) axis is the body ``z`` axis, so the spine
direction is ``u = R(q) e_z``.

Free rotation of a symmetric top (moments ``I_perp``, ``I_perp``, ``I_axis``) with
constant lab angular momentum ``L`` is exactly: a rotation about ``L`` by
``|L| t / I_perp`` (the precession of ``u``) composed with a spin about the body axis by
``(L . u)(1/I_axis - 1/I_perp) t``. :func:`free_rotate` applies that flow, so the
rotational drift of the integrator is exact and only the torque kicks are split.

The half-angles of a step (about ``|omega| dt/2``) are small in a resolved run: their
sines and cosines come from Taylor series (:func:`sincos`), the same operations for every
particle, so that a loop over particles runs on SIMD lanes
(:func:`pysim.integrators._half_and_half`); beyond :data:`SERIES_MAX` the library's
``sin`` and ``cos`` take over.
"""
from __future__ import annotations

import numpy as np

from pysim.jit import inline_njit, njit, pnjit, prange


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


#: the largest half-angle (rad) whose sine and cosine :func:`sincos` takes from its series:
#: there the truncation error is below 1e-17 (sine to degree 13, cosine to degree 14)
SERIES_MAX = 0.5
_S3, _S5, _S7, _S9, _S11, _S13 = (-1.0 / 6.0, 1.0 / 120.0, -1.0 / 5040.0, 1.0 / 362880.0,
                                  -1.0 / 39916800.0, 1.0 / 6227020800.0)
_C2, _C4, _C6, _C8, _C10, _C12, _C14 = (-0.5, 1.0 / 24.0, -1.0 / 720.0, 1.0 / 40320.0,
                                        -1.0 / 3628800.0, 1.0 / 479001600.0,
                                        -1.0 / 87178291200.0)


@inline_njit
def sincos(a, series):
    """``(sin a, cos a)``: with ``series`` (a constant) the Taylor series ``a - a^3/3! + ...
    + a^13/13!`` and ``1 - a^2/2! + ... - a^14/14!`` in Horner form, within rounding of the
    library's values for ``|a| <= SERIES_MAX`` and free of calls (SIMD lanes); else
    NumPy's ``sin`` and ``cos``."""
    if series:
        a2 = a * a
        s = a + a * a2 * (_S3 + a2 * (_S5 + a2 * (_S7 + a2 * (_S9 + a2 * (_S11 + a2 * _S13)))))
        c = 1.0 + a2 * (_C2 + a2 * (_C4 + a2 * (_C6 + a2 * (_C8 + a2 * (_C10 + a2 * (
            _C12 + a2 * _C14))))))
        return s, c
    return np.sin(a), np.cos(a)


@inline_njit
def top_rotation(w, x, y, z, l0, l1, l2, ux, uy, uz, rp, ra, dt, series):
    """:func:`rotate_top` without branches on the particle (SIMD lanes): the sines and
    cosines from :func:`sincos` with ``series``. Returns the new unit quaternion and
    whether both half-angles lie within :data:`SERIES_MAX` (with ``series`` the quaternion
    holds only then)."""
    ln = np.sqrt(l0 * l0 + l1 * l1 + l2 * l2)
    a = 0.5 * ln * dt * rp  # half the precession angle |L| dt / I_perp about L
    s, c = sincos(a, series)
    sh = s / ln if ln > 0.0 else 0.0
    w, x, y, z = quat_mul(c, l0 * sh, l1 * sh, l2 * sh, w, x, y, z)
    # half the spin angle about the body axis; body frame: right multiplication by
    # (cos b, 0, 0, sin b), written out
    b = 0.5 * (l0 * ux + l1 * uy + l2 * uz) * (ra - rp) * dt
    s, c = sincos(b, series)
    w, x, y, z = w * c - z * s, x * c + y * s, y * c - x * s, z * c + w * s
    # divided by the norm, not multiplied by its reciprocal: that rounding scales all four
    # components alike, and a free top's energy drifted by 1.1e-12 in 5000 steps
    norm = np.sqrt(w * w + x * x + y * y + z * z)
    return w / norm, x / norm, y / norm, z / norm, abs(a) <= SERIES_MAX and abs(b) <= SERIES_MAX


@njit
def rotate_top(w, x, y, z, l0, l1, l2, ux, uy, uz, rp, ra, dt):
    """Orientation ``(w, x, y, z)`` advanced by ``dt`` of free symmetric-top motion with
    lab angular momentum ``L = (l0, l1, l2)``: a rotation by ``|L| dt rp`` about ``L``
    composed with a spin by ``(L . u)(ra - rp) dt`` about the body axis (``rp``, ``ra``:
    ``1/I_perp``, ``1/I_axis``); ``(ux, uy, uz)`` is the current spine axis. Returns the
    new unit quaternion (:func:`top_rotation`, the library's sine and cosine past
    :data:`SERIES_MAX`)."""
    w1, x1, y1, z1, small = top_rotation(w, x, y, z, l0, l1, l2, ux, uy, uz, rp, ra, dt, True)
    if small:
        return w1, x1, y1, z1
    w1, x1, y1, z1, _ = top_rotation(w, x, y, z, l0, l1, l2, ux, uy, uz, rp, ra, dt, False)
    return w1, x1, y1, z1


@njit
def free_rotate(q, i, l0, l1, l2, ux, uy, uz, rp, ra, dt):
    """:func:`rotate_top` applied to ``q[i]`` in place."""
    q[i, 0], q[i, 1], q[i, 2], q[i, 3] = rotate_top(q[i, 0], q[i, 1], q[i, 2], q[i, 3], l0, l1,
                                                    l2, ux, uy, uz, rp, ra, dt)


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
