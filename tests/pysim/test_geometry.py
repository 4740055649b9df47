"""Spine-spine closest points against brute force and invariants."""
import numpy as np
import pytest

from pysim.geometry import (segment_closest, segment_closest_many, segment_distance,
                            segment_distance_bruteforce)


def random_unit(rng):
    v = rng.normal(size=3)
    return v / np.linalg.norm(v)


def random_pair(rng):
    ca = rng.uniform(-1, 1, 3)
    cb = rng.uniform(-1, 1, 3)
    return ca, random_unit(rng), rng.uniform(0, 1.5), cb, random_unit(rng), rng.uniform(0, 1.5)


def rotation(rng):
    q, _ = np.linalg.qr(rng.normal(size=(3, 3)))
    return q * np.sign(np.linalg.det(q))


def test_distance_equals_bruteforce(rng):
    for _ in range(200):
        ca, ua, ha, cb, ub, hb = random_pair(rng)
        d = segment_distance(ca, ua, ha, cb, ub, hb)
        ref = segment_distance_bruteforce(ca, ua, ha, cb, ub, hb, samples=801)
        # the grid overestimates by at most half a grid step times the slope (<= 1)
        step = 3.0 / 800
        assert ref - step <= d <= ref + 1e-12


def test_closest_points_are_inside_and_optimal(rng):
    for _ in range(300):
        ca, ua, ha, cb, ub, hb = random_pair(rng)
        s, t = segment_closest(ca, ua, ha, cb, ub, hb)
        assert -ha <= s <= ha and -hb <= t <= hb
        d0 = np.linalg.norm(ca + s * ua - cb - t * ub)
        # no small move inside the box improves on it
        for ds, dt in [(1e-4, 0), (-1e-4, 0), (0, 1e-4), (0, -1e-4)]:
            s2 = np.clip(s + ds, -ha, ha)
            t2 = np.clip(t + dt, -hb, hb)
            assert np.linalg.norm(ca + s2 * ua - cb - t2 * ub) >= d0 - 1e-12


def test_symmetric_under_swap(rng):
    for _ in range(200):
        ca, ua, ha, cb, ub, hb = random_pair(rng)
        s, t = segment_closest(ca, ua, ha, cb, ub, hb)
        t2, s2 = segment_closest(cb, ub, hb, ca, ua, ha)
        assert segment_distance(ca, ua, ha, cb, ub, hb) == pytest.approx(
            segment_distance(cb, ub, hb, ca, ua, ha), abs=1e-12)
        np.testing.assert_allclose(ca + s * ua, ca + s2 * ua, atol=1e-9)
        np.testing.assert_allclose(cb + t * ub, cb + t2 * ub, atol=1e-9)


def test_invariant_under_rigid_motion_and_axis_flip(rng):
    for _ in range(200):
        ca, ua, ha, cb, ub, hb = random_pair(rng)
        d = segment_distance(ca, ua, ha, cb, ub, hb)
        rot = rotation(rng)
        shift = rng.uniform(-5, 5, 3)
        d2 = segment_distance(rot @ ca + shift, rot @ ua, ha, rot @ cb + shift, rot @ ub, hb)
        assert d2 == pytest.approx(d, abs=1e-12)
        assert segment_distance(ca, -ua, ha, cb, ub, hb) == pytest.approx(d, abs=1e-12)


def test_point_segment_and_point_point(rng):
    for _ in range(100):
        ca, ua, ha, cb, ub, hb = random_pair(rng)
        # a point (h = 0) against a segment: distance to the clamped projection
        t = np.clip(np.dot(ca - cb, ub), -hb, hb)
        assert segment_distance(ca, ua, 0.0, cb, ub, hb) == pytest.approx(
            np.linalg.norm(ca - cb - t * ub), abs=1e-12)
        assert segment_distance(ca, ua, 0.0, cb, ub, 0.0) == pytest.approx(
            np.linalg.norm(ca - cb), abs=1e-14)
        # shrinking a segment continuously approaches the point result
        assert segment_distance(ca, ua, 1e-9, cb, ub, hb) == pytest.approx(
            segment_distance(ca, ua, 0.0, cb, ub, hb), abs=1e-8)


def test_parallel_spines_contact_at_the_middle_of_the_overlap():
    ua = np.array([1.0, 0, 0])
    ca = np.zeros(3)
    cb = np.array([1.0, 0.8, 0.0])  # offset by one along the axis, 0.8 aside
    for ub in (ua, -ua):
        s, t = segment_closest(ca, ua, 1.0, cb, ub, 1.0)
        # projections [-1, 1] and [0, 2] overlap on [0, 1]: middle at x = 0.5
        assert s == pytest.approx(0.5)
        np.testing.assert_allclose(cb + t * ub, [0.5, 0.8, 0.0], atol=1e-12)
    # disjoint projections: nearest ends
    s, t = segment_closest(ca, ua, 1.0, np.array([3.0, 0.5, 0]), ua, 1.0)
    assert (s, t) == (1.0, -1.0)


def test_many_matches_single(rng):
    pairs = [random_pair(rng) for _ in range(50)]
    arrs = [np.array([p[k] for p in pairs]) for k in range(6)]
    s, t = segment_closest_many(*arrs)
    for k, p in enumerate(pairs):
        assert (s[k], t[k]) == segment_closest(*p)


def test_closest_select_equals_closest_params_bit_for_bit(rng):
    """The branch-free closest points (rod_pass's SIMD loop) are the branching search's,
    bit for bit, on every path: points, a point and a segment, parallel and antiparallel
    spines (overlapping projections or not), nearly parallel ones, the interior minimum
    and both clamped solutions."""
    from pysim.geometry import PARALLEL_TOL, closest_params, closest_select

    cases = []
    for _ in range(4000):
        r = rng.normal(0, 1.5, 3)
        ua = rng.normal(size=3)
        ua /= np.linalg.norm(ua)
        ub = rng.normal(size=3)
        ub /= np.linalg.norm(ub)
        kind = rng.integers(6)
        if kind == 1:
            ub = ua.copy()
        elif kind == 2:
            ub = -ua
        elif kind == 3:
            ub = ua + rng.normal(0, 1e-6, 3)
            ub /= np.linalg.norm(ub)
        ha, hb = rng.uniform(0, 2, 2)
        if kind == 4:
            ha = 0.0
        elif kind == 5:
            hb = 0.0 if rng.random() < 0.5 else hb
            ha = 0.0 if hb != 0.0 and rng.random() < 0.5 else ha
        cases.append((*r, *ua, ha, *ub, hb))
    cases.append((0.1, 0.2, 0.3, 0, 0, 1, 0.0, 0, 0, 1, 0.0))  # two points
    paths = set()
    for c in cases:
        a = closest_params(*c)
        b = closest_select(*c)
        assert np.array_equal(np.array(a), np.array(b)) and np.signbit(a).tolist() == \
            np.signbit(b).tolist(), c
        ub = np.array(c[7:10])
        paths.add(("parallel" if 1 - np.dot(c[3:6], ub) ** 2 < PARALLEL_TOL else "general",
                   c[6] == 0.0, c[10] == 0.0))
    assert len(paths) >= 5
