"""Event-driven molecular dynamics of hard spheres with growing diameters in a periodic
cube (Lubachevsky & Stillinger 1990, Lubachevsky 1991: refs. 36, 37 of Baranau &
Tallarek 2014), with neighbour lists (Donev, Torquato & Stillinger 2005).

The diameters are ``D_i(t) = r(t) D_i^nom`` with ``r(t) = r_0 + gamma t``: ``gamma``
(1 / time) is the compression rate of the paper, the growth speed of a diameter in units
of its nominal diameter (whose mean is 1). Particles fly freely between events; each has
one pending event, the earlier of its next collision (:mod:`pysim.hard.collide`) with a
particle of its neighbour list and its *exit* from its ball, kept in an indexed heap
(:mod:`pysim.hard.heap`). A particle's position is stored at its own last event time
``tloc[i]``.

Neighbour lists: particle ``i`` stays within ``delta = SKIN / 4`` of its ball's centre
``c_i`` (its position when its list was made); ``k`` is on ``i``'s list (and ``i`` on
``k``'s) when ``|c_i - c_k| < sigma_ik(r_lim) + 2 delta``, ``sigma_ik(r) = r (D_i^nom +
D_k^nom) / 2`` and ``r_lim = r + SKIN / (2 max D^nom)``. While both stay in their balls
and ``r <= r_lim``, a pair off the lists cannot touch. A particle leaving its ball
makes a new ball and list (found with a cell grid of the centres, :mod:`pysim.hard.cells`)
and is put on its new neighbours' lists; when ``r`` reaches ``r_lim`` every list is made
afresh. A collision predicted with a partner that has collided since (its collision
counter moved on) is stale and only re-predicted; a particle that changes its flight or
its list re-predicts against all its neighbours, so no collision is missed.

The dynamics runs in *blocks* of a given number of collisions (the paper's 20 per
particle). Every block starts afresh (clock at 0, ``r_0`` the ratio reached, lists and
events made anew from the positions and velocities), so a run continued from the state
saved between blocks is the same run. Over a block of duration ``t`` the reduced
pressure is the virial theorem with unit masses (ref. 40, with the block's mean kinetic
energy ``<K>`` in place of its last):

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
EXIT = 1

#: status of a kernel
OK, OVERFLOW, NO_EVENTS, STUCK, BOX, RUNAWAY = 0, 1, 2, 3, 4, 5
#: events (of any kind) per collision above which a block is taken as running away
MAX_EVENTS_PER_COLLISION = 1000
#: zero-time collisions of one pair in a row taken as a run that cannot go on
MAX_REPEATS = 1000
#: reach of the neighbour lists beyond contact, in units of the mean nominal diameter:
#: balls of radius SKIN / 4, contact distances growing by up to SKIN / 2 between remakes
SKIN = 0.2
#: neighbours a list holds at first (doubled whenever a block needs more)
FIRST_CAPACITY = 32


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
    # differences of positions within a ball's radius of [0, side): one wrap is enough,
    # and a compare is cheaper than a floor
    if d >= 0.5 * side:
        return d - side
    if d < -0.5 * side:
        return d + side
    return d


@inline_njit
def _wrap(y, side):
    if y < 0.0:
        y += side
    elif y >= side:
        y -= side
    if y >= side or y < 0.0:  # round-off, or a coordinate further out
        y -= side * math.floor(y / side)
        if y >= side:
            y = 0.0
    return y


@inline_njit
def _add(i, k, nl, nn):
    """Put ``k`` on ``i``'s list; False when the list is full."""
    m = nn[i]
    if m >= nl.shape[1]:
        return False
    nl[i, m] = k
    nn[i] = m + 1
    return True


@inline_njit
def _drop(i, k, nl, nn):
    """Take ``k`` off ``i``'s list (the last entry takes its place)."""
    m = nn[i]
    for a in range(m):
        if nl[i, a] == k:
            nl[i, a] = nl[i, m - 1]
            nn[i] = m - 1
            return


@njit
def _neighbours_of(i, c, dn, side, r_lim, half_skin, nc, cell, head, nxt, nl, nn, only_above):
    """Put on ``i``'s list, and ``i`` on theirs, the particles whose centres are within
    ``sigma(r_lim) + half_skin`` of ``c_i`` (those above ``i`` only, when
    ``only_above``); False when a list is full."""
    for ox in range(-1, 2):
        for oy in range(-1, 2):
            for oz in range(-1, 2):
                k = head[cells.neighbour_cell(cell[i], ox, oy, oz, nc)]
                while k >= 0:
                    if k != i and (k > i or not only_above):
                        dx = _image(c[k, 0] - c[i, 0], side)
                        dy = _image(c[k, 1] - c[i, 1], side)
                        dz = _image(c[k, 2] - c[i, 2], side)
                        reach = 0.5 * (dn[i] + dn[k]) * r_lim + half_skin
                        if dx * dx + dy * dy + dz * dz < reach * reach:
                            if not _add(i, k, nl, nn) or not _add(k, i, nl, nn):
                                return False
                    k = nxt[k]
    return True


@njit
def make_lists(x, dn, side, r, g, skin, nc_max, c, cell, head, nxt, prv, nl, nn, lim):
    """Wrap every position into the box, make it its ball's centre, sort the centres into
    the cell grid and make every neighbour list; ``lim`` gets ``[r_lim, nc]`` (``r_lim``
    infinite without growth). Returns ``OK``, ``OVERFLOW`` (a list is full) or ``BOX``
    (fewer than 3 cells of the reach fit)."""
    n = x.shape[0]
    dmax = np.max(dn)
    r_lim = r + 0.5 * skin / dmax if g > 0.0 else r
    half_skin = 0.5 * skin
    reach = dmax * r_lim + half_skin
    ncf = math.floor(side / reach)
    if ncf < cells.MIN_CELLS:
        return BOX
    nc = min(int(ncf), nc_max)
    for i in range(n):
        for a in range(3):
            x[i, a] = _wrap(x[i, a], side)
            c[i, a] = x[i, a]
    cells.build(c, nc, side, cell, head, nxt, prv)
    nn[:] = 0
    for i in range(n):
        if not _neighbours_of(i, c, dn, side, r_lim, half_skin, nc, cell, head, nxt, nl, nn,
                              True):
            return OVERFLOW
    lim[0] = r_lim if g > 0.0 else math.inf
    lim[1] = nc
    return OK


@njit
def _remake(i, x, c, dn, side, r_lim, half_skin, nc, cell, head, nxt, prv, nl, nn):
    """Particle ``i`` left its ball: a new ball at its (wrapped) position, a new list,
    and ``i`` off its old neighbours' lists and on its new ones'. False when full."""
    for m in range(nn[i]):
        _drop(nl[i, m], i, nl, nn)
    nn[i] = 0
    for a in range(3):
        x[i, a] = _wrap(x[i, a], side)
        c[i, a] = x[i, a]
    cells.remove(cell[i], i, head, nxt, prv)
    cell[i] = cells.cell_of(c[i, 0], c[i, 1], c[i, 2], side / nc, nc)
    cells.insert(cell[i], i, head, nxt, prv)
    return _neighbours_of(i, c, dn, side, r_lim, half_skin, nc, cell, head, nxt, nl, nn, False)


@inline_njit
def _exit_time(px, py, pz, vx, vy, vz, delta):
    """Time until a particle at ``p`` from its ball's centre, with velocity ``v``, is
    ``delta`` away from it: ``|p + v tau| = delta``. The speed is factored out first:
    rattlers that never collide keep shrinking with every rescaling of the velocities,
    and ``v.v`` of such a one underflows."""
    m = max(abs(vx), abs(vy), abs(vz))
    if m == 0.0:
        return math.inf
    ux = vx / m
    uy = vy / m
    uz = vz / m
    un = math.sqrt(ux * ux + uy * uy + uz * uz)
    ux /= un
    uy /= un
    uz /= un
    speed = m * un
    q = delta * delta - (px * px + py * py + pz * pz)  # >= 0 inside the ball
    if q <= 0.0:
        return 0.0
    b = px * ux + py * uy + pz * uz  # the position along the flight
    if b > 0.0:
        return q / (b + math.sqrt(b * b + q)) / speed
    return (-b + math.sqrt(b * b + q)) / speed


@njit
def predict(i, t, x, v, tloc, dn, c, delta, nl, nn, side, r0, g, ev_t, ev_kind, ev_p,
            ev_cnt, count):
    """Move particle ``i`` to time ``t`` and set its next event: the earliest collision
    with a particle of its list, or its exit from its ball."""
    _advance(x, v, tloc, i, t)
    tau = _exit_time(x[i, 0] - c[i, 0], x[i, 1] - c[i, 1], x[i, 2] - c[i, 2], v[i, 0],
                     v[i, 1], v[i, 2], delta)
    best = t + tau
    kind = EXIT
    partner = -1
    r = r0 + g * t
    xi0 = x[i, 0]
    xi1 = x[i, 1]
    xi2 = x[i, 2]
    for m in range(nn[i]):
        k = nl[i, m]
        dtk = t - tloc[k]
        dx = _image(x[k, 0] + v[k, 0] * dtk - xi0, side)
        dy = _image(x[k, 1] + v[k, 1] * dtk - xi1, side)
        dz = _image(x[k, 2] + v[k, 2] * dtk - xi2, side)
        s = 0.5 * (dn[i] + dn[k])
        tc = t + collision_time(dx, dy, dz, v[k, 0] - v[i, 0], v[k, 1] - v[i, 1],
                                v[k, 2] - v[i, 2], s * r, s * g)
        if tc < best:
            best = tc
            kind = COLLISION
            partner = k
    ev_t[i] = best
    ev_kind[i] = kind
    ev_p[i] = partner
    if kind == COLLISION:
        ev_cnt[i] = count[partner]


@njit
def predict_all(t, x, v, tloc, dn, c, delta, nl, nn, side, r0, g, ev_t, ev_kind, ev_p,
                ev_cnt, count, hp, hpos):
    """Predict every particle's next event at time ``t`` and build the queue."""
    for i in range(x.shape[0]):
        predict(i, t, x, v, tloc, dn, c, delta, nl, nn, side, r0, g, ev_t, ev_kind, ev_p,
                ev_cnt, count)
    heap.build(hp, hpos, ev_t)


@njit
def run_block(x, v, tloc, dn, c, cell, head, nxt, prv, nl, nn, side, skin, nc_max, r0, g,
              lim, ev_t, ev_kind, ev_p, ev_cnt, count, hp, hpos, n_coll, acc):
    """Process events until ``n_coll`` collisions are done. ``lim`` holds ``[r_lim, nc]``
    of the lists (:func:`make_lists`); when the diameters reach ``r_lim`` every particle
    moves there and the lists are made afresh. ``acc`` accumulates, from the block's
    start: ``[time of the last collision, collisions, virial sum |J| sigma, integral of
    K dt, K, ball exits, stale events, list remakes]``; ``acc[4]`` must hold the kinetic
    energy at the start. Returns the status."""
    n = x.shape[0]
    delta = 0.25 * skin
    half_skin = 0.5 * skin
    t_lim = (lim[0] - r0) / g if g > 0.0 else math.inf
    nc = int(lim[1])
    t_last = acc[0]
    kin = acc[4]
    done = 0
    repeats = 0
    last_i = -1
    last_j = -1
    last_t = -1.0
    events = 0
    max_events = MAX_EVENTS_PER_COLLISION * (n_coll + n)
    while done < n_coll:
        events += 1
        if events > max_events:
            acc[0] = t_last
            acc[1] += done
            return RUNAWAY
        i = hp[0]
        t = ev_t[i]
        if t > t_lim:  # the diameters reach the lists' limit: make them afresh there
            for k in range(n):
                _advance(x, v, tloc, k, t_lim)
            status = make_lists(x, dn, side, r0 + g * t_lim, g, skin, nc_max, c, cell, head,
                                nxt, prv, nl, nn, lim)
            if status != OK:
                return status
            predict_all(t_lim, x, v, tloc, dn, c, delta, nl, nn, side, r0, g, ev_t, ev_kind,
                        ev_p, ev_cnt, count, hp, hpos)
            t_lim = (lim[0] - r0) / g
            nc = int(lim[1])
            acc[7] += 1.0
            continue
        if t == math.inf:
            return NO_EVENTS
        if ev_kind[i] == COLLISION:
            j = ev_p[i]
            if count[j] != ev_cnt[i]:  # the partner has collided since: re-predict
                acc[6] += 1.0
                predict(i, t, x, v, tloc, dn, c, delta, nl, nn, side, r0, g, ev_t, ev_kind,
                        ev_p, ev_cnt, count)
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
            predict(i, t, x, v, tloc, dn, c, delta, nl, nn, side, r0, g, ev_t, ev_kind, ev_p,
                    ev_cnt, count)
            heap.update(hp, hpos, ev_t, i)
            predict(j, t, x, v, tloc, dn, c, delta, nl, nn, side, r0, g, ev_t, ev_kind, ev_p,
                    ev_cnt, count)
            heap.update(hp, hpos, ev_t, j)
        else:
            _advance(x, v, tloc, i, t)
            if not _remake(i, x, c, dn, side, lim[0] if g > 0.0 else r0, half_skin, nc, cell,
                           head, nxt, prv, nl, nn):
                return OVERFLOW
            acc[5] += 1.0
            predict(i, t, x, v, tloc, dn, c, delta, nl, nn, side, r0, g, ev_t, ev_kind, ev_p,
                    ev_cnt, count)
            heap.update(hp, hpos, ev_t, i)
    acc[0] = t_last
    acc[1] += done
    acc[4] = kin
    return OK


@njit
def synchronize(x, v, tloc, t, side):
    """Move every particle to time ``t``, wrap it into the box and restart the clock
    there (``tloc = 0``)."""
    for i in range(x.shape[0]):
        _advance(x, v, tloc, i, t)
        tloc[i] = 0.0
        for a in range(3):
            x[i, a] = _wrap(x[i, a], side)


@njit
def _pairs(x, dn, side, r, tol, nc, cell, head, nxt, out):
    """Pairs closer than ``(1 + tol)`` times their contact distance ``sigma = r (D_i^nom +
    D_j^nom) / 2``, found with the cell grid given, as rows ``i j dx dy dz gap`` of
    ``out`` (``dr = x_j - x_i``, minimum image); returns how many (the count goes on
    past ``len(out)``), and the smallest ratio ``|dr| / (sigma / r)`` seen."""
    m = 0
    best = math.inf
    for i in range(x.shape[0]):
        for ox in range(-1, 2):
            for oy in range(-1, 2):
                for oz in range(-1, 2):
                    k = head[cells.neighbour_cell(cell[i], ox, oy, oz, nc)]
                    while k >= 0:
                        if k > i:
                            dx = _image(x[k, 0] - x[i, 0], side)
                            dy = _image(x[k, 1] - x[i, 1], side)
                            dz = _image(x[k, 2] - x[i, 2], side)
                            d = math.sqrt(dx * dx + dy * dy + dz * dz)
                            s0 = 0.5 * (dn[i] + dn[k])
                            if d / s0 < best:
                                best = d / s0
                            gap = d - r * s0
                            if gap < tol * r * s0:
                                if m < out.shape[0]:
                                    out[m, 0] = i
                                    out[m, 1] = k
                                    out[m, 2] = dx
                                    out[m, 3] = dy
                                    out[m, 4] = dz
                                    out[m, 5] = gap
                                m += 1
                        k = nxt[k]
    return m, best


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
    exits: int              #: particles that left their balls (new lists)
    stale: int
    remakes: int            #: times every list was made afresh as the diameters grew
    reduced_pressure: float  #: Z = 1 + virial / (2 <K> t)
    pressure: float          #: collisional pressure virial / (3 V t)


class EDMD:
    """The state of a hard-sphere system in a periodic cube of side ``side``: positions
    ``x`` (N, 3), velocities ``v``, nominal diameters ``dn``, the diameter ratio ``r``
    (diameters ``r dn``) and the compression rate ``rate`` (1 / time, ``dr/dt``); ``r``
    must leave every pair apart (``r <=`` :meth:`closest_ratio`)."""

    #: what :meth:`arrays` saves: between blocks these make the whole state (lists and
    #: events are made afresh at every block's start)
    ARRAYS = ("x", "v", "dn", "count")
    SCALARS = ("side", "r", "rate", "collisions", "time")

    def __init__(self, x, v, dn, side: float, r: float, rate: float = 0.0):
        self.n = len(dn)
        self.side = float(side)
        self.x = np.ascontiguousarray(np.mod(np.asarray(x, np.float64), self.side))
        self.v = np.array(v, np.float64, order="C")  # a copy: the dynamics changes it
        self.dn = np.array(dn, np.float64, order="C")
        self.r = float(r)
        self.rate = float(rate)
        self.nc_max = cells.max_cells(self.side, self.n)
        self.c = np.zeros((self.n, 3))
        self.cell, self.head, self.nxt, self.prv = cells.empty(self.n, self.nc_max)
        self.capacity = FIRST_CAPACITY
        self.nl = np.zeros((self.n, self.capacity), np.int64)
        self.nn = np.zeros(self.n, np.int64)
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

    def arrays(self) -> dict:
        """The state between blocks, to save (:meth:`from_arrays` restores it)."""
        out = {k: getattr(self, k).copy() for k in self.ARRAYS}
        out.update({k: np.asarray(getattr(self, k)) for k in self.SCALARS})
        return out

    @classmethod
    def from_arrays(cls, a) -> "EDMD":
        """The state :meth:`arrays` saved, exactly: a run continued from it is the same
        run."""
        s = cls(a["x"], a["v"], a["dn"], float(a["side"]), float(a["r"]), float(a["rate"]))
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

    def _scan(self, r: float, tol: float, reach: float, size: int):
        """:func:`_pairs` on a grid of cells no smaller than ``reach`` (3 per side at
        least: then every pair is seen)."""
        nc = max(cells.MIN_CELLS, min(int(self.side / reach), self.nc_max))
        cell, head, nxt, prv = cells.empty(self.n, nc)
        x = np.mod(self.x, self.side)
        cells.build(x, nc, self.side, cell, head, nxt, prv)
        out = np.empty((size, 6))
        m, best = _pairs(x, self.dn, self.side, r, tol, nc, cell, head, nxt, out)
        return nc, m, best, out, (x, cell, head, nxt)

    def closest_ratio(self) -> float:
        """The ratio ``r`` at which the closest pair touches: ``min |x_j - x_i| /
        ((D_i^nom + D_j^nom) / 2)``."""
        reach = 2.0 * self.side / self.n ** (1.0 / 3.0)
        while True:
            nc, _, best, _, _ = self._scan(0.0, -1.0, reach, 1)
            # a pair not seen is farther apart than a cell side
            if nc == cells.MIN_CELLS or best * float(np.max(self.dn)) <= self.side / nc:
                return float(best)
            reach *= 2.0

    def near_contacts(self, tol: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``(ij (C, 2), dr (C, 3), gap (C,))`` of the pairs whose gap is below ``tol``
        times their contact distance (``dr = x_j - x_i``, minimum image)."""
        reach = float(np.max(self.dn)) * self.r * (1.0 + tol)
        size = max(16, 8 * self.n)
        _, m, _, out, _ = self._scan(self.r, float(tol), reach, size)
        if m > size:
            _, m, _, out, _ = self._scan(self.r, float(tol), reach, m)
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
        Raises :class:`DynamicsError` if the dynamics stalls or the box holds fewer than
        3 cells of the neighbour lists' reach."""
        r0, g = self.r, self.rate
        start = (self.x.copy(), self.v.copy(), self.count.copy())
        while True:
            self.tloc[:] = 0.0
            lim = np.zeros(2)
            acc = np.zeros(8)
            acc[4] = self.kinetic_energy()
            status = make_lists(self.x, self.dn, self.side, r0, g, SKIN, self.nc_max, self.c,
                                self.cell, self.head, self.nxt, self.prv, self.nl, self.nn, lim)
            if status == OK:
                predict_all(0.0, self.x, self.v, self.tloc, self.dn, self.c, 0.25 * SKIN,
                            self.nl, self.nn, self.side, r0, g, self.ev_t, self.ev_kind,
                            self.ev_p, self.ev_cnt, self.count, self.hp, self.hpos)
                status = run_block(self.x, self.v, self.tloc, self.dn, self.c, self.cell,
                                   self.head, self.nxt, self.prv, self.nl, self.nn, self.side,
                                   SKIN, self.nc_max, r0, g, lim, self.ev_t, self.ev_kind,
                                   self.ev_p, self.ev_cnt, self.count, self.hp, self.hpos,
                                   int(n_coll), acc)
            if status != OVERFLOW:
                break
            # a list was full: the block again from its start with twice the room (the
            # lists' order does not depend on their room, so neither does the run)
            self.x[...], self.v[...], self.count[...] = start
            self.capacity *= 2
            self.nl = np.zeros((self.n, self.capacity), np.int64)
        if status != OK:
            phi = self.packing_fraction()
            what = {NO_EVENTS: "no particle moves",
                    STUCK: f"one pair collided {MAX_REPEATS} times at the same instant",
                    RUNAWAY: f"{MAX_EVENTS_PER_COLLISION} events a collision and more",
                    BOX: f"the box holds fewer than {cells.MIN_CELLS} cells of the largest "
                         "contact distance and skin per side; use more particles"}
            raise DynamicsError(f"hard-sphere dynamics stopped at phi = {phi:.6f} "
                                f"(rate {g:g}): {what[status]}")
        t = float(acc[0])
        synchronize(self.x, self.v, self.tloc, t, self.side)
        self.r = r0 + g * t
        self.collisions += int(acc[1])
        self.time += t
        kin_end = self.kinetic_energy()
        kin_mean = acc[3] / t if t > 0 else kin_end
        z = 1.0 + acc[2] / (2.0 * acc[3]) if acc[3] > 0 else math.inf
        p = acc[2] / (3.0 * self.volume * t) if t > 0 else math.inf
        return Block(t, int(acc[1]), float(acc[2]), float(kin_mean), kin_end, float(acc[4]),
                     int(acc[5]), int(acc[6]), int(acc[7]), float(z), float(p))
