"""The kernels' scalar records: the parameters they read and the cache they write.

The integrators (:mod:`pysim.integrators`) take two records besides the arrays: ``params``
(:data:`PARAMS_DTYPE`, fields :data:`PARAM_FIELDS`), the physical and protocol parameters
that Python sets and the kernels only read, and ``cache`` (:data:`CACHE_DTYPE`, fields
:data:`CACHE_FIELDS`), what the kernels keep from call to call: the state of the last
list build, the motion bound since, the threads' bookkeeping, the largest overlap.

Each is a NumPy structured array of one element (:func:`new_params`, :func:`new_cache`).
Python sets and reads its fields by name (``sim.params["skin"] = 0.1``); a kernel takes
the element (``prm = params[0]``), a record whose field reads (``prm.skin``) Numba
compiles to one load at a fixed offset and whose writes land in the array. The array,
not its element, crosses from Python into the kernels: Numba types an array argument
from its dtype at once, a ``numpy.record`` through its fields at every call.
Checkpoints store both records by field name (:mod:`pysim.checkpoint`). Lengths, times
and masses are in the units of the case (pysim never converts units).
"""
from __future__ import annotations

import numpy as np

#: The parameters, written from Python only (``Simulation``), read by the kernels: name,
#: type (a shape for vectors), meaning and units.
PARAM_FIELDS = (
    ("gamma_bg", np.float64, "drag on translation, force ``-gamma_bg v`` (force/velocity)"),
    ("gamma_rot", np.float64, "drag on rotation, torque ``-gamma_rot omega`` "
                              "(torque/(1/time))"),
    ("gravity", (np.float64, 3), "acceleration of gravity, force ``m g`` (length/time^2)"),
    ("strain_rate", (np.float64, 3), "true strain rate of each box edge, ``L_k *= exp(eps_k "
                                     "dt)`` (1/time; 0 on fixed edges; ``-kappa`` in Heun)"),
    ("growth", np.float64, "particle growth rate, ``R, L *= exp(g dt)`` (1/time)"),
    ("skin", np.float64, "Verlet skin of the pair list (length)"),
    ("k_d", np.float64, "substrate drag of the overdamped integrator, ``F = k_d a (dr/dt + "
                        "kappa r)`` (force/velocity per unit of ``a``, the particle area in "
                        "2-D, volume in 3-D)"),
    ("parts", np.int64, "threads the kernels run on: the parts of the contact pass "
                        "(:func:`pysim.integrators.forces`)"),
    ("rods", np.bool_, "some particle has ``L > 0``: the rods' contact pass, spine "
                       "separations and rotation lanes"),
    ("dim2", np.bool_, "a 2-D run: no force out of the plane, no torque in it"),
)

#: The cache, written by the kernels (and reset from Python where the state is replaced):
#: name, type, meaning and units.
CACHE_FIELDS = (
    ("rint_build", np.float64, "largest interaction radius ``r_int`` at the last list build "
                               "(length): the growth since is ``max r_int`` over it"),
    ("rc_build", np.float64, "twice the largest contact reach ``r_int - L/2`` at the build "
                             "(length)"),
    ("half_build", np.float64, "largest half-length ``L/2`` at the build (length)"),
    ("sep_sigma", np.float64, "the motion bound's ``sigma`` since the build "
                              "(:func:`pysim.neighbors.motion_bound`; dimensionless); 0 "
                              "turns the skipping of pairs out of reach off"),
    ("sep_shrink", np.float64, "the motion bound's ``shrink`` since the build (length)"),
    ("worst", (np.float64, 2), "at the last :func:`pysim.integrators.forces` with ``stats``: "
                               "the largest overlap as a fraction of the smaller diameter, "
                               "and its pair (``-inf, -1``: none; pair "
                               ":data:`WORST_UNKNOWN`: not known)"),
    ("slot_parts", np.int64, "the parts for which the reaction slots of the shared "
                             "particles in the pair scratch hold zero "
                             "(:func:`pysim.contacts.clear_slots`; 0 after a build)"),
    ("own_parts", np.int64, "the parts for which the ``own`` flags that "
                            ":func:`pysim.integrators.forces` keeps are this list's (0 after "
                            "a build, and whenever the flags array is new)"),
)


def _record_dtype(fields) -> np.dtype:
    """A record dtype of ``fields`` (C layout, fields aligned), whose elements read and
    write their fields as attributes (also in plain Python, ``NUMBA_DISABLE_JIT=1``)."""
    return np.dtype((np.record, np.dtype([(name, kind) for name, kind, _ in fields],
                                         align=True)))


PARAMS_DTYPE = _record_dtype(PARAM_FIELDS)
CACHE_DTYPE = _record_dtype(CACHE_FIELDS)

#: The pair in the cache field ``worst`` when the last force evaluation with statistics
#: could not tell the largest overlap (``end_bonds`` rods): :func:`pysim.contacts.
#: worst_overlap` must
WORST_UNKNOWN = -2.0


def new_params() -> np.ndarray:
    """A parameter record, every field zero (no drag, gravity, strain, growth)."""
    return np.zeros(1, PARAMS_DTYPE)


def new_cache() -> np.ndarray:
    """A cache record, every field zero (as before any list build)."""
    return np.zeros(1, CACHE_DTYPE)
