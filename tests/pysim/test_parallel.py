"""The threaded kernels: the same bits on 1 and 2 threads, the same forces as the serial
loop and the NumPy reference, a complete rod-aware Verlet list, and a short trajectory
against a NumPy velocity-Verlet reference."""
import numba
import numpy as np
import pytest

from pysim import State
from pysim.contacts import FJ_COLUMNS, pair_forces, pair_pass, reduce_pass
from pysim.forces import HOOKE, contact_params
from pysim.geometry import segment_distance
from pysim.initial import random_spheres, random_spherocylinders
from pysim.jit import get_threads, set_threads
from pysim.neighbors import all_pairs, build_list, list_is_stale
from pysim.simulation import ContactModel, Simulation
from tests.pysim.helpers import random_rods, reference

PER = np.ones(3, bool)


def threaded(x, u, r, half, v, w, box, p, friction, hist=None, skin=0.3):
    n = len(x)
    pi, pj, istart, jstart, jk = build_list(x, u, r + half, half, box, PER, skin)
    hist = np.zeros((len(pi), 3)) if hist is None else hist
    f = np.empty((n, 3))
    tq = np.empty((n, 3))
    vir = np.zeros((3, 3))
    fj = np.empty((FJ_COLUMNS, len(pi)))
    pe, nc = pair_pass(x, v, w, u, r, half, box, PER, pj, istart, jstart, jk, hist, HOOKE, p,
                       friction, 1e-4, bool(np.any(half > 0)), f, tq, fj, True, vir)
    reduce_pass(f, tq, jstart, fj, v, w, np.ones(n), 0.0, 0.0, 0.0, 0.0, 0.0, False)
    return f, tq, vir, pe, nc, (pi, pj, hist)


@pytest.mark.slow
@pytest.mark.parametrize("friction", [False, True])
def test_threaded_pass_equals_serial_loop_and_reference(rng, friction):
    box = np.full(3, 9.0)
    x, u, r, half, v, w = random_rods(rng, 220, box, 3.0)
    p = contact_params(1e4, 5.0, k_t=5e3, gamma_t=1.0, mu=0.5 if friction else 0.0)
    f, tq, vir, pe, nc, (pi, pj, hist) = threaded(x, u, r, half, v, w, box, p, friction)
    ai, aj = all_pairs(x, r + half, box, PER, 100.0)
    f2, tq2, vir2 = np.zeros((len(x), 3)), np.zeros((len(x), 3)), np.zeros((3, 3))
    hist2 = np.zeros((len(ai), 3))
    pe2, nc2 = pair_forces(x, v, w, u, r, half, box, PER, ai, aj, hist2, HOOKE, p, friction,
                           1e-4, f2, tq2, vir2, False, np.empty((0, 2), np.int64),
                           np.empty((0, 10)))
    assert nc == nc2 > 100
    for a, b in ((f, f2), (tq, tq2), (vir, vir2)):
        np.testing.assert_allclose(a, b, rtol=1e-12, atol=1e-9)
    assert pe == pytest.approx(pe2, rel=1e-12)
    if friction:  # the springs of the touching pairs are the same
        touching = {(a, b): h for a, b, h in zip(ai, aj, hist2) if np.any(h)}
        listed = {(a, b): h for a, b, h in zip(pi, pj, hist) if np.any(h)}
        assert touching.keys() == listed.keys()
        for key in touching:
            np.testing.assert_array_equal(touching[key], listed[key])
    else:
        f_ref, tq_ref, vir_ref, pe_ref, nc_ref, _ = reference(x, u, r, half, v, w, box, HOOKE, p)
        assert nc == nc_ref
        np.testing.assert_allclose(f, f_ref, rtol=1e-10, atol=1e-8)
        np.testing.assert_allclose(tq, tq_ref, rtol=1e-10, atol=1e-8)


@pytest.mark.slow
def test_rod_list_holds_every_pair_within_reach(rng):
    """build_list against brute-force spine distances, with and without a skin."""
    box = np.full(3, 8.0)
    x, u, r, half, *_ = random_rods(rng, 150, box, 4.0)
    for skin in (0.0, 0.4):
        pi, pj, istart, jstart, jk = build_list(x, u, r + half, half, box, PER, skin)
        want = set()
        for i in range(len(x)):
            for j in range(i + 1, len(x)):
                d = x[j] - x[i]
                d -= box * np.round(d / box)
                if segment_distance(np.zeros(3), u[i], half[i], d, u[j], half[j]) < r[i] + r[j] + skin:
                    want.add((i, j))
        got = list(zip(pi.tolist(), pj.tolist()))
        assert set(got) == want and got == sorted(got) and len(want) > 50
        np.testing.assert_array_equal(np.diff(istart), np.bincount(pi, minlength=len(x)))
        assert all(pj[jk[jstart[q]:jstart[q + 1]]].tolist() == [q] * (jstart[q + 1] - jstart[q])
                   for q in range(len(x)))


def brute_force_list(x, u, r, half, box, periodic, skin):
    """Pairs ``i < j`` whose spines are closer than ``r_i + r_j + skin``, one by one."""
    want = []
    for i in range(len(x)):
        for j in range(i + 1, len(x)):
            d = x[j] - x[i]
            for k in range(3):
                if periodic[k]:
                    d[k] -= box[k] * np.round(d[k] / box[k])
            if segment_distance(np.zeros(3), u[i], half[i], d, u[j], half[j]) < r[i] + r[j] + skin:
                want.append((i, j))
    return want


@pytest.mark.parametrize("side, periodic, dim", [
    (14.0, (True, True, True), 3),  # 5 cells of half the range: a stencil on every axis
    (11.0, (True, True, True), 3),  # 4 cells: every cell once on every axis
    (14.0, (False, False, False), 3),
    (14.0, (True, False, True), 3),
    (17.0, (True, True, False), 2),
])
def test_rod_list_in_boxes_of_every_kind(rng, side, periodic, dim):
    """build_list against brute force with rods and spheres, periodic and walled axes
    (with particles outside the walls), 3-D and 2-D."""
    box = np.array([side, side, side if dim == 3 else 0.0])
    per = np.array(periodic)
    x, u, r, half, *_ = random_rods(rng, 260 if dim == 3 else 120, np.where(box > 0, box, 1.0),
                                    4.0, dim)
    walled = ~per & (box > 0)
    x[:10, walled] += 0.6 * side  # above the upper walls
    x[10:20, walled] -= 0.6 * side  # below the lower ones
    pi, pj, istart, jstart, jk = build_list(x, u, r + half, half, box, per, 0.3)
    want = brute_force_list(x, u, r, half, box, per, 0.3)
    got = list(zip(pi.tolist(), pj.tolist()))
    assert got == want and len(want) > 100
    np.testing.assert_array_equal(np.diff(istart), np.bincount(pi, minlength=len(x)))


def test_sphere_list_with_long_rows(rng):
    """Rows longer than the build's room per particle (a large skin): the build's second
    pass writes them, and the list is the brute-force one."""
    from pysim.neighbors import ROW_ROOM

    box = np.full(3, 9.0)
    n = 300
    x = rng.uniform(0, 9.0, (n, 3))
    r = rng.uniform(0.3, 0.6, n)
    r[0] = 2.5  # one large sphere
    pi, pj, istart, *_ = build_list(x, np.zeros((n, 3)), r, np.zeros(n), box, PER, 2.5)
    ai, aj = all_pairs(x, r, box, PER, 2.5)
    assert list(zip(pi.tolist(), pj.tolist())) == list(zip(ai.tolist(), aj.tolist()))
    assert len(pi) > ROW_ROOM * n  # the room per particle was too small


@pytest.mark.slow
def test_list_is_stale_never_misses_a_rod_contact(rng):
    """Rods translating, rotating and compressed: whenever the list is said to be good,
    every pair in contact range is in it."""
    n = 120
    x, u, r, length, box = random_spherocylinders(np.full(n, 0.5), np.full(n, 3.0), 0.2, 4)
    half = length / 2
    r_int = r + half
    skin = 0.3
    pi, pj, *_ = build_list(x, u, r_int, half, box, PER, skin)
    x_ref, u_ref, box_ref = x.copy(), u.copy(), box.copy()
    checked = 0
    for _ in range(300):
        box = box * np.exp(-0.001)
        x = x * np.exp(-0.001) + rng.normal(0, 0.003, x.shape)
        u = u + rng.normal(0, 0.004, u.shape)
        u /= np.linalg.norm(u, axis=1, keepdims=True)
        x %= box
        if list_is_stale(x, x_ref, u, u_ref, half, box, box_ref, PER, 2 * r.max(), half.max(),
                         skin, 1.0):
            pi, pj, *_ = build_list(x, u, r_int, half, box, PER, skin)
            x_ref, u_ref, box_ref = x.copy(), u.copy(), box.copy()
            continue
        ti, tj, *_ = build_list(x, u, r_int, half, box, PER, 0.0)
        assert set(zip(ti.tolist(), tj.tolist())) <= set(zip(pi.tolist(), pj.tolist()))
        checked += 1
    assert checked > 100


@pytest.mark.parametrize("growth", [1.0, 1.002])
def test_each_rods_share_of_the_motion_bound_holds_for_every_pair(rng, growth):
    """Rods (spheres among them) translating, rotating, the box contracting along one
    axis and growing along another, the particles growing: every listed pair's spine
    distance stays at least ``sigma g_ref - dl_i - dl_j``, the largest shares make the
    global shrink, and the shares are much tighter for most pairs."""
    from pysim.geometry import segment_distance
    from pysim.neighbors import motion_bound

    def spine_distance(xi, ui, hi, xj, uj, hj, box):
        d = xj - xi
        d -= box * np.round(d / box)  # minimum image
        return segment_distance(xi, ui, hi, xi + d, uj, hj)

    n = 150
    alpha = rng.uniform(0, 3, n)
    alpha[:20] = 0.0
    x, u, r, length, box = random_spherocylinders(np.full(n, 0.5), alpha, 0.25, 6)
    half0 = length / 2
    pi, pj, *_ = build_list(x, u, r + half0, half0, box, PER, 0.5)
    x_ref, u_ref, box_ref = x.copy(), u.copy(), box.copy()
    g_ref = np.array([spine_distance(x[i], u[i], half0[i], x[j], u[j], half0[j], box)
                      for i, j in zip(pi, pj)])
    a = np.array([np.exp(-0.004), np.exp(0.003), 1.0])
    tighter = 0
    for step in range(1, 31):
        box = box_ref * a ** step
        x = (x_ref * a ** step + rng.normal(0, 0.004 * step, x.shape)) % box
        u = u_ref + rng.normal(0, 0.003 * step, u.shape)
        u /= np.linalg.norm(u, axis=1, keepdims=True)
        g = growth ** step
        half = half0 * g
        dl = np.full(n, np.nan)
        sigma, shrink = motion_bound(x, x_ref, u, u_ref, half, box, box_ref, PER,
                                     half0.max(), g, dl)
        # the bound is on the distance with the build's half-lengths scaled by g
        now = np.array([spine_distance(x[i], u[i], half[i], x[j], u[j], half[j], box)
                        for i, j in zip(pi, pj)])
        assert np.all(now >= sigma * g_ref - dl[pi] - dl[pj] - 1e-12)
        assert 2 * dl.max() == pytest.approx(shrink, rel=1e-12)
        tighter += np.mean(dl[pi] + dl[pj] < 0.8 * shrink)
    assert tighter / 30 > 0.5


@pytest.mark.slow
def test_a_rod_brought_into_contact_by_its_own_motion_is_not_skipped():
    """Two parallel rods 0.1 D apart at the build; the second moves 0.11 D towards the
    first. The pair's own shares (0 and 0.11) keep it, and the rods' pass gives the
    contact force that the pass without shares gives (a share counted at half would
    skip the pair, and the force would be zero)."""
    from pysim.contacts import PAIR_SCRATCH, SEP, rod_pass
    from pysim.neighbors import motion_bound, spine_separations

    box = np.full(3, 10.0)
    x = np.array([[5.0, 5.0, 5.0], [5.0, 6.1, 5.0]])
    u = np.array([[1.0, 0.0, 0.0], [1.0, 0.0, 0.0]])
    r = np.full(2, 0.5)
    half = np.ones(2)
    pi, pj, istart, jstart, jk = build_list(x, u, r + half, half, box, PER, 0.4)
    assert len(pi) == 1
    fj = np.zeros((PAIR_SCRATCH, 1))
    spine_separations(x, u, half, box, PER, pi, pj, fj[SEP])
    x_ref, u_ref = x.copy(), u.copy()
    x[1, 1] -= 0.11
    dl = np.empty(2)
    sigma, shrink = motion_bound(x, x_ref, u, u_ref, half, box, box, PER, 1.0, 1.0, dl)
    assert dl == pytest.approx([0.0, 0.11]) and shrink == pytest.approx(0.22)
    p = contact_params(1e4, 5.0)
    out = []
    for shares in (None, dl):
        f, tq, vir = np.empty((2, 3)), np.empty((2, 3)), np.zeros((3, 3))
        rod_pass(x, np.zeros((2, 3)), np.zeros((2, 3)), u, r, half, box, PER, pi, pj, istart,
                 jstart, jk, np.zeros((1, 0)), HOOKE, p, False, 1e-4, f, tq, fj.copy(), False,
                 vir, sigma, shrink, 1, None, shares)
        out.append(f)
    assert out[0][0, 1] == pytest.approx(-1e4 * 0.01)
    np.testing.assert_array_equal(out[0], out[1])


def dense_rods_with_friction(alpha_max=3.0):
    """300 rods of ``L/D`` uniform in ``[0, alpha_max]`` (spheres with 0) with friction."""
    rng = np.random.default_rng(5)
    n = 300
    x, u, r, length, box = random_spherocylinders(np.full(n, 0.5),
                                                  rng.uniform(0, alpha_max, n), 0.3, 8)
    v = rng.normal(0, 1.0, (n, 3))
    w = rng.normal(0, 1.0, (n, 3))
    st = State.create(x, r, length, box, axis=u, v=v, omega=w)
    model = ContactModel("hooke", 1e5, 30.0, k_t=3e4, gamma_t=5.0, mu=0.4, gamma_bg=0.5)
    return Simulation(st, model, dt=5e-5)


def on_one_and_two_threads(alpha_max, protocol):
    """The same dense rods, ``protocol(sim)`` run on one thread and then on two."""
    before = get_threads()
    out = []
    try:
        for threads in (1, 2):
            set_threads(threads)
            sim = dense_rods_with_friction(alpha_max)
            protocol(sim)
            out.append(sim)
    finally:
        set_threads(before)
    return out


def assert_same_rods(a, b, arrays):
    """In contact, with friction, and the same bits in the state and in ``arrays``."""
    assert a.thermo().n_contacts > 50 and np.abs(a.hist).max() > 0
    for k in ("x", "v", "q", "omega"):
        np.testing.assert_array_equal(getattr(a.state, k), getattr(b.state, k), err_msg=k)
    for k in arrays:
        np.testing.assert_array_equal(getattr(a, k), getattr(b, k), err_msg=k)


@pytest.mark.slow
@pytest.mark.skipif(numba.config.NUMBA_NUM_THREADS < 2, reason="needs 2 Numba threads")
@pytest.mark.parametrize("alpha_max", [3.0, 0.0])
def test_one_and_two_threads_give_identical_bits(alpha_max):
    """One thread adds the reactions inside the contact pass (rows in order), two store
    them per pair and gather them: the same sums in the same order, the same bits, for
    rods and for spheres."""
    def compress(sim):
        sim.run(1500, strain_rate=-3.0)

    a, b = on_one_and_two_threads(alpha_max, compress)
    assert_same_rods(a, b, ("f", "torque", "virial", "hist", "pi", "pj"))
    assert a._pe == b._pe


@pytest.mark.slow
@pytest.mark.skipif(numba.config.NUMBA_NUM_THREADS < 2, reason="needs 2 Numba threads")
@pytest.mark.parametrize("alpha_max", [3.0, 0.0])
def test_a_run_after_fire_rebuilt_the_list_gives_the_bits_of_one_thread(alpha_max):
    """FIRE runs on the run's cache: a list it builds is the run's list from then on, and
    the threads' shared-particle flags kept for the old one are found again (with FIRE on
    a copy of the cache, the next run kept the old list's flags: on two threads some
    reactions were added twice or lost)."""
    def compress_fire_compress(sim):
        sim.run(1500, strain_rate=-3.0)
        pj = sim.pj
        sim.minimize(1e-9, max_iter=2000)
        assert sim.pj is not pj  # FIRE rebuilt the list
        sim.run(300, strain_rate=-3.0)

    a, b = on_one_and_two_threads(alpha_max, compress_fire_compress)
    assert_same_rods(a, b, ("f", "torque", "virial", "hist"))


@pytest.mark.parametrize("alpha_max", [3.0, 0.0])
def test_kept_shared_flags_are_found_again_for_a_new_list_or_new_parts(alpha_max):
    """``forces`` keeps the flags of the threads' shared particles from call to call:
    after a list build (the particles in another order) and after a change of the
    number of parts it finds them again, and the forces are those found with new flags
    at every call. Kept flags of the old list would let an earlier part add reactions
    to particles that a later part zeroes, and lose them."""
    import pysim.integrators as itg

    sim = dense_rods_with_friction(alpha_max)
    sim.run(1500, strain_rate=-3.0)  # into contact
    assert sim.thermo().n_contacts > 50
    s = sim.state
    own = np.zeros(s.n, np.bool_)

    def forces(own_flags):
        f, tq = np.empty_like(sim.f), np.empty_like(sim.torque)
        walls = (sim.planes, sim.cyls, sim._wp, sim.whist.copy(), sim.wall_force)
        itg.forces(s.x, s.v, s.omega, s.u, s.radius, sim.half, s.mass, s.box, s.periodic,
                   sim._pairs(), sim.model.law_id, sim._cp, sim.model.friction, walls,
                   sim._wfriction, sim.params, sim.cache, 0.0, sim.dt, f, tq, np.zeros((3, 3)),
                   False, None, own_flags)
        return f, tq

    hist = sim.hist.copy()
    for parts, reorder in ((3, False), (3, True), (2, False), (3, False)):
        if reorder:  # the same particles in reverse order: another list, other flags
            for k in ("x", "v", "omega", "u", "q", "radius", "length", "mass", "inertia"):
                setattr(s, k, np.ascontiguousarray(getattr(s, k)[::-1]))
            sim.half = np.ascontiguousarray(sim.half[::-1])
            sim.r_int = np.ascontiguousarray(sim.r_int[::-1])
            sim.pi, sim.pj = np.zeros(0, np.int32), np.zeros(0, np.int32)
            sim.hist = np.zeros((0, 3))
            sim._index_pairs()
            sim._rebuild()
            hist = sim.hist.copy()
        sim.params["parts"] = parts
        for kept in (False, True, True):
            sim.hist[:] = hist
            got = forces(own)
            assert sim.cache["own_parts"][0] == parts
            sim.hist[:] = hist
            want = forces(None)
            for a, b in zip(got, want):
                np.testing.assert_array_equal(a, b)
            assert np.isfinite(got[0]).all() and np.abs(got[0]).max() > 0


@pytest.mark.parametrize("dimension", [3, 2])
def test_steps_in_one_call_equal_steps_one_by_one(dimension):
    """Inside a call, each step's second half-kick (with the box remap and the growth)
    runs in one pass with the next step's first half: the same bits as the separate
    passes that a call of one step runs, for rods and spheres, compressed and growing."""
    out = []
    for calls in (1, 120):
        if dimension == 3:
            sim = dense_rods_with_friction(3.0)
        else:
            rng = np.random.default_rng(3)
            n = 120
            x, u, r, length, box = random_spherocylinders(
                rng.choice([0.5, 0.7], n), rng.uniform(0, 2.0, n), 0.4, 2, dimension=2)
            box[2] = 1.0
            v = np.column_stack([rng.normal(0, 1.0, (n, 2)), np.zeros(n)])
            st = State.create(x, r, length, box, axis=u, v=v, dimension=2,
                              periodic=(True, True, False))
            sim = Simulation(st, ContactModel("hooke", 1e5, 30.0, k_t=3e4, gamma_t=5.0,
                                              mu=0.4), dt=5e-5)
        growth = 0.5 if dimension == 3 else 20.0  # the sparser 2-D start grows into contact
        for _ in range(calls):
            sim.run(120 // calls, strain_rate=-2.0, growth_rate=growth)
        out.append(sim)
    a, b = out
    assert a.thermo().n_contacts > 20
    for k in ("x", "v", "q", "u", "omega", "radius", "mass", "inertia", "box"):
        np.testing.assert_array_equal(getattr(a.state, k), getattr(b.state, k), err_msg=k)
    np.testing.assert_array_equal(a.f, b.f)


@pytest.mark.slow
def test_short_trajectory_against_numpy_velocity_verlet():
    """Frictionless spheres: 200 steps of pysim against velocity Verlet written in
    NumPy with the reference forces of test_contacts (all pairs, no Verlet list)."""
    x, d, box = random_spheres(np.ones(80), 0.35, seed=6)
    rng = np.random.default_rng(2)
    v = rng.normal(0, 5.0, x.shape)
    st = State.spheres(x, d / 2, box, v=v)
    model = ContactModel("hooke", 1e5, 20.0)
    dt = 2e-5
    sim = Simulation(st, model, dt=dt)
    n = len(x)
    xr, vr, r = st.x.copy(), st.v.copy(), st.radius.copy()
    m = st.mass
    zeros = np.zeros((n, 3))
    u = np.tile([0.0, 0.0, 1.0], (n, 1))
    p = contact_params(1e5, 20.0)

    def force(xx, vv):
        out = reference(xx, u, r, np.zeros(n), vv, zeros, box, HOOKE, p)
        return out[0], out[4]

    f, touching = force(xr, vr)
    for _ in range(200):
        vr += 0.5 * dt * f / m[:, None]
        xr = (xr + dt * vr) % box
        f, nc = force(xr, vr)
        touching += nc
        vr += 0.5 * dt * f / m[:, None]
    sim.run(200)
    assert touching > 100
    np.testing.assert_allclose(st.x, xr, rtol=0, atol=1e-11)
    np.testing.assert_allclose(st.v, vr, rtol=1e-9, atol=1e-9)


def chunk_test_law(law, friction):
    """``(law id, parameters)`` of the chunked passes' tests: the linear law, the linear law
    without tension and a damping that clips many contacts, or Hertz with cohesion (pairs
    in a cohesive gap), with or without friction."""
    from pysim.forces import HERTZ, NO_TENSION

    mu = 0.5 if friction else 0.0
    if law == "hooke":
        return HOOKE, contact_params(1e4, 5.0, k_t=5e3, gamma_t=1.0, mu=mu)
    if law == "hooke_no_tension":
        return HOOKE | NO_TENSION, contact_params(1e4, 3e3, k_t=5e3, gamma_t=1.0, mu=mu)
    return HERTZ, contact_params(1e5, 5.0, k_t=5e3, gamma_t=1.0, mu=mu, f_coh=3.0, d_coh=0.05)


@pytest.mark.parametrize("parts", [1, 3])
@pytest.mark.parametrize("law", ["hooke", "hooke_no_tension", "hertz_cohesive"])
@pytest.mark.parametrize("friction", [False, True])
def test_sphere_pass_equals_the_general_pass(rng, friction, law, parts):
    """The spheres-only loop (gather, SIMD laws, scatter, in chunks of listed pairs, the
    rows in one or three parts) gives the general loop's forces, torques, springs, energy
    and virial, for the linear law and for Hertz with cohesion (pairs in a cohesive gap);
    rows and blocks span several chunks. Both report the largest overlap and its pair
    as :func:`worst_overlap` finds them."""
    from pysim.contacts import BLOCK, CAP, clear_slots, pair_pass, sphere_pass, worst_overlap
    from pysim.neighbors import build_list

    n = 300
    box = np.full(3, 7.0)
    x = rng.uniform(0, 7.0, (n, 3))
    r = rng.uniform(0.35, 0.55, n)
    v = rng.normal(0, 1, (n, 3))
    w = rng.normal(0, 1, (n, 3))
    u = np.tile([0.0, 0.0, 1.0], (n, 1))
    half = np.zeros(n)
    per = np.ones(3, bool)
    pi, pj, istart, jstart, jk = build_list(x, u, r, half, box, per, 0.3)
    assert istart[BLOCK] > CAP  # the first block runs in more than one chunk
    law_id, p = chunk_test_law(law, friction)
    out = []
    for kernel in ("general", "spheres"):
        hist = np.tile([1e-4, -2e-4, 3e-4], (len(pj), 1)) if friction else np.zeros((len(pj), 0))
        f = np.zeros((n, 3))
        tq = np.zeros((n, 3))
        fj = np.full((6, len(pj)), np.nan)  # the general pass writes every slot
        vir = np.zeros((3, 3))
        worst = np.full(2, np.nan)
        if kernel == "general":
            pe, nc = pair_pass(x, v, w, u, r, half, box, per, pj, istart, jstart, jk, hist,
                               law_id, p, friction, 1e-4, False, f, tq, fj, True, vir, 0.0, 0.0,
                               True, worst)
        else:
            clear_slots(istart, jstart, jk, fj, parts, True)
            pe, nc = sphere_pass(x, v, w, r, box, per, pi, pj, istart, jstart, jk, hist,
                                 law_id, p, friction, 1e-4, f, tq, fj, True, vir, parts, worst)
            assert np.all(np.isnan(fj) | (fj == 0.0))  # slots read are left at zero
        assert tuple(worst) == worst_overlap(x, u, r, half, box, per, pi, pj, False)
        out.append((f, tq, vir, hist, pe, nc))
    assert out[0][5] and worst[0] > 0.05  # deep overlaps: the fraction is tested
    (a, b) = out
    assert a[5] == b[5] > 100
    # the general loop's normal forces leave rounding torques, of the forces' rounding
    atol = 1e-14 * max(1.0, np.abs(a[0]).max())
    for k in range(4):
        np.testing.assert_allclose(a[k], b[k], rtol=1e-12, atol=atol)
    assert a[4] == pytest.approx(b[4], rel=1e-14)
    if law != "hooke":  # some pairs attract across a gap, without a tangential force
        g = np.linalg.norm(x[pj] - x[pi] - box * np.round((x[pj] - x[pi]) / box), axis=1)
        gap = (g > r[pi] + r[pj]) & (g < r[pi] + r[pj] + 0.05)
        assert gap.sum() > 3
        if friction:
            assert np.all(b[3][gap] == 0.0)


def shared_particles(pi, jstart, jk, istart, parts):
    """How many particles the contact passes treat as shared among ``parts`` parts (their
    reactions come from rows of an earlier part), from :func:`part_bounds` directly."""
    from pysim.contacts import BLOCK, part_bounds

    n = len(istart) - 1
    bounds = part_bounds(istart, (n + BLOCK - 1) // BLOCK, parts) * BLOCK
    count = 0
    for lo, hi in zip(bounds[:-1], bounds[1:]):
        for i in range(lo, min(hi, n)):
            count += jstart[i] < jstart[i + 1] and pi[jk[jstart[i]]] < lo
    return count


@pytest.mark.parametrize("order", ["random", "sorted"])
def test_sphere_pass_is_the_same_bits_in_any_number_of_parts(rng, order):
    """Parts (threads) do not change the sums: the sphere pass on its rows in 2, 3 or 7
    parts, shared particles gathering their stored reactions, equals bit for bit the pass
    in one part that adds every reaction at once, for particles in random order (most
    are shared) and sorted by cell (few are); on the threads there are."""
    from pysim.contacts import clear_slots, sphere_pass
    from pysim.forces import HOOKE, contact_params
    from pysim.neighbors import build_list, spatial_order

    n = 500
    box = np.full(3, 8.0)
    x = rng.uniform(0, 8.0, (n, 3))
    if order == "sorted":
        x = x[spatial_order(x, box)]
    r = rng.uniform(0.4, 0.6, n)
    v = rng.normal(0, 1, (n, 3))
    w = rng.normal(0, 1, (n, 3))
    pi, pj, istart, jstart, jk = build_list(x, np.tile([0.0, 0.0, 1.0], (n, 1)), r,
                                            np.zeros(n), box, np.ones(3, bool), 0.3)
    p = contact_params(1e4, 5.0, k_t=5e3, gamma_t=1.0, mu=0.5)
    res = []
    for parts in (1, 2, 3, 7):
        shared = shared_particles(pi, jstart, jk, istart, parts)
        assert (shared == 0) if parts == 1 else (shared > 3)
        if order == "random" and parts > 1:
            assert shared > n // 4
        hist = np.tile([1e-4, -2e-4, 3e-4], (len(pj), 1))
        f = np.full((n, 3), np.nan)
        tq = np.full((n, 3), np.nan)
        fj = np.full((6, len(pj)), np.nan)  # only the shared particles' slots are read
        clear_slots(istart, jstart, jk, fj, parts, True)
        zeroed = np.sum(fj == 0.0)  # records of the shared particles' pairs
        assert zeroed == 0 if parts == 1 else zeroed > 3 * 6
        vir = np.zeros((3, 3))
        pe, nc = sphere_pass(x, v, w, r, box, np.ones(3, bool), pi, pj, istart, jstart, jk,
                             hist, HOOKE, p, True, 1e-4, f, tq, fj, True, vir, parts)
        assert np.all(np.isnan(fj) | (fj == 0.0))  # and left at zero
        res.append((f, tq, hist, vir, pe, nc))
    for other in res[1:]:
        for a, b in zip(res[0], other):
            assert np.array_equal(a, b)
    assert np.isfinite(res[0][0]).all() and res[0][5] > 100


@pytest.mark.slow
def test_pairs_skipped_by_the_motion_bound_change_nothing(rng):
    """The contact loop skips listed pairs that the motion bound keeps out of reach: after
    random translations, rotations and a box contraction the forces, torques, reactions
    and springs are the same bits as with every pair evaluated, and pairs were skipped."""
    from pysim.contacts import PAIR_SCRATCH, SEP
    from pysim.neighbors import motion_bound, spine_separations

    n = 200
    x, u, r, length, box = random_spherocylinders(np.full(n, 0.5), rng.uniform(0, 3, n), 0.3, 3)
    half = length / 2
    pi, pj, istart, jstart, jk = build_list(x, u, r + half, half, box, PER, 0.4)
    scratch = np.zeros((PAIR_SCRATCH, len(pi)))
    spine_separations(x, u, half, box, PER, pi, pj, scratch[SEP])
    x_ref, u_ref, box_ref = x.copy(), u.copy(), box.copy()
    p = contact_params(1e4, 5.0, k_t=5e3, gamma_t=1.0, mu=0.5)
    skipped = 0
    for step in range(40):
        box = box * np.exp(-0.0005)
        x = (x * np.exp(-0.0005) + rng.normal(0, 0.002, x.shape)) % box
        u = u + rng.normal(0, 0.002, u.shape)
        u /= np.linalg.norm(u, axis=1, keepdims=True)
        sigma, shrink = motion_bound(x, x_ref, u, u_ref, half, box, box_ref, PER, half.max(),
                                     1.0)
        v = rng.normal(0, 1, (n, 3))
        w = rng.normal(0, 1, (n, 3))
        hist = rng.normal(0, 1e-4, (len(pi), 3))
        out = []
        for bound in ((0.0, 0.0), (sigma, shrink)):
            f, tq, vir = np.empty((n, 3)), np.empty((n, 3)), np.zeros((3, 3))
            fj = scratch.copy()
            fj[:SEP] = np.nan
            h = hist.copy()
            pair_pass(x, v, w, u, r, half, box, PER, pj, istart, jstart, jk, h, HOOKE, p, True,
                      1e-4, True, f, tq, fj, True, vir, *bound)
            out.append((f, tq, fj[:SEP], h, vir))
        for a, b in zip(*out):
            np.testing.assert_array_equal(a, b)
        gap = sigma * scratch[SEP] - shrink - (r[pi] + r[pj])
        skipped += int(np.sum(gap > 1e-9))
    assert skipped > 1000


@pytest.mark.parametrize("radii", ["equal", "mixed"])
@pytest.mark.parametrize("parts", [1, 3])
@pytest.mark.parametrize("law", ["hooke", "hooke_no_tension", "hertz_cohesive"])
@pytest.mark.parametrize("friction", [False, True])
def test_rod_pass_is_the_same_bits_as_the_general_pass(rng, friction, law, parts, radii):
    """The rods loop (gather, closest points and laws on SIMD lanes, sums in pair order,
    the rows in one or three parts) gives the general loop's forces (with the reactions
    stored per pair and gathered), torques, springs, energy, contacts and virial bit for
    bit: rods of mixed lengths with spheres among them, 2-D-like parallel pairs, pairs in
    a cohesive gap, pairs skipped by the motion bound, and rows and blocks over several
    chunks. With mixed radii the rod pass's motion bound, which takes the largest reach
    for every pair, keeps pairs that the general pass's rules out."""
    from pysim.contacts import (BLOCK, PAIR_SCRATCH, RCAP, SEP, clear_slots, rod_pass,
                                worst_overlap)
    from pysim.neighbors import motion_bound, spine_separations

    n = 400
    alpha = rng.uniform(0, 3, n)
    alpha[rng.random(n) < 0.15] = 0.0  # some spheres among the rods
    radius = np.full(n, 0.5) if radii == "equal" else rng.choice([0.3, 0.5], n)
    x, u, r, length, box = random_spherocylinders(radius, alpha, 0.3, 5)
    u[:40] = u[0]  # exactly parallel spines
    half = length / 2
    pi, pj, istart, jstart, jk = build_list(x, u, r + half, half, box, PER, 0.4)
    assert istart[BLOCK] > RCAP  # the first block runs in more than one chunk
    scratch = np.zeros((PAIR_SCRATCH, len(pi)))
    spine_separations(x, u, half, box, PER, pi, pj, scratch[SEP])
    x_ref, u_ref, box_ref = x.copy(), u.copy(), box.copy()
    box = box * np.exp(-0.02)  # compress into contact
    x = (x * np.exp(-0.02) + rng.normal(0, 0.01, x.shape)) % box
    u = u + rng.normal(0, 0.01, u.shape)
    u /= np.linalg.norm(u, axis=1, keepdims=True)
    dl = np.full(n, np.nan)
    sigma, shrink = motion_bound(x, x_ref, u, u_ref, half, box, box_ref, PER, half.max(), 1.0,
                                 dl)
    v = rng.normal(0, 1, (n, 3))
    w = rng.normal(0, 1, (n, 3))
    law_id, p = chunk_test_law(law, friction)
    hist0 = rng.normal(0, 1e-4, (len(pi), 3)) if friction else np.zeros((len(pi), 0))
    out = []
    for kernel in ("general", "rods", "rods, own shares"):
        f, tq, vir = np.ones((n, 3)), np.ones((n, 3)), np.zeros((3, 3))
        fj = scratch.copy()
        fj[:SEP] = np.nan
        h = hist0.copy()
        worst = np.full(2, np.nan)
        if kernel == "general":
            pe, nc = pair_pass(x, v, w, u, r, half, box, PER, pj, istart, jstart, jk, h, law_id, p,
                               friction, 1e-4, True, f, tq, fj, True, vir, sigma, shrink,
                               False, worst)
            reduce_pass(f, tq, jstart, fj, v, w, np.ones(n), 0.0, 0.0, 0.0, 0.0, 0.0,
                        False)
        else:
            clear_slots(istart, jstart, jk, fj, parts, False)
            pe, nc = rod_pass(x, v, w, u, r, half, box, PER, pi, pj, istart, jstart, jk, h,
                              law_id, p, friction, 1e-4, f, tq, fj, True, vir, sigma, shrink,
                              parts, worst, dl if kernel == "rods, own shares" else None)
            assert np.all(np.isnan(fj[:SEP]) | (fj[:SEP] == 0.0))
        # the largest overlap and its pair, as a pass of its own finds them
        assert tuple(worst) == worst_overlap(x, u, r, half, box, PER, pi, pj, True)
        assert worst[0] > 0.01
        out.append((f, tq, h, vir, fj[SEP:], pe, nc))
    a = out[0]
    for b in out[1:]:
        assert a[6] == b[6] > 100
        for k in range(5):
            assert np.array_equal(a[k], b[k], equal_nan=True), k
        assert a[5] == b[5]
    skipped = sigma * scratch[SEP] - shrink > (r[pi] + r[pj] + p[6]) * 1.000000001
    assert skipped.sum() > 10
    # the rods' own shares rule out many of the pairs that the largest share keeps
    reach_max = (2 * r.max() + p[6]) * 1.000000001
    own = sigma * scratch[SEP] - dl[pi] - dl[pj] > reach_max
    assert np.sum(own & ~(sigma * scratch[SEP] - shrink > reach_max)) > 100
    if radii == "mixed":  # kept by the largest reach, skipped by the pair's own
        kept = ~(sigma * scratch[SEP] - shrink > (2 * r.max() + p[6]) * 1.000000001)
        assert np.sum(kept & skipped) > 10


def compressed_2d_rods(n=400, seed=4):
    """2-D bidisperse rods (``L/D`` up to 1) from RSA at 0.45, overdamped to 0.9."""
    rng = np.random.default_rng(seed)
    d = np.where(rng.random(n) < 0.5, 1.0, 1.4)
    x, u, r, length, box = random_spherocylinders(d / 2, rng.uniform(0, 1, n) * d, 0.45, seed,
                                                  dimension=2)
    st = State.create(x, r, length, box, axis=u, dimension=2, periodic=(True, True, False))
    sim = Simulation(st, ContactModel("harmonic", 1.0), dt=0.01, check_dt=False)
    sim.run_overdamped(int(np.log(0.9 / 0.45) / (2 * 2e-3 * 0.01)), k_d=1.0, kappa=2e-3)
    return sim


@pytest.mark.slow
@pytest.mark.skipif(numba.config.NUMBA_NUM_THREADS < 2, reason="needs 2 Numba threads")
def test_overdamped_and_fire_give_identical_bits_on_one_and_two_threads():
    """Heun's and FIRE's per-particle loops run on threads, and FIRE's sums are taken per
    block in block order: an overdamped compression and a FIRE relaxation end in the same
    bits on one thread and on two."""
    before = get_threads()
    out = []
    try:
        for threads in (1, 2):
            set_threads(threads)
            sim = compressed_2d_rods()
            it, fmax, tmax = sim.minimize(f_tol=1e-30, max_iter=400)
            out.append((sim, it, fmax, tmax))
    finally:
        set_threads(before)
    (a, it_a, fa, ta), (b, it_b, fb, tb) = out
    assert a.thermo().n_contacts > 100 and it_a == 400
    assert (it_a, fa, ta) == (it_b, fb, tb)
    for k in ("x", "v", "q", "u", "omega"):
        np.testing.assert_array_equal(getattr(a.state, k), getattr(b.state, k), err_msg=k)
    np.testing.assert_array_equal(a.f, b.f)
    assert a._pe == b._pe


def test_fire_sums_against_numpy(rng):
    """FIRE's block sums (:func:`pysim.integrators._fire_sums`, ``_speed_sums``): the
    largest squared force and torque exactly, the sums to rounding, on a length that
    does not fill its last block."""
    from pysim.contacts import BLOCK
    from pysim.integrators import _FIRE_SUMS, _fire_sums, _speed_sums
    n = 5 * BLOCK + 17
    f, tq, v, w = (rng.normal(size=(n, 3)) for _ in range(4))
    part = np.full(((n + BLOCK - 1) // BLOCK, _FIRE_SUMS), np.nan)
    fm, tm, fs, ts, vs, ws, pw = _fire_sums(f, tq, v, w, part)
    f2 = (f ** 2).sum(1)
    t2 = (tq ** 2).sum(1)
    assert fm == f2.max() and tm == t2.max()
    expect = (f2.sum(), t2.sum(), (v ** 2).sum(), (w ** 2).sum(), (f * v).sum() + (tq * w).sum())
    np.testing.assert_allclose((fs, ts, vs, ws, pw), expect, rtol=1e-12)
    assert _speed_sums(v, w, part) == (vs, ws)
