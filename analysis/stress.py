"""Stress from contact forces.

Per particle ``sigma^i_ab = sum_c l^c_a F^c_b`` with ``l^c`` from the centre of
``i`` to the contact point and ``F^c`` the force on ``i``; over a volume ``V``,
``sigma_ab = (1/V) sum_i sigma^i_ab`` (tension positive). The pressure is
``p = -tr(sigma)/d`` (science.md section 5).
"""
from __future__ import annotations

import numpy as np

from analysis.frame import Contacts, Frame


def _branch(frame: Frame, rows: np.ndarray, point: np.ndarray) -> np.ndarray:
    """Branch vectors from particle centres to contact points (minimum image)."""
    l = point - frame.x[rows]
    return l - frame.box * np.floor(l / frame.box + 0.5) * frame.periodic


def particle_stress(frame: Frame, contacts: Contacts) -> np.ndarray:
    """``sigma^i`` (N, 3, 3): ``sum_c l^c_a F^c_b`` over the contacts of each particle
    (force units x length)."""
    a = frame.index_of(contacts.i)
    b = frame.index_of(contacts.j)
    la = _branch(frame, a, contacts.point)
    lb = _branch(frame, b, contacts.point)
    out = np.zeros((frame.n, 3, 3))
    np.add.at(out, a, la[:, :, None] * contacts.force[:, None, :])
    np.add.at(out, b, lb[:, :, None] * (-contacts.force)[:, None, :])
    return out


def stress_tensor(frame: Frame, contacts: Contacts) -> np.ndarray:
    """Box-averaged contact stress ``sigma_ab = (1/V) sum_i sigma^i_ab`` (3, 3)."""
    return particle_stress(frame, contacts).sum(axis=0) / frame.volume


def pressure(frame: Frame, contacts: Contacts, dim: int = 3) -> float:
    """Contact pressure ``p = -tr(sigma)/d`` (force / length^(d-1))."""
    return float(-np.trace(stress_tensor(frame, contacts)) / dim)
