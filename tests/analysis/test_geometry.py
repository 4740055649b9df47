"""Spherocylinder geometry: the measure below a level against independent quadrature,
brute-force sampling and invariants; spine closest points against brute force."""
import numpy as np
import pytest
from scipy.integrate import quad

from analysis.geometry import inside, measure_below, particle_measure, spine_closest


def axial_slicing_volume(uv, radius, length, h):
    """Independent reference: integrate, along the spine, the area of each perpendicular
    disk slice below the level (scipy quad on many sub-intervals)."""
    a = length / 2
    su = np.sqrt(1 - uv**2)

    def disk_below(rho, d):
        if rho <= 0:
            return 0.0
        d = np.clip(d, -rho, rho)
        return rho**2 * np.arccos(-d / rho) + d * np.sqrt(rho**2 - d**2)

    def f(s):
        rho = radius if abs(s) <= a else np.sqrt(max(radius**2 - (abs(s) - a) ** 2, 0.0))
        return disk_below(rho, (h - s * uv) / su)

    edges = np.linspace(-a - radius, a + radius, 121)
    return sum(quad(f, edges[k], edges[k + 1], epsabs=1e-14, epsrel=1e-12)[0]
               for k in range(len(edges) - 1))


def test_measure_below_matches_axial_slicing(rng):
    for _ in range(25):
        uv = rng.uniform(-0.99, 0.99)
        r, ln = rng.uniform(0.2, 1.0), rng.uniform(0.0, 4.0)
        h = rng.uniform(-(ln / 2 + r), ln / 2 + r)
        ref = axial_slicing_volume(uv, r, ln, h)
        assert measure_below(0.0, uv, r, ln, h, 3) == pytest.approx(ref, abs=1e-9 * particle_measure(r, ln))


@pytest.mark.parametrize("dim", [2, 3])
def test_measure_below_against_brute_force_sampling(rng, dim):
    u = rng.normal(size=3)
    if dim == 2:
        u[2] = 0
    u /= np.linalg.norm(u)
    r, ln = 0.4, 1.7
    ext = ln / 2 + r
    n = 400_000
    p = rng.uniform(-ext, ext, size=(n, 3))
    if dim == 2:
        p[:, 2] = 0
    ins = inside(p, np.zeros(3), u, r, ln)
    v = dim - 1
    for h in (-0.5, 0.1, 0.7):
        frac = np.mean(ins & (p[:, v] < h))
        mc = (2 * ext) ** dim * frac
        sd = (2 * ext) ** dim * np.sqrt(frac * (1 - frac) / n)
        assert abs(measure_below(0.0, u[v], r, ln, h, dim) - mc) < 4 * sd


@pytest.mark.parametrize("dim", [2, 3])
def test_measure_below_invariants(rng, dim):
    r, ln = 0.5, 3.0
    full = particle_measure(r, ln, dim)
    for uv in (1.0, -1.0, 0.0, 1e-9, 0.3, -0.8, 1 - 1e-13):
        assert measure_below(0, uv, r, ln, -10, dim) == pytest.approx(0, abs=1e-12)
        assert measure_below(0, uv, r, ln, 10, dim) == pytest.approx(full, rel=1e-12)
        # point symmetry: half below the centre, and below(h) + below(-h) = V
        assert measure_below(0, uv, r, ln, 0.0, dim) == pytest.approx(full / 2, rel=1e-12)
        h = rng.uniform(-2, 2)
        assert measure_below(0, uv, r, ln, h, dim) + measure_below(0, uv, r, ln, -h, dim) == \
            pytest.approx(full, rel=1e-10)
        # the body does not depend on the sign of u; translation shifts the level
        assert measure_below(0, -uv, r, ln, h, dim) == pytest.approx(
            measure_below(0, uv, r, ln, h, dim), rel=1e-10, abs=1e-13)
        assert measure_below(2.5, uv, r, ln, h + 2.5, dim) == pytest.approx(
            measure_below(0, uv, r, ln, h, dim), rel=1e-10, abs=1e-13)
    # monotone in h
    hs = np.linspace(-3, 3, 301)
    assert np.all(np.diff(measure_below(0, 0.37, r, ln, hs, dim)) >= -1e-13)


def test_sphere_is_a_spherical_cap_and_upright_rod_a_stack():
    r = 0.7
    for h in np.linspace(-0.7, 0.7, 9):
        cap = np.pi * (r + h) ** 2 * (3 * r - (r + h)) / 3
        for uv in (0.2, -0.6, 1.0):
            assert measure_below(0, uv, r, 0.0, h, 3) == pytest.approx(cap, abs=1e-12)
        # a disk in 2-D: circular segment
        seg = r**2 * np.arccos(-h / r) + h * np.sqrt(r**2 - h**2)
        assert measure_below(0, 0.2, r, 0.0, h, 2) == pytest.approx(seg, abs=1e-12)
    # upright rod: lower cap + cylinder part
    ln = 2.0
    h = 0.3
    expect = 2 / 3 * np.pi * r**3 + np.pi * r**2 * (h + ln / 2)
    assert measure_below(0, 1.0, r, ln, h, 3) == pytest.approx(expect, rel=1e-12)
    # lying rod (2-D): rectangle + two half-disks cut at the same height
    seg = r**2 * np.arccos(-h / r) + h * np.sqrt(r**2 - h**2)
    assert measure_below(0, 0.0, r, ln, h, 2) == pytest.approx(seg + ln * (h + r), rel=1e-12)


def test_spine_closest_against_brute_force(rng):
    for _ in range(30):
        xa = rng.normal(size=3)
        xb = xa + rng.normal(size=3)
        ua, ub = (v / np.linalg.norm(v) for v in rng.normal(size=(2, 3)))
        la, lb = rng.uniform(0, 3, 2)
        s, t = spine_closest(xa[None], ua[None], [la], xb[None], ub[None], [lb])
        d = np.linalg.norm(xa + s[0] * ua - xb - t[0] * ub)
        ss = np.linspace(-la / 2, la / 2, 801)
        tt = np.linspace(-lb / 2, lb / 2, 801)
        pa = xa + ss[:, None] * ua
        pb = xb + tt[:, None] * ub
        brute = np.min(np.linalg.norm(pa[:, None] - pb[None], axis=2))
        assert d <= brute + 1e-12
        assert d == pytest.approx(brute, abs=5e-3)


def test_spine_closest_is_the_engines_rule_to_the_bit(rng):
    """The analysis' own closest points (NumPy) against pysim's kernel, over random,
    parallel, antiparallel, point and degenerate pairs: the same ``(s, t)`` bits, so an
    engine's contact and the analysis' reading of it never disagree on where it sits."""
    from pysim.geometry import segment_closest_many

    m = 4000
    xa = rng.normal(size=(m, 3))
    xb = xa + rng.normal(size=(m, 3))
    ua = rng.normal(size=(m, 3))
    ub = rng.normal(size=(m, 3))
    ub[:800] = ua[:800]                      # parallel
    ub[800:1200] = -ua[800:1200]             # antiparallel
    xb[1200:1400] = xa[1200:1400] + 0.3 * ua[1200:1400]  # collinear, overlapping
    ua /= np.linalg.norm(ua, axis=1)[:, None]
    ub /= np.linalg.norm(ub, axis=1)[:, None]
    la, lb = rng.uniform(0, 3, m), rng.uniform(0, 3, m)
    la[1400:1600] = 0.0                      # a sphere against a rod
    lb[1500:1700] = 0.0                      # ... and both points
    s, t = spine_closest(xa, ua, la, xb, ub, lb)
    s_ref, t_ref = segment_closest_many(xa, ua, 0.5 * la, xb, ub, 0.5 * lb)
    assert np.array_equal(s, s_ref) and np.array_equal(t, t_ref)
