"""The contact loop against a slow NumPy reference, and neighbour-list forces against
all-pairs forces, on random dense packings of rods of mixed length (and spheres)."""
import numpy as np
import pytest

from pysim.contacts import REC_COLUMNS, pair_forces
from pysim.forces import HARMONIC, HERTZ, HOOKE, KEEP_SPRING, NO_TENSION, contact_params
from pysim.neighbors import all_pairs, build_pairs
from tests.pysim.helpers import random_rods, reference


def call(x, u, r, half, v, w, box, pi, pj, law, p, friction=False, hist=None, dt=1e-4):
    n = len(x)
    f = np.zeros((n, 3))
    tq = np.zeros((n, 3))
    vir = np.zeros((3, 3))
    hist = np.zeros((len(pi), 3)) if hist is None else hist
    rec_ij = np.empty((len(pi), 2), np.int64)
    rec = np.empty((len(pi), REC_COLUMNS))
    pe, nc = pair_forces(x, v, w, u, r, half, box, np.ones(3, bool), pi, pj, hist, law, p,
                         friction, dt, f, tq, vir, True, rec_ij, rec)
    return f, tq, vir, pe, nc, rec_ij[:nc], rec[:nc]


@pytest.mark.parametrize("dim", [2, 3])
@pytest.mark.parametrize("law", [HOOKE, HERTZ, HARMONIC, HOOKE | NO_TENSION,
                                 HERTZ | NO_TENSION])
def test_kernel_matches_reference(rng, law, dim):
    box = np.array([7.0, 7.0, 7.0 if dim == 3 else 1.0])
    n = 60 if dim == 3 else 40
    x, u, r, half, v, w = random_rods(rng, n, box, 3.0, dim)
    pi, pj = all_pairs(x, r + half, box, np.ones(3, bool), 0.1)
    # without tension: a damping that pulls in many of the opening contacts
    p = contact_params(1e4, 3e3 if law & NO_TENSION else 3.0)
    f, tq, vir, pe, nc, ij, rec = call(x, u, r, half, v, w, box, pi, pj, law, p)
    f_ref, tq_ref, vir_ref, pe_ref, nc_ref, clipped = reference(x, u, r, half, v, w, box, law, p)
    assert nc == nc_ref > 20
    assert clipped > 5 if law & NO_TENSION else clipped == 0
    np.testing.assert_allclose(f, f_ref, rtol=1e-10, atol=1e-8)
    np.testing.assert_allclose(tq, tq_ref, rtol=1e-10, atol=1e-8)
    np.testing.assert_allclose(vir, vir_ref, rtol=1e-10, atol=1e-8)
    assert pe == pytest.approx(pe_ref, rel=1e-10)
    # Newton's third law; the table's forces add up to the particle forces
    np.testing.assert_allclose(f.sum(axis=0), 0.0, atol=1e-8)
    f_tab = np.zeros_like(f)
    np.add.at(f_tab, ij[:, 0], rec[:, 7:10])
    np.add.at(f_tab, ij[:, 1], -rec[:, 7:10])
    np.testing.assert_allclose(f_tab, f, atol=1e-8)
    np.testing.assert_allclose(np.linalg.norm(rec[:, 3:6], axis=1), 1.0)


@pytest.mark.parametrize("friction", [False, True])
def test_neighbour_list_equals_all_pairs_for_mixed_rods(rng, friction):
    box = np.full(3, 10.0)
    x, u, r, half, v, w = random_rods(rng, 250, box, 4.0)
    p = contact_params(1e4, 5.0, k_t=5e3, gamma_t=1.0, mu=0.5 if friction else 0.0)
    per = np.ones(3, bool)
    pi, pj = build_pairs(x, r + half, box, per, 0.3)
    ai, aj = all_pairs(x, r + half, box, per, 100.0)  # every pair
    out_nl = call(x, u, r, half, v, w, box, pi, pj, HOOKE, p, friction)
    out_all = call(x, u, r, half, v, w, box, ai, aj, HOOKE, p, friction)
    assert out_nl[4] == out_all[4] > 100
    for a, b in zip(out_nl[:3], out_all[:3]):
        np.testing.assert_array_equal(a, b)  # same pairs in the same order: bit-identical


def test_contacts_conserve_angular_momentum(rng):
    """Sum of torques plus sum of x cross F vanishes (non-periodic pair sums)."""
    box = np.full(3, 50.0)
    x, u, r, half, v, w = random_rods(rng, 80, np.full(3, 6.0), 3.0)
    x += 20.0
    p = contact_params(1e4, 5.0, k_t=5e3, gamma_t=1.0, mu=0.4)
    pi, pj = all_pairs(x, r + half, box, np.ones(3, bool), 0.1)
    f, tq, *_ = call(x, u, r, half, v, w, box, pi, pj, HOOKE, p, friction=True)
    assert np.abs(f).max() > 1.0
    np.testing.assert_allclose(tq.sum(axis=0) + np.cross(x, f).sum(axis=0), 0.0,
                               atol=1e-9 * np.abs(np.cross(x, f)).sum())


@pytest.mark.parametrize("law", [HOOKE, HOOKE | KEEP_SPRING])
def test_tangential_force_is_capped_and_history_resets(rng, law):
    """A sliding contact carries exactly mu |f_n|; its spring is cut back to the cap, or
    with ``KEEP_SPRING`` holds the whole slip; separated pairs forget their spring."""
    x = np.array([[2.0, 2.0, 2.0], [2.9, 2.0, 2.0]])
    u = np.tile([0.0, 0.0, 1.0], (2, 1))
    r = np.full(2, 0.5)
    half = np.zeros(2)
    v = np.array([[0.0, 5.0, 0.0], [0.0, 0.0, 0.0]])
    w = np.zeros((2, 3))
    box = np.full(3, 10.0)
    pi, pj = np.array([0]), np.array([1])
    p = contact_params(1e4, 0.0, k_t=1e4, gamma_t=0.0, mu=0.3)
    hist = np.zeros((1, 3))
    for _ in range(200):
        f, *_ = call(x, u, r, half, v, w, box, pi, pj, law, p, True, hist, dt=1e-3)
    fn = 1e4 * 0.1
    assert abs(f[0, 1]) == pytest.approx(0.3 * fn, rel=1e-12)
    assert f[0, 1] < 0  # opposes the sliding of particle 0 in +y
    # the spring: the cap's length, or the whole slip 200 * 5 * 1e-3
    slip = 1.0 if law & KEEP_SPRING else 0.3 * fn / 1e4
    np.testing.assert_allclose(hist[0], [0.0, slip, 0.0], rtol=1e-12, atol=1e-15)
    x[1, 0] = 3.5  # separate
    call(x, u, r, half, v, w, box, pi, pj, law, p, True, hist)
    assert np.all(hist == 0.0)


def paper_tangential_law(v_r, dt, k_t, c_t, mu, f_n, keep):
    """Slow transcription of Pournin et al. (2005), section 3.1, for a contact whose normal
    stays put: ``v_r`` (steps, 3) the tangential velocity of the contact point of grain 2
    relative to that of grain 1; ``xi_t`` integrates eq. 6, ``xi_t' = -v_r``, from zero;
    ``f_t = k_t xi_t + c_t xi_t'`` (the force of grain 1 on grain 2), rescaled to
    ``mu |f_n|`` when longer. ``keep``: the paper's law, ``xi_t`` untouched by the
    rescaling; else the spring is cut back to the capped force (Cundall-Strack, pysim's
    default). Returns ``f_t`` per step."""
    xi = np.zeros(3)
    out = []
    for v in v_r:
        rate = -v
        xi = xi + rate * dt
        f = k_t * xi + c_t * rate
        if np.linalg.norm(f) > mu * abs(f_n):
            f = mu * abs(f_n) * f / np.linalg.norm(f)
            if not keep:
                xi = (f - c_t * rate) / k_t
        out.append(f)
    return np.array(out)


def _tangential_setup(geometry, model):
    """A contact of overlap 0.1 whose normal cannot turn (positions are never moved):
    returns the simulation, the moving grain (the paper's grain 2; grain 1 is the other
    grain or the wall) and the unit normal from grain 1 to grain 2."""
    from pysim import State
    from pysim.simulation import Simulation
    from pysim.walls import cylinder, plane

    box = np.full(3, 10.0)
    closed = (False, False, False)
    if geometry == "spheres":  # sphere_pass
        st = State.spheres(np.array([[5.0, 5.0, 5.0], [5.9, 5.0, 5.0]]), 0.5, box, periodic=closed)
        return Simulation(st, model, dt=1e-3), 1, np.array([1.0, 0, 0])
    if geometry == "rods":  # rod_pass: crossed rods, rod 1 on top of rod 0
        st = State.create(np.array([[5.0, 5.0, 5.0], [5.0, 5.0, 5.9]]), 0.5, 4.0, box,
                          axis=np.array([[0.0, 1.0, 0.0], [1.0, 0.0, 0.0]]), periodic=closed)
        return Simulation(st, model, dt=1e-3), 1, np.array([0, 0, 1.0])
    if geometry == "plane":  # an upright rod's lower end on the base
        st = State.create(np.array([[5.0, 5.0, 1.4]]), 0.5, 2.0, box,
                          axis=np.array([[0.0, 0.0, 1.0]]), periodic=closed)
        return (Simulation(st, model, dt=1e-3, planes=[plane((0, 0, 1), (0, 0, 0))]), 0,
                np.array([0, 0, 1.0]))
    # a sphere against the inside of the cylinder wall
    st = State.spheres(np.array([[7.6, 5.0, 5.0]]), 0.5, box, periodic=closed)
    return (Simulation(st, model, dt=1e-3, cylinders=[cylinder(5.0, 5.0, 3.0)]), 0,
            np.array([-1.0, 0, 0]))


@pytest.mark.parametrize("geometry", ["spheres", "rods", "plane", "cylinder"])
@pytest.mark.parametrize("spring", ["reset", "keep"])
def test_tangential_spring_past_the_coulomb_cap_against_the_paper_law(geometry, spring):
    """Grain 2 slides on grain 1 (or a wall) past the Coulomb cap, stops, slides back,
    sideways, and sticks again, at prescribed velocities; the kernels' tangential force
    follows the reference law step by step, grain-grain (sphere and rod passes) and
    grain-wall (plane and cylinder). With ``keep`` the force stays at the cap while
    sliding back until the excess slip is undone; with ``reset`` it leaves the cap at once."""
    from pysim.simulation import ContactModel

    k_n, k_t, c_t, mu = 1e4, 5e3, 2.0, 0.3
    model = ContactModel("hooke", k_n, 0.0, k_t=k_t, gamma_t=c_t, mu=mu, tangential_spring=spring)
    sim, g, n = _tangential_setup(geometry, model)
    t1 = np.cross(n, [0.3, 0.5, 0.8])
    t1 /= np.linalg.norm(t1)
    t2 = np.cross(n, t1)
    # slide 0.1 (past the cap's 0.06), rest, slide back 0.15, sideways 0.03, rest, stick
    phases = [(t1, 100), (0 * t1, 20), (-t1, 150), (t2, 30), (0 * t1, 20), (0.2 * t1, 30)]
    v_r = np.concatenate([np.tile(d, (k, 1)) for d, k in phases])
    f_t = []
    for v in v_r:
        sim.state.v[g] = v
        sim.compute_forces()
        f = sim.f[g]
        f_t.append(f - (f @ n) * n)
        assert f @ n == pytest.approx(k_n * 0.1, rel=1e-12)  # the normal force on grain 2
    f_t = np.array(f_t)
    ref = paper_tangential_law(v_r, 1e-3, k_t, c_t, mu, k_n * 0.1, spring == "keep")
    np.testing.assert_allclose(f_t, ref, rtol=1e-12, atol=1e-9)
    other = paper_tangential_law(v_r, 1e-3, k_t, c_t, mu, k_n * 0.1, spring != "keep")
    cap = mu * k_n * 0.1
    back = slice(130, 155)  # sliding back: the kept spring holds the force at the cap
    held = np.linalg.norm(ref if spring == "keep" else other, axis=1)[back]
    left = np.linalg.norm(other if spring == "keep" else ref, axis=1)[back]
    np.testing.assert_allclose(held, cap, rtol=1e-12)
    assert np.all(left < cap - 50.0)
    assert np.abs(f_t - other).max() > 0.5 * cap  # the two laws differ where they should
