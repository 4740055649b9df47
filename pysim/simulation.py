"""``Simulation``: a state, a contact model, walls, and the machinery to advance them.

Example (1000 spheres compressed at a true strain rate of 0.005 per axis)::

    from pysim import State
    from pysim.simulation import Simulation, ContactModel
    sim = Simulation(state, ContactModel("hooke", k_n=1e5, gamma_n=300.0, gamma_bg=1.0),
                     dt=1e-4)
    sim.run(10_000, strain_rate=-0.005)
    print(sim.thermo())

Rods drop under gravity onto a frictional floor::

    sim = Simulation(state, ContactModel("hooke", 1e5, 100.0, k_t=2e4, mu=0.5),
                     dt=1e-4, gravity=(0, 0, -10), planes=[walls.plane((0, 0, 1), (0, 0, 0))])
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import numpy as np

from pysim import integrators as itg
from pysim.contacts import PAIR_SCRATCH, REC_COLUMNS, pair_forces, worst_overlap
from pysim.forces import (END_BONDS, KEEP_SPRING, LAW_IDS, NO_TENSION, SPINE_CONTACTS,
                          contact_params)
from pysim.jit import get_threads
from pysim.neighbors import row_starts, transpose
from pysim.records import WORST_UNKNOWN, new_cache, new_params
from pysim.state import State
from pysim.walls import CYL_COLUMNS, PLANE_COLUMNS, wall_forces


@dataclass(frozen=True)
class ContactModel:
    """Contact laws and their parameters (science.md section 3).

    * ``law``: ``hooke`` | ``hertz`` | ``harmonic`` normal law; ``k_n`` stiffness,
      ``gamma_n`` absolute normal damping (force/velocity).
    * ``k_t``, ``gamma_t``, ``mu``: tangential spring with history, damping and Coulomb
      cap; friction is on when ``mu > 0``.
    * ``f_coh``, ``d_coh``: constant attraction within a gap ``d_coh``.
    * ``gamma_bg``, ``gamma_rot``: background drag on translation (force/velocity) and
      rotation (torque/angular velocity).
    * wall contacts use ``k_n``, ``gamma_n``, ``k_t``, ``gamma_t`` with ``mu_wall``
      (default ``mu``), and the grains' cohesion ``f_coh``, ``d_coh`` only with
      ``wall_cohesion`` (walls that are particles of the grains' law, as the long fixed
      spheropolygons of Hidalgo et al.).
    * ``spine_contact``: ``"closest"`` (science.md section 2: one contact at the closest
      points of the spines) or ``"end_bonds"`` (2-D rods: one bond from each spine end to
      the other spine, :func:`pysim.contacts.end_bond`, each a contact of the full law
      with its own tangential spring and cohesion, as the vertex-edge contacts of
      spheropolygons; a smooth energy where the closest-point law has a kink at parallel
      side contacts; :class:`Simulation` refuses it for a 3-D state,
      :meth:`check_dimension`), or ``"end_bonds_distinct"``: the same, a bond that joins
      the same two points as another counted once
      (:func:`pysim.contacts.kinematics.repeats_bond`), so a tip-tip contact is one bond
      and a side-side contact two, as in Marschall & Teitel (2018).
    * every parameter is a finite number (NaN would pass a ``>= 0`` test and run).
    * ``limit_damping``: clip every contact's normal force (grains and walls) at zero, so
      that the damping never pulls (LAMMPS' ``limit_damping``); off by default, as in
      science.md's law.
    * ``tangential_spring``: what the tangential spring does past the Coulomb cap, in
      grain and wall contacts: ``"reset"`` (default) to the length that gives the capped
      force, or ``"keep"`` its integral of the sliding velocity, only the force being
      capped (Pournin et al. 2005, section 3.1; :func:`pysim.forces.tangential_force`).
    """

    law: str
    k_n: float
    gamma_n: float = 0.0
    k_t: float = 0.0
    gamma_t: float = 0.0
    mu: float = 0.0
    f_coh: float = 0.0
    d_coh: float = 0.0
    gamma_bg: float = 0.0
    gamma_rot: float = 0.0
    mu_wall: float | None = None
    wall_cohesion: bool = False
    spine_contact: str = "closest"
    limit_damping: bool = False
    tangential_spring: str = "reset"

    def __post_init__(self):
        if self.law not in LAW_IDS:
            raise ValueError(f"unknown contact law {self.law!r}; valid: {sorted(LAW_IDS)}")
        if self.spine_contact not in SPINE_CONTACTS:
            raise ValueError(f"unknown spine_contact {self.spine_contact!r}; valid: "
                             + ", ".join(repr(k) for k in SPINE_CONTACTS))
        if self.tangential_spring not in ("reset", "keep"):
            raise ValueError(f"unknown tangential_spring {self.tangential_spring!r}; valid: "
                             "'reset', 'keep'")
        if not (math.isfinite(self.k_n) and self.k_n > 0):
            raise ValueError(f"k_n = {self.k_n} is not allowed; use a finite number > 0")
        for name in ("gamma_n", "k_t", "gamma_t", "mu", "f_coh", "d_coh", "gamma_bg", "gamma_rot",
                     "mu_wall"):
            value = getattr(self, name)
            if value is not None and not (math.isfinite(value) and value >= 0):
                raise ValueError(f"{name} = {value} is not allowed; use a finite number >= 0")
        if self.f_coh > 0 and not self.d_coh > 0:
            raise ValueError(f"cohesion f_coh = {self.f_coh} needs a range d_coh > 0")

    def check_dimension(self, dimension: int) -> None:
        """Raise ValueError when the model cannot run in ``dimension`` (2 or 3): the end
        bonds are a 2-D law (:func:`pysim.contacts.end_bond`; the case schema's rule)."""
        if self.spine_contact != "closest" and dimension != 2:
            raise ValueError(f"spine_contact '{self.spine_contact}' is a 2-D law, and this "
                             f"state is {dimension}-D; use spine_contact 'closest' in 3-D")

    @property
    def law_id(self) -> int:
        """The kernels' law id (:mod:`pysim.forces`), with ``NO_TENSION`` when
        ``limit_damping`` and ``KEEP_SPRING`` when ``tangential_spring`` is ``"keep"``."""
        return (LAW_IDS[self.law] | (NO_TENSION if self.limit_damping else 0)
                | (KEEP_SPRING if self.tangential_spring == "keep" else 0))

    @property
    def friction(self) -> bool:
        return self.mu > 0

    @property
    def spring_columns(self) -> int:
        """Columns of a pair's tangential history: three per bond (four end bonds, one
        closest-point contact), none without friction."""
        if not self.friction:
            return 0
        return 3 * (4 if self.spine_contact != "closest" else 1)

    def pair_params(self) -> np.ndarray:
        return contact_params(self.k_n, self.gamma_n, self.k_t, self.gamma_t, self.mu,
                              self.f_coh, self.d_coh, SPINE_CONTACTS[self.spine_contact])

    def wall_params(self) -> np.ndarray:
        mu = self.mu if self.mu_wall is None else self.mu_wall
        coh = (self.f_coh, self.d_coh) if self.wall_cohesion else (0.0, 0.0)
        return contact_params(self.k_n, self.gamma_n, self.k_t, self.gamma_t, mu, *coh)

    def contact_time(self, m_eff: float) -> float:
        """Binary contact time of the linear law, ``t_c = pi / sqrt(k/m_eff -
        (gamma/(2 m_eff))^2)`` (science.md); the undamped value when overdamped."""
        w2 = self.k_n / m_eff - (self.gamma_n / (2.0 * m_eff)) ** 2
        if w2 <= 0:
            w2 = self.k_n / m_eff
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
    stress: np.ndarray = field(repr=False)  # (3, 3) contact stress, tension positive

    def row(self) -> tuple:
        return (self.step, self.time, self.phi, self.pressure, self.ke, self.pe,
                self.n_contacts)


#: the schemes of :meth:`Simulation.run`: velocity Verlet, explicit (forward) Euler and
#: semi-implicit Euler (:mod:`pysim.integrators`)
INTEGRATORS = ("verlet", "euler", "semi_implicit_euler")


def check_integrator(name: str) -> None:
    """Raise ValueError unless ``name`` is one of :data:`INTEGRATORS`."""
    if name not in INTEGRATORS:
        raise ValueError(f"unknown integrator {name!r}; valid: "
                         + ", ".join(repr(k) for k in INTEGRATORS))


class BlowUpError(FloatingPointError):
    """The integration became unstable; the message says where and what to change."""


class Simulation:
    """Advance a :class:`State` with a :class:`ContactModel`, walls and gravity.

    ``dt`` time step; ``gravity`` (3,) acceleration; ``planes``/``cylinders`` wall rows
    (:mod:`pysim.walls`); ``skin`` Verlet skin (default 0.2 of the largest diameter);
    ``max_overlap`` the overlap (fraction of the smaller diameter) that counts as a
    blow-up; ``integrator`` the scheme of :meth:`run`, one of :data:`INTEGRATORS`
    (velocity Verlet by default; :mod:`pysim.integrators`).

    The kernels' scalars are two records (:mod:`pysim.records`): ``params``, the
    parameters (drags, gravity, strain and growth rates, skin, threads), and ``cache``,
    what the kernels keep from call to call (the list build, the largest overlap).
    """

    def __init__(self, state: State, model: ContactModel, dt: float, gravity=(0.0, 0.0, 0.0),
                 planes=(), cylinders=(), skin: float | None = None, max_overlap: float = 0.25,
                 check_dt: bool = True, integrator: str = "verlet"):
        if not dt > 0:
            raise ValueError(f"dt must be > 0, got {dt}")
        self.integrator = integrator
        model.check_dimension(state.dimension)
        self.state = state
        self.model = model
        self._dt = float(dt)
        self._t_seg, self._s_seg = float(state.time), int(state.step)
        self.max_overlap = float(max_overlap)
        s = state
        self.half = 0.5 * s.length.copy()
        self.r_int = s.radius + self.half + 0.5 * model.d_coh
        dmax = 2.0 * float(np.max(s.radius + self.half))
        self.skin = float(skin if skin is not None else 0.2 * 2.0 * float(s.radius.max()))
        self.planes = np.ascontiguousarray(np.reshape(planes, (-1, PLANE_COLUMNS)), dtype=np.float64)
        self.cyls = np.ascontiguousarray(np.reshape(cylinders, (-1, CYL_COLUMNS)), dtype=np.float64)
        self.n_walls = self.planes.shape[0] + self.cyls.shape[0]
        self.wall_force = np.zeros((self.n_walls, 3))
        self._cp = model.pair_params()
        self._wp = model.wall_params()
        self._wfriction = self._wp[4] > 0
        self.whist = np.zeros((s.n * self.n_walls * 2 if self._wfriction else 0, 3))
        g = np.asarray(gravity, dtype=np.float64).reshape(3)
        if s.dimension == 2 and g[2] != 0:
            raise ValueError(f"gravity {tuple(g)} has a z component in a 2-D run; use (0, -g, 0)")
        self.params = new_params()
        self.params["gamma_bg"] = model.gamma_bg
        self.params["gamma_rot"] = model.gamma_rot
        self.params["gravity"] = g
        self.params["skin"] = self.skin
        self.params["rods"] = bool(np.any(self.half > 0))
        self.params["dim2"] = s.dimension == 2
        self.cache = new_cache()
        for k in range(3):
            if s.periodic[k] and s.box[k] < 2.0 * (dmax + model.d_coh + self.skin):
                raise ValueError(
                    f"box edge {k} = {s.box[k]:.4g} is below twice the interaction range "
                    f"{dmax + model.d_coh + self.skin:.4g} (longest particle plus skin); use a "
                    "larger box or more particles")
        self.f = np.zeros_like(s.x)
        self.torque = np.zeros_like(s.x)
        self.virial = np.zeros((3, 3))
        self._pe = 0.0
        self._nc = 0
        self._nw = 0
        self.rebuilds = 0
        if check_dt:
            self._check_dt()
        itg.wrap(s.x, s.box, s.periodic)
        self.pi = np.zeros(0, np.int32)
        self.pj = np.zeros(0, np.int32)
        self.hist = np.zeros((0, model.spring_columns))
        self.x_ref = s.x.copy()
        self.u_ref = s.u.copy() if self.params["rods"][0] else np.zeros((0, 3))
        self.box_ref = s.box.copy()
        self._new_scratch()
        self._index_pairs()
        self._rebuild()
        self.compute_forces()

    @property
    def integrator(self) -> str:
        """The scheme of :meth:`run`, one of :data:`INTEGRATORS`; setting it checks the
        name, so that a misspelt one is refused, not run as another scheme."""
        return self._integrator

    @integrator.setter
    def integrator(self, name: str):
        check_integrator(name)
        self._integrator = name

    # -- time --------------------------------------------------------------------------
    @property
    def dt(self) -> float:
        """Time step; changing it starts a new segment of the clock (time stays a function
        of the step number within a segment)."""
        return self._dt

    @dt.setter
    def dt(self, value: float):
        if not value > 0:
            raise ValueError(f"dt must be > 0, got {value}")
        self._t_seg, self._s_seg = float(self.state.time), int(self.state.step)
        self._dt = float(value)

    def _clock(self) -> np.ndarray:
        return np.array([self._t_seg, float(self._s_seg), float(self.state.step)])

    def _advance_clock(self, nsteps: int):
        s = self.state
        s.step += int(nsteps)
        s.time = self._t_seg + (s.step - self._s_seg) * self._dt

    # -- internals -------------------------------------------------------------------
    def _check_dt(self):
        s = self.state
        m = float(s.mass.min())
        if self.model.law == "hooke":
            t_c = self.model.contact_time(0.5 * m)
            if self.dt > t_c / 10:
                raise ValueError(
                    f"time step dt = {self.dt:g} is above 1/10 of the contact time "
                    f"t_c = {t_c:.3g} of the lightest pair; use dt <= {t_c / 10:.3g} "
                    "(t_c/50 is usual)")

    # the pair arrays travel through the kernels as one tuple in the order of
    # itg.PAIR_ARRAYS; pi, pj and hist are attributes (checkpoints store them, the index
    # arrays are derived)
    def _pairs(self) -> tuple:
        return (self.pi, self.pj, self._istart, self._jstart, self._jk, self.hist, self._fj)

    def _set_pairs(self, p):
        self.pi, self.pj, self._istart, self._jstart, self._jk, self.hist, self._fj = p

    def _ref(self) -> tuple:
        """The state at the last list build (itg.REF_ARRAYS)."""
        return (self.x_ref, self.u_ref, self.box_ref)

    def _walls(self) -> tuple:
        """The wall arrays (itg.WALL_ARRAYS)."""
        return (self.planes, self.cyls, self._wp, self.whist, self.wall_force)

    def _new_scratch(self):
        """The per-particle scratch the steps keep (new at construction and after a
        checkpoint load): ``_dl``, each rod's share of the motion bound, written by every
        list check of a run (:func:`pysim.integrators.maybe_rebuild`) and read by the
        rods' contact pass alone (empty otherwise; infinite, no pair skipped by it, until
        then); ``_own``, the threads' shared-particle flags that
        :func:`pysim.integrators.forces` keeps, found again at the first step
        (the cache field ``own_parts`` 0)."""
        one_bond = self.params["rods"][0] and not self._cp[END_BONDS]
        self._dl = np.full(self.state.n if one_bond else 0, np.inf)
        self._own = np.zeros(self.state.n, np.bool_)
        self.cache["own_parts"] = 0

    def _index_pairs(self):
        """Derive the row starts, the transposed index and the reaction scratch from
        ``pi``/``pj`` (after a checkpoint load)."""
        n = self.state.n
        self.pi = np.ascontiguousarray(self.pi, dtype=np.int32)
        self.pj = np.ascontiguousarray(self.pj, dtype=np.int32)
        self._istart = row_starts(self.pi, n)
        self._jstart, self._jk = transpose(self.pj, n)
        self._fj = np.zeros((PAIR_SCRATCH, len(self.pi)))  # separations 0: nothing skipped

    def _rebuild(self):
        s = self.state
        self._set_pairs(itg.rebuild(s.x, s.u, s.box, s.periodic, self.r_int, self.half,
                                    self.params, self.cache, self._pairs(), self._ref()))
        self.rebuilds += 1

    def compute_forces(self):
        """Forces, torques and virial of the current state (half-step velocities are
        whatever ``state.v`` holds)."""
        s = self.state
        self.cache["sep_sigma"] = 0.0  # the state may have changed since the motion bound
        self._sync_threads()
        self._pe, self._nc, self._nw = itg.forces(
            s.x, s.v, s.omega, s.u, s.radius, self.half, s.mass, s.box, s.periodic,
            self._pairs(), self.model.law_id, self._cp, self.model.friction, self._walls(),
            self._wfriction, self.params, self.cache, s.time, self.dt, self.f, self.torque,
            self.virial, True)

    def _sync_threads(self):
        """Tell the kernels how many threads they run on (the contact pass cuts its rows
        into as many parts; the same bits for any number)."""
        self.params["parts"] = get_threads()

    def _check(self, what: str):
        """Raise :class:`BlowUpError` on non-finite positions or velocities, or on an
        overlap above ``max_overlap`` at the last force evaluation (the largest overlap
        comes with the forces, the cache field ``worst``: a pass over the pairs of its own
        took as long as most of a step of 10^6 rods)."""
        s = self.state
        if not itg.all_finite(s.x, s.v):
            bad = ~(np.all(np.isfinite(s.x), axis=1) & np.all(np.isfinite(s.v), axis=1))
            ids = np.flatnonzero(bad)
            raise BlowUpError(
                f"{what}: non-finite positions or velocities at step {s.step} for particles "
                f"(0-based) {ids[:10].tolist()}; reduce dt (now {self.dt:g}) or the driving rate")
        if self._nc:
            frac, k = self.cache["worst"][0]
            k = int(k)
            if k == WORST_UNKNOWN:
                frac, k = worst_overlap(s.x, s.u, s.radius, self.half, s.box, s.periodic,
                                        self.pi, self.pj, bool(self.params["rods"][0]))
            if k >= 0:
                if frac > self.max_overlap:
                    a, b = int(self.pi[k]), int(self.pj[k])
                    raise BlowUpError(
                        f"{what}: overlap {frac:.3g} of a diameter between particles "
                        f"(0-based) {a} and {b} at step {s.step} exceeds {self.max_overlap}; "
                        f"reduce dt (now {self.dt:g}) or the driving rate, or stiffen k_n")

    # -- public API --------------------------------------------------------------------
    def run(self, nsteps: int, strain_rate=0.0, growth_rate: float = 0.0):
        """Advance ``nsteps`` steps of the simulation's integrator (velocity Verlet by
        default). ``strain_rate`` (scalar or 3 values, 1/time) scales periodic box edges
        as ``L(t) = L(0) exp(rate t)``; ``growth_rate`` grows every particle as
        ``exp(g t)`` at fixed aspect ratio (both velocity Verlet only)."""
        if nsteps <= 0:
            return
        if self.integrator != "verlet":
            self._run_euler(int(nsteps), strain_rate, growth_rate)
            return
        s = self.state
        rate = np.broadcast_to(np.asarray(strain_rate, dtype=np.float64), (3,)).copy()
        rate[~s.periodic] = 0.0
        self.params["strain_rate"] = rate
        self.params["growth"] = growth_rate
        self._sync_threads()
        self._chunks(itg.verlet_chunk, int(nsteps))
        if growth_rate:
            s.length[:] = 2.0 * self.half
        self._check("velocity Verlet")

    def _run_euler(self, nsteps: int, strain_rate, growth_rate: float):
        """:meth:`run` with an Euler scheme (:func:`pysim.integrators.euler_chunk`)."""
        if np.any(np.asarray(strain_rate) != 0) or growth_rate:
            raise ValueError(f"the {self.integrator} integrator has no box deformation or "
                             "growth; use integrator 'verlet'")
        self.params["strain_rate"] = 0.0
        self.params["growth"] = 0.0
        self._sync_threads()
        self._chunks(itg.euler_chunk, nsteps, self.integrator == "euler")
        self._check(self.integrator.replace("_", " "))

    def _chunks(self, kernel, nsteps: int, *extra):
        """Advance ``nsteps`` steps with an inertial ``kernel`` (:func:`pysim.integrators.
        verlet_chunk` or ``euler_chunk``, ``extra`` its arguments after the common ones),
        calling it again after each return at a list rebuild (the old list is freed
        here)."""
        s = self.state
        left = nsteps
        while left > 0:
            (pairs, self._pe, self._nc, self._nw, nreb, done) = kernel(
                s.x, s.v, s.q, s.u, s.omega, self.f, self.torque, s.radius, self.half,
                self.r_int, s.mass, s.inertia, s.box, s.periodic, self._pairs(), self._ref(),
                self.model.law_id, self._cp, self.model.friction, self._walls(),
                self._wfriction, self.params, self.cache, self._clock(), self.dt, left,
                self.virial, self._dl, self._own, *extra)
            self._set_pairs(pairs)
            self.rebuilds += nreb
            self._advance_clock(done)
            left -= done

    def run_overdamped(self, nsteps: int, k_d: float, kappa: float = 0.0):
        """Advance ``nsteps`` overdamped Heun steps with substrate drag ``k_d`` while the
        periodic box contracts as ``dL/dt = -kappa L`` (science.md, 2-D compression)."""
        if nsteps <= 0:
            return
        if self.model.friction:
            raise ValueError("the overdamped integrator has no tangential history; use mu = 0")
        s = self.state
        rate = np.where(s.periodic, -float(kappa), 0.0)
        if s.dimension == 2:
            rate[2] = 0.0
        self.params["strain_rate"] = rate
        self.params["k_d"] = k_d
        self._sync_threads()
        msize = s.mass / s.density
        (pairs, self._pe, self._nc, nreb) = itg.heun_chunk(
            s.x, s.v, s.q, s.u, s.omega, self.f, self.torque, s.radius, self.half, self.r_int,
            s.mass, s.inertia, msize, s.box, s.periodic, self._pairs(), self._ref(),
            self.model.law_id, self._cp, self._walls(), self.params, self.cache, self._clock(),
            self.dt, int(nsteps), self.virial)
        self._set_pairs(pairs)
        self.params["strain_rate"] = 0.0
        self.rebuilds += nreb
        self._advance_clock(nsteps)
        self._check("overdamped Heun")

    def minimize(self, f_tol: float, max_iter: int = 100_000, dt_max: float | None = None,
                 until=None, check_every: int = 1000):
        """FIRE energy minimisation at fixed box until every force and torque is below
        ``f_tol``, or ``max_iter`` iterations. ``until(sim) -> bool``, when given, is
        called every ``check_every`` iterations with forces, torques and energy current,
        and a true answer stops the minimisation there (FIRE's velocities and step size
        carry over between the checks). Returns ``(iterations, max |F|, max |tau|)``."""
        s = self.state
        if check_every < 1:
            raise ValueError(f"check_every must be a positive number of iterations, "
                             f"got {check_every}")
        dt_max = 10.0 * self.dt if dt_max is None else dt_max
        fire = np.array([self.dt, 0.1, 0.0, dt_max, 0.02 * self.dt])
        # FIRE's parameters: no drag, strain or growth; the cache is the run's (a list
        # that FIRE builds is the run's list from then on)
        fire_params = self.params.copy()
        fire_params["gamma_bg"] = 0.0
        fire_params["gamma_rot"] = 0.0
        fire_params["strain_rate"] = 0.0
        fire_params["growth"] = 0.0
        s.v[:] = 0.0
        s.omega[:] = 0.0
        saved = self.params
        self.params = fire_params
        done = 0
        try:
            self.compute_forces()  # also sets the threads in fire_params
            while True:
                chunk = int(max_iter) - done if until is None else min(check_every,
                                                                       int(max_iter) - done)
                (pairs, self._pe, self._nc, it, fmax, tmax) = itg.fire_chunk(
                    s.x, s.v, s.q, s.u, s.omega, self.f, self.torque, s.radius, self.half,
                    self.r_int, s.mass, s.inertia, s.box, s.periodic, self._pairs(),
                    self._ref(), self.model.law_id, self._cp, self._walls(), fire_params,
                    self.cache, fire, chunk, float(f_tol), self.virial)
                self._set_pairs(pairs)
                converged = fmax < f_tol and tmax < f_tol
                done += int(it) if converged else chunk
                if converged or done >= max_iter or (until is not None and until(self)):
                    break
        finally:
            self.params = saved
            s.v[:] = 0.0
            s.omega[:] = 0.0
        self._check("FIRE")
        return done, float(fmax), float(tmax)

    def rescale_particles(self, factor: float):
        """Scale every particle's ``R`` and ``L`` by ``factor`` at fixed centres, axes and
        box (mass by ``factor^d``, inertia by ``factor^(d+2)``), then recompute forces:
        the packing fraction changes by ``factor^d``."""
        if not factor > 0:
            raise ValueError(f"scale factor must be > 0, got {factor}")
        s = self.state
        d = s.dimension
        s.radius *= factor
        s.length *= factor
        self.half *= factor
        self.r_int *= factor
        s.mass *= factor**d
        s.inertia *= factor ** (d + 2)
        self._rebuild()
        self.compute_forces()

    def rescale_box(self, factor: float):
        """Scale the periodic box edges by ``factor`` with the centres moved affinely
        (orientations and sizes kept), then recompute forces: the packing fraction
        changes by ``factor^-d``."""
        if not factor > 0:
            raise ValueError(f"scale factor must be > 0, got {factor}")
        s = self.state
        axes = np.flatnonzero(s.periodic)
        s.box[axes] *= factor
        s.x[:, axes] *= factor
        itg.wrap(s.x, s.box, s.periodic)
        self._rebuild()
        self.compute_forces()

    def add_particles(self, x, radius, length, axis, v=None):
        """Append ``m`` particles (rows ``n ... n + m - 1``) at positions ``x`` (m, 3) with
        spine directions ``axis``, velocities ``v`` (default rest) and no spin; masses from
        the state's density. They must touch nothing: no grain or wall within their
        interaction range (the gap above the cohesion range), so that their force is
        gravity and drag alone, set here without a force evaluation (which would advance
        every tangential spring); a ``ValueError`` names the first that does. The pair list
        is rebuilt, the springs of the old pairs carried over.

        Per call it reallocates the per-particle arrays (O(n)): for a feed of grains one at
        a time, not for the hot loop."""
        s = self.state
        new = State.create(np.atleast_2d(x), radius, length, s.box, axis=np.atleast_2d(axis),
                           v=None if v is None else np.atleast_2d(v), density=s.density,
                           periodic=s.periodic, dimension=s.dimension)
        n0, m = s.n, new.n
        for k in ("x", "v", "q", "u", "omega", "radius", "length", "mass", "inertia"):
            setattr(s, k, np.ascontiguousarray(np.concatenate([getattr(s, k), getattr(new, k)])))
        half = 0.5 * new.length
        self.half = np.concatenate([self.half, half])
        self.r_int = np.concatenate([self.r_int, new.radius + half + 0.5 * self.model.d_coh])
        g = self.params["gravity"][0]
        # what forces() adds
        f = new.mass[:, None] * g[None, :] - self.params["gamma_bg"][0] * new.v
        if s.dimension == 2:
            f[:, 2] = 0.0
        self.f = np.ascontiguousarray(np.concatenate([self.f, f]))
        self.torque = np.ascontiguousarray(np.concatenate([self.torque, np.zeros((m, 3))]))
        if self._wfriction:
            self.whist = np.concatenate([self.whist, np.zeros((m * self.n_walls * 2, 3))])
        self.x_ref = s.x.copy()
        if self.params["rods"][0] or np.any(half > 0):
            self.params["rods"] = True
            self.u_ref = s.u.copy()
        # the new particles have empty rows in the old list: the springs carry over
        self._istart = np.concatenate([self._istart, np.full(m, self._istart[-1])])
        self._new_scratch()
        self._rebuild()
        ij, _ = self.contact_table()
        hit = ij[(ij >= n0).any(axis=1)]
        if len(hit):
            raise ValueError(f"added particle (0-based) {int(hit[0].max())} touches particle "
                             f"{int(hit[0].min())}; place it clear of every grain")
        if self.n_walls:
            iw, _ = self.wall_contact_table()
            hit = iw[iw[:, 0] >= n0]
            if len(hit):
                raise ValueError(f"added particle (0-based) {int(hit[0, 0])} touches wall "
                                 f"{int(hit[0, 1])}; place it clear of the walls")

    def set_drag(self, gamma_bg: float, gamma_rot: float):
        """Change the background drag on translation (force/velocity) and rotation
        (torque/angular velocity) from now on (the model keeps its own values; checkpoints
        keep the current ones)."""
        if gamma_bg < 0 or gamma_rot < 0:
            raise ValueError(f"drags must be >= 0, got gamma_bg = {gamma_bg}, "
                             f"gamma_rot = {gamma_rot}")
        self.params["gamma_bg"] = float(gamma_bg)
        self.params["gamma_rot"] = float(gamma_rot)

    def set_spine_contact(self, spine_contact: str):
        """Change the rods' contact rule (:attr:`ContactModel.spine_contact`) from now on,
        and evaluate the forces again under it. The pair list stays: every rule has the
        same reach. A frictional model cannot switch between the closest point and the
        end bonds: their tangential springs sit at different points."""
        model = replace(self.model, spine_contact=spine_contact)
        model.check_dimension(self.state.dimension)
        if model.spring_columns != self.model.spring_columns:
            raise ValueError(f"cannot switch a frictional model (mu = {model.mu}) from "
                             f"spine_contact '{self.model.spine_contact}' to "
                             f"'{spine_contact}': their tangential springs do not carry over")
        self.model = model
        self._cp = model.pair_params()
        self.compute_forces()

    def stress(self) -> np.ndarray:
        """Contact stress ``sigma_ab = (1/V) sum_c l^c_a F^c_b`` (tension positive) of the
        last force evaluation (pair contacts; walls excluded)."""
        return self.virial / self.state.volume()

    def thermo(self) -> Thermo:
        """Global quantities; pressure ``p = -tr(sigma)/d`` from pair contacts only."""
        s = self.state
        sigma = self.stress()
        d = s.dimension
        return Thermo(step=s.step, time=s.time, phi=s.packing_fraction(),
                      pressure=float(-np.trace(sigma[:d, :d]) / d), ke=s.kinetic_energy(),
                      pe=float(self._pe), n_contacts=int(self._nc), stress=sigma)

    def contact_table(self):
        """Pair contacts of the current state: ``(ij (C, 2) 0-based, rec (C, 10))`` with
        columns point (3), unit normal i->j (3), overlap, force on i (3)."""
        s = self.state
        npair = self.pi.shape[0]
        ij = np.empty((npair, 2), np.int64)
        rec = np.empty((npair, REC_COLUMNS))
        f = np.zeros_like(s.x)
        tq = np.zeros_like(s.x)
        vir = np.zeros((3, 3))
        hist = self.hist.copy()  # the table must not advance the tangential springs
        _, nc = pair_forces(s.x, s.v, s.omega, s.u, s.radius, self.half, s.box, s.periodic,
                            self.pi, self.pj, hist, self.model.law_id, self._cp,
                            self.model.friction, 0.0, f, tq, vir, True, ij, rec)
        return ij[:nc].copy(), rec[:nc].copy()

    def wall_contact_table(self):
        """Wall contacts: ``(iw (C, 2): grain index, wall index; rec (C, 10))``."""
        s = self.state
        cap = s.n * max(self.n_walls, 1) * 2
        iw = np.empty((cap, 2), np.int64)
        rec = np.empty((cap, REC_COLUMNS))
        f = np.zeros_like(s.x)
        tq = np.zeros_like(s.x)
        wf = np.zeros_like(self.wall_force)
        whist = self.whist.copy()
        nw = wall_forces(s.x, s.v, s.omega, s.u, s.radius, self.half, self.planes, self.cyls,
                         s.time, self.model.law_id, self._wp, self._wfriction, whist, 0.0, f, tq,
                         wf, True, iw, rec)
        return iw[:nw].copy(), rec[:nw].copy()
