"""Contact laws: small scalar functions plugged into the one contact loop.

Sign convention: ``delta > 0`` is the overlap, ``ddelta`` its rate of change
(``> 0`` while approaching); the returned normal force magnitude is repulsive when
positive. The force on particle ``i`` is ``-f_n n`` with ``n`` the unit normal from
``i`` to ``j``.

Laws are selected by an integer id so that kernels stay monomorphic and cacheable:

==============  ==  ================================================  ============
law             id  formula                                           params
==============  ==  ================================================  ============
``hooke``        0  ``f_n = k_n delta + gamma_n d(delta)/dt``         ``k_n, gamma_n``
``hertz``        1  ``f_n = k_n delta^(3/2) + gamma_n d(delta)/dt``   ``k_n, gamma_n``
==============  ==  ================================================  ============
"""
from __future__ import annotations

import numpy as np

from pysim.jit import njit

HOOKE = 0
HERTZ = 1
LAW_IDS = {"hooke": HOOKE, "hertz": HERTZ}


@njit
def normal_force(law, params, delta, ddelta):
    """Normal force magnitude for overlap ``delta`` and overlap rate ``ddelta``.

    ``hooke``: linear spring-dashpot ``f_n = k_n delta + gamma_n ddelta``
    (science.md section 3); ``hertz``: ``f_n = k_n delta^(3/2) + gamma_n ddelta``.
    Damping is absolute (force per velocity), as LAMMPS ``damping velocity`` and
    LIGGGHTS ``absolute_damping on``. No force limiting: a contact may pull briefly
    at the end of a damped collision, as in both peers' defaults.
    """
    kn = params[0]
    gamma_n = params[1]
    if law == HOOKE:
        return kn * delta + gamma_n * ddelta
    return kn * delta * np.sqrt(delta) + gamma_n * ddelta


@njit
def elastic_energy(law, params, delta):
    """Elastic energy stored in one contact: ``k delta^2 / 2`` or ``2/5 k delta^(5/2)``."""
    kn = params[0]
    if law == HOOKE:
        return 0.5 * kn * delta * delta
    return 0.4 * kn * delta * delta * np.sqrt(delta)
