"""Event-driven molecular dynamics of hard spheres with growing diameters in a periodic
cube (Lubachevsky & Stillinger 1990, Lubachevsky 1991: refs. 36, 37 of Baranau &
Tallarek 2014).

The diameters are ``D_i(t) = r(t) D_i^nom`` with ``r(t) = r_0 + gamma t``: ``gamma``
(1 / time) is the compression rate of the paper, the growth speed of a diameter in units
of its nominal diameter (whose mean is 1). Particles fly freely between events; each has
one pending event, the earlier of its next collision (:mod:`pysim.hard.collide`) with a
particle of the 27 cells around it and its next cell transfer (:mod:`pysim.hard.cells`),
kept in an indexed heap (:mod:`pysim.hard.heap`). A particle's position is stored at its
own last event time ``tloc[i]``. A collision predicted with a partner that has collided
since (its collision counter moved on) is stale and only re-predicted; a particle that
changes its flight re-predicts against every candidate, so no collision is missed.

The dynamics runs in *blocks* of a given number of collisions (the paper's 20 per
particle). The time restarts from 0 at every block, ``r_0`` taking the value it
reached, so event times keep their precision; all events are predicted afresh at a
block's start, so a run continued from the state saved between blocks is the same run.
Over a block of duration ``t`` the reduced pressure is the virial theorem with unit
masses (ref. 40, with the block's mean kinetic energy ``<K>`` in place of its last):

    Z = P V / (N k_B T) = 1 + sum_c |J_c| sigma_c / (2 <K> t),

``J_c`` the elastic impulse of collision ``c`` and ``sigma_c`` its contact distance; the
collisional pressure (kinetic part excluded) is ``P_c = sum_c |J_c| sigma_c / (3 V t)``.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from pysim.hard import cells, heap
from pysim.hard.collide import collide, collision_time
from pysim.jit import inline_njit, njit

COLLISION = 0
TRANSFER = 1

#: status of a block
OK, REACHED_R_MAX, NO_EVENTS, STUCK = 0, 1, 2, 3
#: zero-time collisions of one pair in a row taken as a run that cannot go on
MAX_REPEATS = 1000

#: the highest packing fraction the cell grid is made for; a run stops above it
PHI_CAP = 0.78


class DynamicsError(RuntimeError):
    """The event-driven dynamics cannot go on; the message is one line."""


@inline_njit
def _advance(x, v, tloc, i, t):
    dt = t - tloc[i]
    if dt != 0.0:
        x[i, 0] += v[i, 0] * dt
        x[i, 1] += v[i, 1] * dt
        x[i, 2] += v[i, 2] * dt
        tloc[i] = t


@inline_njit
def _image(d, side):
    # positions stay within a hair of [0, side): one wrap is enough, and a compare is
    # cheaper than a floor
    if d >= 0.5 * side:
        return d - side
    if d < -0.5 * side:
        return d + side
    return d


@njit
def predict(i, t, x, v, tloc, dn, cell, head, nxt, nc, side, r0, g, ev_t, ev_kind, ev_p,
            ev_cnt, count):
    """Move particle ``i`` to time ``t`` and set its next event: the earliest collision
    with a particle of the 27 cells around it, or its cell transfer."""
    _advance(x, v, tloc, i, t)
    w = side / nc
    tau, face = cells.transfer_time(x, v, cell, i, w)
    best = t + tau
    kind = TRANSFER
    partner = face
    r = r0 + g * t
    xi0 = x[i, 0]
    xi1 = x[i, 1]
    xi2 = x[i, 2]
    for ox in range(-1, 2):
        cx = (cell[i, 0] + ox) % nc
        for oy in range(-1, 2):
            cy = (cell[i, 1] + oy) % nc
            for oz in range(-1, 2):
                cz = (cell[i, 2] + oz) % nc
                k = head[cells.cell_id(cx, cy, cz, nc)]
                while k >= 0:
                    if k != i:
                        dtk = t - tloc[k]
                        dx = _image(x[k, 0] + v[k, 0] * dtk - xi0, side)
                        dy = _image(x[k, 1] + v[k, 1] * dtk - xi1, side)
                        dz = _image(x[k, 2] + v[k, 2] * dtk - xi2, side)
                        s = 0.5 * (dn[i] + dn[k])
                        tc = t + collision_time(dx, dy, dz, v[k, 0] - v[i, 0],
                                                v[k, 1] - v[i, 1], v[k, 2] - v[i, 2],
                                                s * r, s * g)
                        if tc < best:
                            best = tc
                            kind = COLLISION
                            partner = k
                    k = nxt[k]
    ev_t[i] = best
    ev_kind[i] = kind
    ev_p[i] = partner
    if kind == COLLISION:
        ev_cnt[i] = count[partner]


@njit
def predict_all(x, v, tloc, dn, cell, head, nxt, nc, side, r0, g, ev_t, ev_kind, ev_p,
                ev_cnt, count, hp, hpos):
    """Predict every particle's next event at time 0 and build the queue."""
    for i in range(x.shape[0]):
        predict(i, 0.0, x, v, tloc, dn, cell, head, nxt, nc, side, r0, g, ev_t, ev_kind,
                ev_p, ev_cnt, count)
    heap.build(hp, hpos, ev_t)


@njit
def run_block(x, v, tloc, dn, cell, head, nxt, prv, nc, side, r0, g, r_max, ev_t, ev_kind,
              ev_p, ev_cnt, count, hp, hpos, n_coll, acc):
    """Process events until ``n_coll`` collisions are done (or the diameters would pass
    ``r_max`` of their nominal size). ``acc`` accumulates, from the block's start:
    ``[time of the last event, collisions, virial sum |J| sigma, integral of K dt, K,
    transfers, stale events]``; ``acc[4]`` must hold the kinetic energy at the start.
    Returns the status (``OK``, ``REACHED_R_MAX``, ``NO_EVENTS``, ``STUCK``)."""
    t_last = acc[0]
    kin = acc[4]
    done = 0
    repeats = 0
    last_i = -1
    last_j = -1
    last_t = -1.0
    while done < n_coll:
        i = hp[0]
        t = ev_t[i]
        if t == math.inf:
            return NO_EVENTS
        if g > 0.0 and r0 + g * t > r_max:
            return REACHED_R_MAX
        if ev_kind[i] == COLLISION:
            j = ev_p[i]
            if count[j] != ev_cnt[i]:  # the partner has collided since: re-predict
                acc[6] += 1.0
                predict(i, t, x, v, tloc, dn, cell, head, nxt, nc, side, r0, g, ev_t,
                        ev_kind, ev_p, ev_cnt, count)
                heap.update(hp, hpos, ev_t, i)
                continue
            if t == last_t and ((i == last_i and j == last_j) or (i == last_j and j == last_i)):
                repeats += 1
                if repeats > MAX_REPEATS:
                    return STUCK
            else:
                repeats = 0
            last_i = i
            last_j = j
            last_t = t
            _advance(x, v, tloc, i, t)
            _advance(x, v, tloc, j, t)
            dx = _image(x[j, 0] - x[i, 0], side)
            dy = _image(x[j, 1] - x[i, 1], side)
            dz = _image(x[j, 2] - x[i, 2], side)
            before = (v[i, 0] ** 2 + v[i, 1] ** 2 + v[i, 2] ** 2
                      + v[j, 0] ** 2 + v[j, 1] ** 2 + v[j, 2] ** 2)
            acc[2] += collide(v, i, j, dx, dy, dz, 0.5 * (dn[i] + dn[j]) * g)
            after = (v[i, 0] ** 2 + v[i, 1] ** 2 + v[i, 2] ** 2
                     + v[j, 0] ** 2 + v[j, 1] ** 2 + v[j, 2] ** 2)
            acc[3] += kin * (t - t_last)
            t_last = t
            kin += 0.5 * (after - before)
            count[i] += 1
            count[j] += 1
            done += 1
            predict(i, t, x, v, tloc, dn, cell, head, nxt, nc, side, r0, g, ev_t, ev_kind,
                    ev_p, ev_cnt, count)
            heap.update(hp, hpos, ev_t, i)
            predict(j, t, x, v, tloc, dn, cell, head, nxt, nc, side, r0, g, ev_t, ev_kind,
                    ev_p, ev_cnt, count)
            heap.update(hp, hpos, ev_t, j)
        else:
            _advance(x, v, tloc, i, t)
            face = ev_p[i]
            a = face >> 1
            cells.remove(cells.cell_id(cell[i, 0], cell[i, 1], cell[i, 2], nc), i, head, nxt,
                         prv)
            if face & 1:
                cell[i, a] += 1
                if cell[i, a] == nc:
                    cell[i, a] = 0
                    x[i, a] -= side
            else:
                cell[i, a] -= 1
                if cell[i, a] < 0:
                    cell[i, a] = nc - 1
                    x[i, a] += side
            cells.insert(cells.cell_id(cell[i, 0], cell[i, 1], cell[i, 2], nc), i, head, nxt,
                         prv)
            acc[5] += 1.0
            predict(i, t, x, v, tloc, dn, cell, head, nxt, nc, side, r0, g, ev_t, ev_kind,
                    ev_p, ev_cnt, count)
            heap.update(hp, hpos, ev_t, i)
    acc[0] = t_last
    acc[1] += done
    acc[4] = kin
    return OK


@njit
def synchronize(x, v, tloc, t):
    """Move every particle to time ``t`` and restart the clock there (``tloc = 0``)."""
    for i in range(x.shape[0]):
        _advance(x, v, tloc, i, t)
        tloc[i] = 0.0


@njit
def min_ratio(x, dn, side, cell, head, nxt, nc):
    """Smallest ``|x_j - x_i| / ((D_i^nom + D_j^nom) / 2)`` over pairs in neighbouring
    cells (every pair closer than a cell side): the diameter ratio ``r`` at which the
    closest pair touches."""
    best = math.inf
    for i in range(x.shape[0]):
        for ox in range(-1, 2):
            cx = (cell[i, 0] + ox) % nc
            for oy in range(-1, 2):
                cy = (cell[i, 1] + oy) % nc
                for oz in range(-1, 2):
                    cz = (cell[i, 2] + oz) % nc
                    k = head[cells.cell_id(cx, cy, cz, nc)]
                    while k >= 0:
                        if k > i:
                            dx = _image(x[k, 0] - x[i, 0], side)
                            dy = _image(x[k, 1] - x[i, 1], side)
                            dz = _image(x[k, 2] - x[i, 2], side)
                            q = math.sqrt(dx * dx + dy * dy + dz * dz) / (0.5 * (dn[i] + dn[k]))
                            if q < best:
                                best = q
                        k = nxt[k]
    return best


@njit
def near_pairs(x, dn, r, side, cell, head, nxt, nc, tol, out):
    """Pairs whose gap ``|dr| - sigma`` is below ``tol sigma`` (``sigma = r (D_i^nom +
    D_j^nom) / 2``), written as rows ``i j dx dy dz gap`` of ``out`` (``dr = x_j - x_i``,
    minimum image); returns how many (at most ``len(out)``; the count goes on past it)."""
    m = 0
    for i in range(x.shape[0]):
        for ox in range(-1, 2):
            cx = (cell[i, 0] + ox) % nc
            for oy in range(-1, 2):
                cy = (cell[i, 1] + oy) % nc
                for oz in range(-1, 2):
                    cz = (cell[i, 2] + oz) % nc
                    k = head[cells.cell_id(cx, cy, cz, nc)]
                    while k >= 0:
                        if k > i:
                            dx = _image(x[k, 0] - x[i, 0], side)
                            dy = _image(x[k, 1] - x[i, 1], side)
                            dz = _image(x[k, 2] - x[i, 2], side)
                            sig = r * 0.5 * (dn[i] + dn[k])
                            gap = math.sqrt(dx * dx + dy * dy + dz * dz) - sig
                            if gap < tol * sig:
                                if m < out.shape[0]:
                                    out[m, 0] = i
                                    out[m, 1] = k
                                    out[m, 2] = dx
                                    out[m, 3] = dy
                                    out[m, 4] = dz
                                    out[m, 5] = gap
                                m += 1
                        k = nxt[k]
    return m


def thermal_velocities(n: int, temperature: float, rng) -> np.ndarray:
    """Gaussian velocities of unit masses with zero total momentum, scaled so that the
    kinetic energy is exactly ``3 N k_B T / 2`` (rms speed ``sqrt(3 T)``)."""
    v = rng.normal(size=(n, 3))
    v -= v.mean(axis=0)
    return v * math.sqrt(3.0 * n * temperature / float(np.sum(v * v)))


@dataclass
class Block:
    """What one block of collisions measured (time in the block's own clock)."""
    duration: float         #: time the block took
    collisions: int
    virial: float           #: sum over collisions of |J| sigma
    kinetic_mean: float     #: <K> over the block
    kinetic_end: float      #: K at its end (before any rescaling), summed afresh
    kinetic_tracked: float  #: K at its end as the collisions' energy changes add it up
    transfers: int
    stale: int
    reduced_pressure: float  #: Z = 1 + virial / (2 <K> t)
    pressure: float          #: collisional pressure virial / (3 V t)


class EDMD:
    """The state of a hard-sphere system in a periodic cube of side ``side``: positions
    ``x`` (N, 3) in ``[0, side)``, velocities ``v``, nominal diameters ``dn``, the
    diameter ratio ``r`` (diameters ``r dn``) and the compression rate ``rate`` (1 /
    time, ``dr/dt``). The cell grid is made for diameters up to the packing fraction
    ``phi_cap`` (:data:`PHI_CAP` unless given); ``r`` must leave every pair apart (``r
    <=`` :meth:`closest_ratio`)."""

    def __init__(self, x, v, dn, side: float, r: float, rate: float = 0.0,
                 phi_cap: float = PHI_CAP):
        self.n = len(dn)
        self.side = float(side)
        self.x = np.ascontiguousarray(np.mod(np.asarray(x, np.float64), self.side))
        self.v = np.array(v, np.float64, order="C")  # a copy: the dynamics changes it
        self.dn = np.array(dn, np.float64, order="C")
        self.r = float(r)
        self.rate = float(rate)
        volume_nom = float(np.sum(np.pi / 6.0 * self.dn**3))
        self.phi_cap = float(phi_cap)
        r_cap = (self.phi_cap * self.side**3 / volume_nom) ** (1.0 / 3.0)
        self.nc = cells.cells_per_side(self.side, float(np.max(self.dn)) * r_cap)
        #: the largest ratio the grid allows (cells no smaller than the largest diameter)
        self.r_max = self.side / self.nc / float(np.max(self.dn))
        self.cell, self.head, self.nxt, self.prv = cells.empty(self.n, self.nc)
        cells.build(self.x, self.nc, self.side, self.cell, self.head, self.nxt, self.prv)
        self.tloc = np.zeros(self.n)
        self.ev_t = np.zeros(self.n)
        self.ev_kind = np.zeros(self.n, np.int64)
        self.ev_p = np.zeros(self.n, np.int64)
        self.ev_cnt = np.zeros(self.n, np.int64)
        self.count = np.zeros(self.n, np.int64)
        self.hp, self.hpos = heap.empty(self.n)
        #: collisions and simulated time since the state was made
        self.collisions = 0
        self.time = 0.0

    #: what :meth:`arrays` saves: between blocks (every ``tloc`` 0, every event predicted
    #: afresh at the next block) these make the whole state, the cell lists included,
    #: whose order decides ties and whose transfers decide where a flight is cut
    ARRAYS = ("x", "v", "dn", "cell", "head", "nxt", "prv", "count")
    SCALARS = ("side", "r", "rate", "phi_cap", "collisions", "time")

    def arrays(self) -> dict:
        """The state between blocks, to save (:meth:`from_arrays` restores it)."""
        out = {k: getattr(self, k).copy() for k in self.ARRAYS}
        out.update({k: np.asarray(getattr(self, k)) for k in self.SCALARS})
        return out

    @classmethod
    def from_arrays(cls, a) -> "EDMD":
        """The state :meth:`arrays` saved, exactly: a run continued from it is the same
        run."""
        s = cls(a["x"], a["v"], a["dn"], float(a["side"]), float(a["r"]), float(a["rate"]),
                phi_cap=float(a["phi_cap"]))
        for k in cls.ARRAYS:
            getattr(s, k)[...] = a[k]
        s.collisions = int(a["collisions"])
        s.time = float(a["time"])
        return s

    # -- measures ------------------------------------------------------------------------
    @property
    def volume(self) -> float:
        return self.side**3

    def packing_fraction(self) -> float:
        """``phi = sum pi (r D_i^nom)^3 / 6 / L^3``."""
        return float(np.sum(np.pi / 6.0 * (self.r * self.dn) ** 3)) / self.volume

    def kinetic_energy(self) -> float:
        return 0.5 * float(np.sum(self.v * self.v))

    def temperature(self) -> float:
        """``k_B T = 2 K / (3 N)``."""
        return 2.0 * self.kinetic_energy() / (3.0 * self.n)

    def closest_ratio(self) -> float:
        """The ratio ``r`` at which the closest pair touches (:func:`min_ratio`)."""
        return float(min_ratio(self.x, self.dn, self.side, self.cell, self.head, self.nxt,
                               self.nc))

    def near_contacts(self, tol: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``(ij (C, 2), dr (C, 3), gap (C,))`` of the pairs whose gap is below ``tol``
        times their contact distance (``dr = x_j - x_i``, minimum image)."""
        out = np.empty((max(16, 8 * self.n), 6))
        m = near_pairs(self.x, self.dn, self.r, self.side, self.cell, self.head, self.nxt,
                       self.nc, float(tol), out)
        if m > len(out):
            out = np.empty((m, 6))
            m = near_pairs(self.x, self.dn, self.r, self.side, self.cell, self.head, self.nxt,
                           self.nc, float(tol), out)
        out = out[:m]
        return out[:, :2].astype(np.int64), out[:, 2:5].copy(), out[:, 5].copy()

    # -- dynamics ------------------------------------------------------------------------
    def rescale(self, temperature: float) -> None:
        """Scale the velocities to the temperature ``k_B T`` (kinetic energy ``3 N T /
        2``): the growth's pushes heat the system, Lubachevsky-Stillinger take the heat
        out after every block."""
        self.v *= math.sqrt(1.5 * self.n * temperature / self.kinetic_energy())

    def block(self, n_coll: int) -> Block:
        """Run ``n_coll`` collisions at the compression rate :attr:`rate`, then move every
        particle to the end time and restart the clock (``r`` takes its new value).
        Raises :class:`DynamicsError` if the diameters would pass the grid's
        :attr:`r_max` or the dynamics stalls."""
        r0, g = self.r, self.rate
        predict_all(self.x, self.v, self.tloc, self.dn, self.cell, self.head, self.nxt,
                    self.nc, self.side, r0, g, self.ev_t, self.ev_kind, self.ev_p,
                    self.ev_cnt, self.count, self.hp, self.hpos)
        acc = np.zeros(7)
        acc[4] = self.kinetic_energy()
        status = run_block(self.x, self.v, self.tloc, self.dn, self.cell, self.head, self.nxt,
                           self.prv, self.nc, self.side, r0, g, self.r_max, self.ev_t,
                           self.ev_kind, self.ev_p, self.ev_cnt, self.count, self.hp,
                           self.hpos, int(n_coll), acc)
        if status != OK:
            phi = self.packing_fraction()
            what = {REACHED_R_MAX: f"the diameters would pass the packing fraction "
                                   f"{self.phi_cap} the cell grid is made for",
                    NO_EVENTS: "no particle moves",
                    STUCK: f"one pair collided {MAX_REPEATS} times at the same instant"}
            raise DynamicsError(f"hard-sphere dynamics stopped at phi = {phi:.6f} "
                                f"(rate {g:g}): {what[status]}")
        t = float(acc[0])
        synchronize(self.x, self.v, self.tloc, t)
        self.r = r0 + g * t
        self.collisions += int(acc[1])
        self.time += t
        kin_end = self.kinetic_energy()
        kin_mean = acc[3] / t if t > 0 else kin_end
        z = 1.0 + acc[2] / (2.0 * acc[3]) if acc[3] > 0 else math.inf
        p = acc[2] / (3.0 * self.volume * t) if t > 0 else math.inf
        return Block(t, int(acc[1]), float(acc[2]), float(kin_mean), kin_end, float(acc[4]),
                     int(acc[5]), int(acc[6]), float(z), float(p))
