"""The event-driven hard-sphere dynamics (pysim.hard): collision prediction against a
slow NumPy reference, the event loop against a brute-force all-pairs simulation, no
overlaps, energy and momentum bookkeeping, and the pressure of a fluid."""
import math

import numpy as np
import pytest

from pysim.hard import heap
from pysim.hard.collide import collide, collision_time
from pysim.hard.edmd import EDMD, thermal_velocities
from pysim.initial import random_spheres, sample_diameters


def reference_time(dr, dv, s, sdot):
    """First root ``tau >= 0`` of ``|dr + dv tau|^2 = (s + sdot tau)^2`` at which the gap
    closes (the textbook quadratic formula in complex arithmetic), ``inf`` if none."""
    a = dv @ dv - sdot**2
    b = dr @ dv - s * sdot
    c = dr @ dr - s**2
    if a == 0.0:
        roots = [-c / (2 * b)] if b != 0 else []
    else:
        sq = np.sqrt(complex(b * b - a * c))
        roots = [(-b - sq) / a, (-b + sq) / a]
    ok = [z.real for z in map(complex, roots)
          if abs(z.imag) < 1e-12 and z.real >= -1e-12 and 2 * a * z.real + 2 * b < 0]
    return max(min(ok), 0.0) if ok else math.inf


def test_collision_time_matches_the_quadratic_formula(rng):
    checked = 0
    for _ in range(4000):
        dr = rng.normal(size=3) * rng.uniform(0.5, 3.0)
        dv = rng.normal(size=3)
        s = rng.uniform(0.3, 1.0) * np.linalg.norm(dr)  # apart
        sdot = rng.choice([0.0, rng.uniform(0, 2.0)])
        got = collision_time(*dr, *dv, s, sdot)
        want = reference_time(dr, dv, s, sdot)
        if math.isinf(want):
            assert math.isinf(got)
            continue
        checked += 1
        assert got == pytest.approx(want, rel=1e-9, abs=1e-12)
        # they touch then
        assert np.linalg.norm(dr + dv * got) == pytest.approx(s + sdot * got, rel=1e-10)
    assert checked > 1000


def test_touching_pairs_collide_now_only_when_closing():
    n = np.array([1.0, 0.0, 0.0])
    # touching, closing
    assert collision_time(*n, -0.1, 0, 0, 1.0, 0.0) == 0.0
    # touching, separating, no growth: never
    assert math.isinf(collision_time(*n, 0.1, 0, 0, 1.0, 0.0))
    # touching, separating slower than... faster than the contact distance grows: they
    # meet again when the growth catches up, at tau = 2 (v - sdot) / (sdot^2 - v^2) * s
    v, sdot = 0.1, 0.5
    tau = collision_time(*n, v, 0, 0, 1.0, sdot)
    assert 1.0 + v * tau == pytest.approx(1.0 + sdot * tau) or tau == pytest.approx(0.0)
    # overlapping by round-off and separating, the growth faster: at once
    assert collision_time(*(n * (1 - 1e-16)), 0.5, 0, 0, 1.0, 0.5) == 0.0


def test_ball_exit_time(rng):
    """Time until a particle leaves its neighbour-list ball, also at speeds whose square
    underflows (rattlers that never collide shrink with every rescaling)."""
    from pysim.hard.edmd import _exit_time

    for _ in range(200):
        p = rng.normal(size=3)
        p *= rng.uniform(0, 0.05) / np.linalg.norm(p)
        v = rng.normal(size=3) * 10.0 ** rng.uniform(-170, 2)
        tau = _exit_time(*p, *v, 0.05)
        assert np.linalg.norm(p + v * tau) == pytest.approx(0.05, rel=1e-9)
        assert tau > 0
    assert math.isinf(_exit_time(0.01, 0, 0, 0, 0, 0, 0.05))
    assert _exit_time(0.06, 0, 0, 1.0, 0, 0, 0.05) == 0.0


def test_collision_rule(rng):
    v = rng.normal(size=(2, 3))
    p0 = v.sum(axis=0)
    dr = np.array([0.6, 0.8, 0.0])
    vn0 = (v[1] - v[0]) @ dr
    sdot = 0.3
    w = collide(v, 0, 1, *dr, sdot)
    assert np.allclose(v.sum(axis=0), p0, atol=1e-15)
    assert w == pytest.approx(abs(vn0) * 1.0)
    # the normal relative velocity is reversed and gains 4 sdot; the rest is unchanged
    assert (v[1] - v[0]) @ dr == pytest.approx(-vn0 + 4 * sdot)


def test_heap_orders_any_updates(rng):
    n = 257
    key = rng.uniform(size=n)
    hp, pos = heap.empty(n)
    heap.build(hp, pos, key)
    for _ in range(2000):
        i = rng.integers(n)
        key[i] = rng.uniform() if rng.uniform() < 0.5 else key[i] * rng.uniform()
        heap.update(hp, pos, key, i)
        assert key[hp[0]] == key.min()
    assert np.array_equal(hp[pos], np.arange(n))
    for k in range(1, n):
        assert key[hp[(k - 1) // 2]] <= key[hp[k]]


def fluid(rng, n=200, phi=0.2, sigma=0.2, seed=4):
    """Polydisperse spheres at random (RSA) at ``phi``, thermal velocities at T = 0.2."""
    d = sample_diameters(n, "lognormal", 1.0, sigma, rng)
    x, d, box = random_spheres(d, phi, seed)
    return x, thermal_velocities(n, 0.2, rng), d, float(box[0])


def reference_times(dr, dv, s, sdot):
    """:func:`reference_time` of many pairs at once (rows of ``dr``, ``dv``)."""
    a = np.einsum("ij,ij->i", dv, dv) - sdot**2
    b = np.einsum("ij,ij->i", dr, dv) - s * sdot
    c = np.einsum("ij,ij->i", dr, dr) - s**2
    sq = np.sqrt((b * b - a * c).astype(complex))
    with np.errstate(divide="ignore", invalid="ignore"):
        roots = np.stack([(-b - sq) / a, (-b + sq) / a])
    ok = (np.abs(roots.imag) < 1e-12) & (roots.real >= -1e-12) & (a * roots.real + b < 0)
    tau = np.where(ok, np.maximum(roots.real, 0.0), np.inf).min(axis=0)
    return np.where(a == 0.0, np.inf, tau)  # no pair of these tests has a == 0


def brute_force(x, v, dn, side, r0, g, n_coll):
    """All-pairs event-driven reference in NumPy: repeatedly find the earliest collision
    over every pair, move everything there and collide the pair as the rule says.
    Returns the pairs, times and final positions and velocities."""
    x, v = x.copy(), v.copy()
    iu, ju = np.triu_indices(len(dn), 1)
    t = 0.0
    pairs, times = [], []
    for _ in range(n_coll):
        dr = x[ju] - x[iu]
        dr -= side * np.round(dr / side)
        dv = v[ju] - v[iu]
        sig = 0.5 * (dn[iu] + dn[ju])
        taus = reference_times(dr, dv, sig * (r0 + g * t), sig * g)
        k = int(np.argmin(taus))
        best = taus[k]
        x += v * best
        t += best
        i, j = iu[k], ju[k]
        d = x[j] - x[i]
        d -= side * np.round(d / side)
        nrm = d / np.linalg.norm(d)
        vn = (v[j] - v[i]) @ nrm
        kick = vn - 2.0 * sig[k] * g
        v[i] += kick * nrm
        v[j] -= kick * nrm
        pairs.append((min(i, j), max(i, j)))
        times.append(t)
    return pairs, np.array(times), np.mod(x, side), v


@pytest.mark.parametrize("g", [0.0, 0.2])
def test_event_loop_matches_brute_force(rng, g):
    """The same collisions, in the same order, at the same times, as the all-pairs
    reference (every pair, no lists); one block of 300 collisions (lazy invalidation of stale events) ends in
    the same state as 300 blocks of one (every event predicted afresh)."""
    x, v, d, side = fluid(rng, n=100, phi=0.1, sigma=0.1)
    want_pairs, want_t, want_x, want_v = brute_force(x, v, d, side, 1.0, g, 150)
    one = EDMD(x, v, d, side, 1.0, rate=g)
    pairs, times = [], []
    for _ in range(150):
        before = one.count.copy()
        one.block(1)
        ij = np.flatnonzero(one.count != before)
        pairs.append(tuple(ij))
        times.append(one.time)
    assert pairs == want_pairs
    assert np.allclose(times, want_t, rtol=1e-9, atol=1e-12)
    dx = one.x - want_x
    dx -= side * np.round(dx / side)
    assert np.abs(dx).max() < 1e-8 and np.abs(one.v - want_v).max() < 1e-8
    many = EDMD(x, v, d, side, 1.0, rate=g)
    blk = many.block(150)
    # particles left their balls (new lists) and, growing, every list was made afresh
    assert blk.exits > 0 and (blk.remakes > 0 or g == 0)
    assert np.array_equal(many.count, one.count)
    dx = many.x - one.x
    dx -= side * np.round(dx / side)
    assert np.abs(dx).max() < 1e-9 and many.r == pytest.approx(one.r, rel=1e-12)


def test_energy_and_momentum_bookkeeping(rng):
    """Without growth the kinetic energy and the (zero) momentum stay; with growth the
    energy the collisions' pushes add is tracked exactly and momentum still stays."""
    x, v, d, side = fluid(rng, n=300, phi=0.3, sigma=0.1)
    s = EDMD(x, v, d, side, 1.0, rate=0.0)
    k0 = s.kinetic_energy()
    for _ in range(3):
        blk = s.block(2000)
        assert blk.kinetic_end == pytest.approx(k0, rel=1e-12)
        assert blk.kinetic_tracked == pytest.approx(k0, rel=1e-12)
    assert np.abs(s.v.sum(axis=0)).max() < 1e-12
    s.rate = 0.05
    blk = s.block(3000)
    assert blk.kinetic_end > 1.01 * k0
    assert blk.kinetic_tracked == pytest.approx(blk.kinetic_end, rel=1e-11)
    assert np.abs(s.v.sum(axis=0)).max() < 1e-12


def test_no_overlap_up_to_jamming(rng):
    """Compressed from a Poisson start to a reduced pressure of 1e12 with the velocities
    rescaled after every block: no pair ever overlaps beyond round-off."""
    n = 250
    dn = sample_diameters(n, "lognormal", 1.0, 0.1, rng)
    side = (np.sum(np.pi / 6 * dn**3) / 0.64) ** (1 / 3)
    x = rng.uniform(0, side, (n, 3))
    s = EDMD(x, thermal_velocities(n, 0.2, rng), dn, side, 0.0, rate=2.0)
    s.r = s.closest_ratio()
    worst = 0.0
    for _ in range(400):
        blk = s.block(20 * n)
        s.rescale(0.2)
        worst = min(worst, s.closest_ratio() / s.r - 1.0)
        if blk.reduced_pressure >= 1e12:
            break
    assert blk.reduced_pressure >= 1e12
    assert worst > -1e-13
    assert 0.55 < s.packing_fraction() < 0.66


def test_pressure_of_a_fluid_is_carnahan_starling(rng):
    """Monodisperse fluid at phi = 0.3 (no growth): Z = 1 + sum |J| sigma / (2 <K> t)
    within 2 % of Carnahan-Starling, (1 + phi + phi^2 - phi^3) / (1 - phi)^3 = 3.97."""
    n = 500
    x, d, box = random_spheres(np.ones(n), 0.3, 9)
    s = EDMD(x, thermal_velocities(n, 0.2, rng), d, box[0], 1.0, rate=0.0)
    s.block(20 * n)  # forget the random insertion
    z = np.mean([s.block(20 * n).reduced_pressure for _ in range(4)])
    phi = 0.3
    assert z == pytest.approx((1 + phi + phi**2 - phi**3) / (1 - phi) ** 3, rel=0.02)
