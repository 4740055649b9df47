"""``Simulation``: a state, a contact law and the machinery to advance them.

Example (1000 spheres compressed at a true strain rate of 0.005 per axis)::

    from pysim import State
    from pysim.simulation import Simulation, ContactLaw
    sim = Simulation(state, ContactLaw("hooke", k_n=1e5, gamma_n=100.0), dt=1e-4,
                     gamma_bg=1.0)
    sim.run(10_000, strain_rate=-0.005)
    print(sim.thermo())
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from pysim.contacts import REC_COLUMNS, sphere_contacts
from pysim.forces import LAW_IDS
from pysim.integrators import compute_forces, verlet_chunk, wrap
from pysim.neighbors import build_pairs
from pysim.state import State


@dataclass(frozen=True)
class ContactLaw:
    """A normal contact law by name (see :mod:`pysim.forces`) and its parameters.

    ``k_n`` is the stiffness (force/length for ``hooke``, force/length^(3/2) for
    ``hertz``), ``gamma_n`` the absolute normal damping (force/velocity).
    """

    name: str
    k_n: float
    gamma_n: float = 0.0

    def __post_init__(self):
        if self.name not in LAW_IDS:
            raise ValueError(f"unknown contact law {self.name!r}; valid: {sorted(LAW_IDS)}")
        if not self.k_n > 0:
            raise ValueError(f"k_n must be > 0, got {self.k_n}")
        if self.gamma_n < 0:
            raise ValueError(f"gamma_n must be >= 0, got {self.gamma_n}")

    @property
    def law_id(self) -> int:
        return LAW_IDS[self.name]

    @property
    def params(self) -> np.ndarray:
        return np.array([self.k_n, self.gamma_n], dtype=np.float64)

    def contact_time(self, m_eff: float) -> float:
        """Duration of a binary collision for the linear law (time units).

        ``t_c = pi / sqrt(k/m_eff - (gamma/(2 m_eff))^2)`` (science.md, section 3).
        """
        w2 = self.k_n / m_eff - (self.gamma_n / (2.0 * m_eff)) ** 2
        if w2 <= 0:
            return np.inf
        return np.pi / np.sqrt(w2)


@dataclass
class Thermo:
    """Global quantities of the current state (one row of ``thermo.dat``)."""

    step: int
    time: float
    phi: float
    pressure: float
    ke: float
    pe: float
    n_contacts: int
    stress: np.ndarray  # (3, 3) contact stress tensor, tension positive

    def row(self) -> tuple:
        return (self.step, self.time, self.phi, self.pressure, self.ke, self.pe,
                self.n_contacts)


class Simulation:
    """Advance a :class:`State` of spheres with one contact law.

    ``dt`` is the time step, ``gamma_bg`` a background drag coefficient
    (force/velocity, ``F = -gamma_bg v``), ``skin`` the Verlet-list skin (length).
    """

    def __init__(self, state: State, law: ContactLaw, dt: float, gamma_bg: float = 0.0,
                 skin: float | None = None):
        if np.any(state.length > 0):
            raise NotImplementedError(
                "this Simulation integrates spheres (L = 0) only; spherocylinders "
                "need the rod kernels")
        if not dt > 0:
            raise ValueError(f"dt must be > 0, got {dt}")
        self.state = state
        self.law = law
        self.dt = float(dt)
        self.gamma_bg = float(gamma_bg)
        self.skin = float(skin if skin is not None else 0.2 * 2 * state.radius.max())
        self._params = law.params
        self.f = np.zeros_like(state.x)
        self.virial = np.zeros((3, 3))
        self._pe = 0.0
        self._nc = 0
        self.rebuilds = 0
        self._check_dt()
        wrap(state.x, state.box, state.periodic)
        self._rebuild()
        self._forces()

    # -- internals -------------------------------------------------------------------
    def _check_dt(self):
        m = self.state.mass.min()
        t_c = self.law.contact_time(0.5 * m)
        if self.law.name == "hooke" and self.dt > t_c / 10:
            raise ValueError(
                f"time step dt = {self.dt:g} is above 1/10 of the contact time "
                f"t_c = {t_c:.3g} of the lightest pair; use dt <= {t_c / 10:.3g} "
                "(t_c/50 is usual)")

    def _rebuild(self):
        s = self.state
        self.pi, self.pj = build_pairs(s.x, s.radius, s.box, s.periodic, self.skin)
        self.x_ref = s.x.copy()
        self.box_ref = s.box.copy()
        self.rebuilds += 1

    def _forces(self):
        s = self.state
        self._pe, self._nc = compute_forces(
            s.x, s.v, s.radius, s.box, s.periodic, self.pi, self.pj, self.law.law_id,
            self._params, self.gamma_bg, self.f, self.virial)

    # -- public API --------------------------------------------------------------------
    def run(self, nsteps: int, strain_rate=0.0):
        """Advance ``nsteps`` steps; ``strain_rate`` (scalar or 3 values, 1/time) scales
        the box as ``L(t) = L(0) exp(strain_rate t)`` (negative compresses)."""
        if nsteps <= 0:
            return
        s = self.state
        rate = np.broadcast_to(np.asarray(strain_rate, dtype=np.float64), (3,)).copy()
        rate[~s.periodic] = 0.0
        self.pi, self.pj, self._pe, self._nc, nreb = verlet_chunk(
            s.x, s.v, self.f, s.radius, s.mass, s.box, s.periodic, self.pi, self.pj,
            self.x_ref, self.box_ref, self.skin, self.law.law_id, self._params,
            self.gamma_bg, rate, self.dt, int(nsteps), self.virial)
        self.rebuilds += nreb
        s.step += int(nsteps)
        s.time += nsteps * self.dt
        if not np.all(np.isfinite(s.x)):
            bad = np.flatnonzero(~np.all(np.isfinite(s.x), axis=1))
            raise FloatingPointError(
                f"non-finite positions at step {s.step} for particles (0-based) "
                f"{bad[:10].tolist()}; reduce dt or the compression rate")

    def stress(self) -> np.ndarray:
        """Contact stress tensor ``sigma_ab = (1/V) sum_c l^c_a F^c_b`` (tension
        positive) of the last force evaluation."""
        return self.virial / self.state.volume()

    def thermo(self) -> Thermo:
        """Global quantities; pressure ``p = -tr(sigma)/3`` from contacts only."""
        s = self.state
        sigma = self.stress()
        return Thermo(step=s.step, time=s.time, phi=s.packing_fraction(),
                      pressure=float(-np.trace(sigma) / 3.0), ke=s.kinetic_energy(),
                      pe=float(self._pe), n_contacts=int(self._nc), stress=sigma)

    def contact_table(self):
        """Contacts of the current state: ``(ij (C, 2) int, rec (C, 10) float)``.

        ``ij`` are 0-based particle indices; ``rec`` columns are contact point
        (3), unit normal from i to j (3), overlap, force on i (3).
        """
        s = self.state
        npair = self.pi.shape[0]
        ij = np.empty((npair, 2), np.int64)
        rec = np.empty((npair, REC_COLUMNS))
        f = np.zeros_like(s.x)
        vir = np.zeros((3, 3))
        _, nc = sphere_contacts(s.x, s.v, s.radius, s.box, s.periodic, self.pi, self.pj,
                                self.law.law_id, self._params, f, vir, True, ij, rec)
        return ij[:nc].copy(), rec[:nc].copy()
