"""Physics of the reference engine: collisions, conservation laws, friction, walls,
drivers, and the overdamped and FIRE integrators."""
import math

import numpy as np
import pytest
from scipy.integrate import quad

from pysim import State
from pysim.initial import random_spheres, random_spherocylinders
from pysim.protocols.compress import stage_plan
from pysim.simulation import BlowUpError, ContactModel, Simulation
from pysim.walls import plane
from tests.pysim.helpers import clipped_restitution, collide, two_spheres


@pytest.mark.slow
def test_linear_spring_dashpot_restitution_and_contact_time():
    """e_n = exp(-pi zeta / sqrt(1 - zeta^2)), t_c = pi / sqrt(k/m_eff - (gamma/2m_eff)^2)."""
    k, gamma = 1e5, 30.0
    m_eff = np.pi / 12
    zeta = gamma / (2 * np.sqrt(m_eff * k))
    e_theory = np.exp(-np.pi * zeta / np.sqrt(1 - zeta**2))
    tc_theory = np.pi / np.sqrt(k / m_eff - (gamma / (2 * m_eff)) ** 2)
    v0 = 0.5
    sim = two_spheres(v0, ContactModel("hooke", k, gamma), dt=tc_theory / 2000)
    tc, v_rel_after = collide(sim, 20000)
    assert v_rel_after / (2 * v0) == pytest.approx(e_theory, rel=0.01)
    assert tc == pytest.approx(tc_theory, rel=0.01)


@pytest.mark.parametrize("gamma, gain", [(30.0, 0.01), (200.0, 0.15)])
def test_limit_damping_clips_the_pull_and_raises_the_restitution(gamma, gain):
    """With ``limit_damping`` the dashpot never pulls: two spheres part when the force
    reaches zero, with the restitution of the clipped equation of motion, above the
    unclipped ``e_n`` (zeta 0.09 and 0.62: e_n 0.746 and 0.085, clipped 0.759 and
    0.241); a sphere dropped on a plane likewise, with its full mass as ``m_eff``."""
    k, v0 = 1e5, 0.5
    m_eff = np.pi / 12
    zeta = gamma / (2 * np.sqrt(m_eff * k))
    e_free = np.exp(-np.pi * zeta / np.sqrt(1 - zeta**2))
    e_clip = clipped_restitution(k, gamma, m_eff)
    assert e_clip > e_free + gain
    model = ContactModel("hooke", k, gamma, limit_damping=True)
    sim = two_spheres(v0, model, dt=np.pi / np.sqrt(k / m_eff) / 2000)
    _, v_rel_after = collide(sim, 20000)
    assert v_rel_after / (2 * v0) == pytest.approx(e_clip, rel=0.01)
    # one sphere (mass pi/6) falling at 0.5 on a plane, no gravity
    st = State.spheres(np.array([[2.5, 2.5, 0.5 + 1e-9]]), 0.5, np.full(3, 5.0),
                       v=np.array([[0.0, 0.0, -v0]]), periodic=(True, True, False))
    sim = Simulation(st, model, dt=np.pi / np.sqrt(k / (2 * m_eff)) / 2000,
                     planes=[plane((0, 0, 1), (0, 0, 0))])
    for _ in range(20000):
        sim.run(1)
        if st.v[0, 2] > 0 and len(sim.wall_contact_table()[0]) == 0:
            break
    assert st.v[0, 2] / v0 == pytest.approx(clipped_restitution(k, gamma, 2 * m_eff), rel=0.01)


def test_hertz_contact_time():
    """Undamped Hertz f = k delta^(3/2): energy conservation gives the maximal overlap
    delta_max = (5 m_eff v^2 / (4 k))^(2/5) and the duration
    t_c = 2 (delta_max / v) int_0^1 dx / sqrt(1 - x^(5/2))."""
    k = 1e5
    m_eff = np.pi / 12
    v0 = 0.4
    v = 2 * v0
    delta_max = (5 * m_eff * v**2 / (4 * k)) ** 0.4
    integral, _ = quad(lambda x: 1 / np.sqrt(1 - x**2.5), 0, 1)
    tc_theory = 2 * delta_max / v * integral
    sim = two_spheres(v0, ContactModel("hertz", k, 0.0), dt=tc_theory / 4000)
    tc, v_after = collide(sim, 40000)
    assert tc == pytest.approx(tc_theory, rel=0.01)
    assert v_after == pytest.approx(2 * v0, rel=1e-3)


def rod_gas(dim, n, seed=7, alpha=(0.0, 2.0), phi=0.25, v_rms=1.0):
    """Random non-overlapping spherocylinders (D = 1, aspect ratios uniform in
    ``alpha``) in a periodic box, with random velocities and spins."""
    rng = np.random.default_rng(seed)
    x, u, r, length, box = random_spherocylinders(np.full(n, 0.5), rng.uniform(*alpha, n), phi,
                                                   seed, dimension=dim)
    v = rng.normal(0, v_rms, (n, 3))
    w = rng.normal(0, v_rms, (n, 3))
    if dim == 2:
        v[:, 2] = 0
        w[:, :2] = 0
    v -= v.mean(axis=0)
    per = (True, True, dim == 3)
    return State.create(x, r, length, box, axis=u, v=v, omega=w, periodic=per, dimension=dim)


def energy(sim):
    th = sim.thermo()
    return th.ke + th.pe


@pytest.mark.parametrize("dim", [2, 3])
def test_energy_and_momentum_conservation_of_a_dense_rod_gas(dim):
    st = rod_gas(dim, 150 if dim == 3 else 120, phi=0.3, v_rms=3.0)
    model = ContactModel("hooke", 1e5, 0.0)
    m_eff = 0.5 * st.mass.min()
    sim = Simulation(st, model, dt=model.contact_time(m_eff) / 60)
    e0 = energy(sim)
    p0 = st.momentum()
    collisions = 0
    for _ in range(100):
        sim.run(100)
        collisions += sim.thermo().n_contacts
    e1 = energy(sim)
    assert collisions > 200  # a dense gas: a couple of contacts at every sample
    assert abs(e1 - e0) / e0 < 1e-4
    np.testing.assert_allclose(st.momentum(), p0, atol=1e-12 * np.abs(st.mass[:, None] * st.v).sum())


def test_angular_momentum_of_an_isolated_cluster():
    """Rods colliding far from every boundary keep their total angular momentum."""
    st = rod_gas(3, 40, seed=3, phi=0.15, v_rms=2.0)
    st.box[:] = 200.0
    st.x += 90.0
    model = ContactModel("hooke", 1e5, 10.0, k_t=3e4, gamma_t=5.0, mu=0.5)
    sim = Simulation(st, model, dt=2e-5)
    l0 = st.angular_momentum()
    contacts = 0
    for _ in range(100):
        sim.run(200)
        contacts += sim.thermo().n_contacts
    assert contacts > 20
    assert np.all((st.x > 10) & (st.x < 190))
    np.testing.assert_allclose(st.angular_momentum(), l0, atol=1e-10 * np.abs(l0).max())


def test_free_symmetric_top_conserves_energy_and_angular_momentum():
    st = State.create(np.array([[5.0, 5.0, 5.0]]), 0.5, 3.0, np.full(3, 10.0),
                      axis=np.array([[0.3, 0.4, 0.866]]), omega=np.array([[1.0, -2.0, 3.0]]))
    sim = Simulation(st, ContactModel("hooke", 1e5), dt=1e-3)
    e0, l0 = st.kinetic_energy(), st.angular_momentum()
    sim.run(5000)
    assert st.kinetic_energy() == pytest.approx(e0, rel=1e-12)
    np.testing.assert_allclose(st.angular_momentum(), l0, rtol=1e-12)
    assert np.linalg.norm(st.u[0]) == pytest.approx(1.0, abs=1e-14)


def test_tilted_rod_dropped_on_a_frictional_floor_comes_to_rest_flat():
    L = 3.0
    tilt = np.radians(35)
    st = State.create(np.array([[5.0, 5.0, 2.5]]), 0.5, L, np.array([10.0, 10.0, 20.0]),
                      axis=np.array([[np.cos(tilt), 0.0, np.sin(tilt)]]),
                      periodic=(True, True, False))
    # restitution ~ 0.3 against the floor (zeta = 0.36 for the rod's mass)
    model = ContactModel("hooke", 2e5, 550.0, k_t=5e4, gamma_t=10.0, mu=0.5)
    sim = Simulation(st, model, dt=2e-5, gravity=(0, 0, -10), planes=[plane((0, 0, 1), (0, 0, 0))])
    for _ in range(100):
        sim.run(2500)
    assert abs(st.u[0, 2]) < 1e-3  # lying flat
    assert st.x[0, 2] == pytest.approx(0.5, abs=2e-3)
    assert np.linalg.norm(st.v[0]) < 1e-3 and np.linalg.norm(st.omega[0]) < 1e-3
    # two wall contacts (both spine ends) carry the weight
    iw, rec = sim.wall_contact_table()
    assert len(iw) == 2
    assert rec[:, 9].sum() == pytest.approx(st.mass[0] * 10, rel=1e-3)  # on the grain, upwards


@pytest.mark.parametrize("angle_deg, slides", [(15.0, False), (22.0, False), (30.0, True), (40.0, True)])
def test_block_on_a_slope_sticks_below_tan_mu_and_slides_above(angle_deg, slides):
    """A rod lying along the fall line of a plane with mu = 0.5 (tan = 0.5 at 26.6 deg)."""
    mu = 0.5
    a = np.radians(angle_deg)
    st = State.create(np.array([[5.0, 5.0, 0.5 - 1e-4]]), 0.5, 2.0, np.array([10.0, 10.0, 20.0]),
                      axis=np.array([[1.0, 0.0, 0.0]]), periodic=(True, True, False))
    model = ContactModel("hooke", 2e5, 80.0, k_t=5e4, gamma_t=10.0, mu=mu)
    g = 10.0
    sim = Simulation(st, model, dt=2e-5, gravity=(g * np.sin(a), 0.0, -g * np.cos(a)),
                     planes=[plane((0, 0, 1), (0, 0, 0))])
    sim.run(20000)  # settle
    x0 = st.x[0, 0]
    sim.run(30000)
    travelled = st.x[0, 0] - x0
    if slides:
        # accelerating down the slope at g (sin a - mu cos a)
        t = 30000 * 2e-5
        expected = 0.5 * g * (np.sin(a) - mu * np.cos(a)) * t**2
        assert travelled > 0.9 * expected
    else:
        assert abs(travelled) < 1e-4


@pytest.mark.parametrize("dim", [2, 3])
def test_compression_and_growth_drivers_keep_n_and_follow_the_schedule(dim):
    st = rod_gas(dim, 60, seed=5, phi=0.15, v_rms=0.0)
    sim = Simulation(st, ContactModel("hooke", 1e5, 100.0, gamma_bg=1.0, gamma_rot=0.1), dt=1e-4)
    n0 = st.n
    phi0 = st.packing_fraction()
    sim.run(5000, strain_rate=-0.2)
    assert st.packing_fraction() == pytest.approx(phi0 * math.exp(dim * 0.2 * 0.5), rel=1e-9)
    phi1 = st.packing_fraction()
    alpha0 = st.length / (2 * st.radius)
    sim.run(5000, growth_rate=0.1)
    # areas grow as exp(2 g t), volumes as exp(3 g t)
    assert st.packing_fraction() == pytest.approx(phi1 * math.exp(dim * 0.1 * 0.5), rel=1e-9)
    np.testing.assert_allclose(st.length / (2 * st.radius), alpha0, rtol=1e-12)
    assert st.n == n0
    per = st.periodic
    assert np.all((st.x[:, per] >= 0) & (st.x[:, per] < st.box[per]))


def test_growing_particles_fall_at_g_and_keep_their_spin():
    """The kicks multiply by reciprocals of mass and inertia (``integrators.inverses``)
    that must follow the particles' growth within a call: a free particle falls at g
    whatever its mass (a stale ``1/m`` would give it ``g m(t)/m(0)``), and a free rod's
    spin is ``I^-1 (I omega)`` through every step (a stale ``1/I`` scales it by the
    growth of ``I`` per step)."""
    x = np.array([[2.0, 2.0, 2.0], [6.0, 6.0, 6.0]])
    u = np.array([[0.0, 0.6, 0.8], [1.0, 0.0, 0.0]])
    w = np.array([[0.3, -0.2, 0.5], [0.0, 0.0, 0.0]])
    st = State.create(x, np.full(2, 0.5), np.array([2.0, 0.0]), np.full(3, 10.0), axis=u,
                      omega=w)
    g, dt, nsteps = 2.0, 1e-4, 2000
    sim = Simulation(st, ContactModel("hooke", 1e5), dt=dt, gravity=(0.0, 0.0, -g))
    m0 = st.mass.copy()
    w0 = np.linalg.norm(st.omega[0])
    rate = 5.0
    sim.run(nsteps, growth_rate=rate)  # every mass grows e^3-fold
    assert st.mass[0] / m0[0] == pytest.approx(math.exp(3.0), rel=1e-9)
    # the half kick after a step's growth applies the force m g of the mass before it:
    # g/s3 (s3 = exp(3 rate dt)); the first and the last half kick apply g
    s3 = math.exp(3 * rate * dt)
    fall = 0.5 * dt * g * (2 + (nsteps - 1) * (1 + 1 / s3))
    np.testing.assert_allclose(st.v[:, 2], -fall, rtol=1e-10)
    np.testing.assert_allclose(st.v[:, :2], 0.0, atol=1e-15)
    assert np.linalg.norm(st.omega[0]) == pytest.approx(w0, rel=1e-12)


def test_inverses_are_the_reciprocals_of_mass_and_inertia():
    from pysim.integrators import inverses

    st = rod_gas(3, 200, seed=3)
    inv = np.empty((st.n, 3))
    inverses(st.mass, st.inertia, inv)
    np.testing.assert_array_equal(inv, 1.0 / np.column_stack([st.mass, st.inertia]))


@pytest.mark.slow
def test_compression_stage_plan_reaches_the_target():
    x, d, box = random_spheres(np.ones(200), 0.25, seed=2)
    st = State.spheres(x, d / 2, box)
    sim = Simulation(st, ContactModel("hooke", 1e5, 100.0, gamma_bg=1.0), dt=1e-4)
    protocol = {"phi_init": 0.25, "phi_fast": 0.4, "rate_fast": 0.1, "rate": 0.02,
                "phi_final": 0.5, "dt": 1e-4}
    for _, nsteps, rate in stage_plan(protocol):
        sim.run(nsteps, strain_rate=rate)
    assert st.packing_fraction() == pytest.approx(0.5, abs=1e-3)


@pytest.mark.slow
def test_overdamped_pair_relaxes_exponentially():
    """Two overlapping harmonic disks: d(delta)/dt = -2 k_e delta / (k_d A d^2)."""
    x = np.array([[4.0, 5.0, 0.0], [4.8, 5.0, 0.0]])
    st = State.create(x, 0.5, 0.0, np.array([10.0, 10.0, 0.0]), dimension=2,
                      periodic=(True, True, False))
    k_e, k_d = 1.0, 1.0
    sim = Simulation(st, ContactModel("harmonic", k_e), dt=0.01, check_dt=False)
    area = np.pi * 0.25
    rate = 2 * k_e / (k_d * area * 1.0**2)
    sim.run_overdamped(100, k_d=k_d)
    delta = 1.0 - np.linalg.norm(st.x[1] - st.x[0])
    # Heun multiplies a linear decay by 1 - h + h^2/2 per step (h = rate dt) ...
    h = rate * 0.01
    assert delta == pytest.approx(0.2 * (1 - h + h * h / 2) ** 100, rel=1e-10)
    # ... which is the exact exponential to O(h^3) per step
    assert delta == pytest.approx(0.2 * np.exp(-rate * 1.0), rel=1e-3)


def jammed_2d(alpha_max, n=60, seed=11, phi=0.88):
    """Random 2-D packing (RSA at 0.45) compressed overdamped to ``phi``."""
    rng = np.random.default_rng(seed)
    length = rng.uniform(0, alpha_max, n) if alpha_max else np.zeros(n)
    d = np.where(rng.random(n) < 0.5, 1.0, 1.4)
    x, u, r, length, box = random_spherocylinders(d / 2, length * d, 0.45, seed, dimension=2)
    st = State.create(x, r, length, box, axis=u, dimension=2, periodic=(True, True, False))
    sim = Simulation(st, ContactModel("harmonic", 1.0), dt=0.01, check_dt=False)
    kappa = 1e-3
    sim.run_overdamped(int(math.log(phi / 0.45) / (2 * kappa * 0.01)), k_d=1.0, kappa=kappa)
    return sim


@pytest.mark.slow
def test_fire_balances_a_jammed_disk_packing():
    sim = jammed_2d(0.0)
    pe0 = sim.thermo().pe
    assert pe0 > 0  # above jamming
    it, fmax, tmax = sim.minimize(f_tol=1e-10, max_iter=200_000)
    assert fmax < 1e-10
    assert 0 < sim.thermo().pe < pe0  # jammed: energy stays positive


def test_fire_on_2d_rods_stays_planar_and_lowers_the_energy():
    """The spine-distance law has a kink for parallel side-by-side rods (the closest
    points jump from an end to the middle), so forces and torques of jammed rods cannot
    all vanish; FIRE must still lower the energy and leave residuals small against the
    contact forces, and never tilt a rod out of the plane."""
    sim = jammed_2d(1.0, phi=0.93)
    pe0 = sim.thermo().pe
    sim.minimize(f_tol=1e-10, max_iter=20_000)
    st = sim.state
    assert sim.thermo().pe < pe0
    assert np.all(st.x[:, 2] == 0) and np.abs(st.u[:, 2]).max() < 1e-9
    ij, rec = sim.contact_table()
    mean_contact = np.linalg.norm(rec[:, 7:10], axis=1).mean()
    assert np.linalg.norm(sim.f, axis=1).mean() < 0.1 * mean_contact


def test_blow_up_is_reported_with_step_and_particles():
    st = State.spheres(np.array([[2.0, 2.5, 2.5], [3.0, 2.5, 2.5]]), 0.5, np.full(3, 6.0),
                       v=np.array([[40.0, 0, 0], [-40.0, 0, 0]]))
    sim = Simulation(st, ContactModel("hooke", 1e3, 0.0), dt=1e-3)
    with pytest.raises(BlowUpError, match=r"overlap .* between particles \(0-based\) 0 and 1 at step"):
        sim.run(100)


@pytest.mark.parametrize("spine_contact", ["closest", "end_bonds"])
def test_rod_blow_up_is_reported_with_the_overlap_of_the_last_forces(spine_contact):
    """Two rods driven into each other side by side: the overlap the check reports is the
    closest-point overlap of the final state, whether the contact pass found it
    (``closest``) or the check had to search the pairs itself (``end_bonds``)."""
    from pysim.contacts import worst_overlap

    # in 2-D, where end_bonds is allowed (3-D rods refuse it: crossed rods would pass)
    x = np.array([[2.0, 3.0, 0.0], [3.02, 3.0, 0.0], [5.0, 6.0, 0.0]])
    axis = np.tile([0.0, 1.0, 0.0], (3, 1))
    v = np.array([[10.0, 0, 0], [-10.0, 0, 0], [0, 0, 0]])
    st = State.create(x, np.full(3, 0.5), np.array([2.0, 2.0, 0.0]), [8.0, 8.0, 1.0],
                      axis=axis, v=v, periodic=(True, True, False), dimension=2)
    sim = Simulation(st, ContactModel("hooke", 1e3, 0.0, spine_contact=spine_contact),
                     dt=1e-3, max_overlap=0.5)
    sim.run(10)  # below the limit: no error
    s = sim.state
    frac, k = worst_overlap(s.x, s.u, s.radius, sim.half, s.box, s.periodic, sim.pi, sim.pj,
                            True)
    assert 0.05 < frac < 0.5
    sim.max_overlap = 0.9 * frac
    with pytest.raises(BlowUpError, match=rf"overlap {frac:.3g} of a diameter between "
                       r"particles \(0-based\) 0 and 1 at step 10 exceeds"):
        sim._check("test")


def test_time_step_above_contact_time_is_refused():
    x, d, box = random_spheres(np.ones(50), 0.3, seed=1)
    with pytest.raises(ValueError, match="above 1/10 of the contact time"):
        Simulation(State.spheres(x, d / 2, box), ContactModel("hooke", 1e5, 0.0), dt=1e-3)


@pytest.mark.parametrize("spring", ["reset", "keep"])
def test_sphere_launched_sliding_rolls_off_and_the_kept_spring_undoes_its_slip(spring):
    """A sphere launched at V0 without spin slides on a frictional floor until it rolls at
    5/7 V0 with either tangential spring. The slip velocity s = v - omega R falls at
    3.5 mu g, so the contact point slides V0^2 / (7 mu g) and the reset spring keeps that
    slip. The kept spring (Pournin et al. 2005) remembers it: its force stays at the cap
    and drives the contact point back until the net slip fits within the elastic range
    mu m g / k_t, a back-slip nearly as fast as the launch."""
    V0, mu, g, kn, R = 0.3, 0.5, 10.0, 1e5, 0.5
    m = np.pi / 6
    dt = 1.4e-4
    st = State.spheres(np.array([[5.0, 5.0, R - m * g / kn]]), R, np.array([10.0, 10.0, 10.0]),
                       v=np.array([[V0, 0.0, 0.0]]), periodic=(True, True, False))
    model = ContactModel("hooke", kn, 137.0, k_t=2 / 7 * kn, gamma_t=50.0, mu=mu,
                         tangential_spring=spring)
    sim = Simulation(st, model, dt=dt, gravity=(0, 0, -g), planes=[plane((0, 0, 1), (0, 0, 0))])
    s = [V0]
    for _ in range(3000):
        sim.run(1)
        s.append(st.v[0, 0] - R * st.omega[0, 1])
    s = np.array(s)
    slip = dt * (s.sum() - 0.5 * (s[0] + s[-1]))  # net slip of the contact point
    assert st.v[0, 0] == pytest.approx(5 / 7 * V0, rel=1e-3)
    assert abs(s[-1]) < 1e-3 * V0  # rolling
    if spring == "reset":
        assert slip == pytest.approx(V0**2 / (7 * mu * g), rel=0.05)
        assert s.min() > -0.1 * V0  # an elastic recoil only
    else:
        assert abs(slip) < mu * m * g / (2 / 7 * kn)
        assert s.min() < -0.8 * V0


def euler_pair(k, gamma, v0, dt, explicit, nmax=2000):
    """NumPy reference of :func:`tests.pysim.helpers.two_spheres` under the linear law
    ``f = k delta + gamma delta'`` stepped with explicit or semi-implicit Euler; returns
    (steps in contact, relative speed after separation)."""
    m = np.pi / 6
    x = np.array([2.0, 3.0 + 1e-9])
    v = np.array([v0, -v0])

    def force(x, v):
        delta = 1.0 - (x[1] - x[0])
        fn = k * delta + gamma * (v[0] - v[1]) if delta > 0 else 0.0
        return np.array([-fn, fn]), delta > 0
    f, _ = force(x, v)
    steps = 0
    for _ in range(nmax):
        if explicit:
            x, v = x + dt * v, v + dt * f / m
        else:
            v = v + dt * f / m
            x = x + dt * v
        f, touching = force(x, v)
        if touching:
            steps += 1
        elif steps:
            return steps, v[1] - v[0]
    raise AssertionError("no separation")


@pytest.mark.parametrize("integrator", ["euler", "semi_implicit_euler"])
@pytest.mark.parametrize("e_n", [0.4, 0.8])
def test_euler_collision_follows_the_numpy_euler_step(integrator, e_n):
    """Two spheres at dt = t_c/30 (Pournin et al.'s step) under pysim's Euler schemes
    collide as a NumPy Euler integration of the same law, to rounding; the explicit
    scheme restitutes more than the nominal e_n, the semi-implicit one about e_n."""
    k, v0, m_eff = 1e5, 0.5, np.pi / 12
    zeta = -np.log(e_n) / np.sqrt(np.pi ** 2 + np.log(e_n) ** 2)
    gamma = 2 * zeta * np.sqrt(m_eff * k)
    dt = np.pi / np.sqrt(k / m_eff - (gamma / (2 * m_eff)) ** 2) / 30
    sim = two_spheres(v0, ContactModel("hooke", k, gamma), dt)
    sim.integrator = integrator
    t_contact, v_after = collide(sim, 2000)
    steps, v_ref = euler_pair(k, gamma, v0, dt, integrator == "euler")
    assert v_after == pytest.approx(v_ref, rel=1e-9)
    assert t_contact == pytest.approx(steps * dt, rel=1e-9)
    e = v_after / (2 * v0)
    if integrator == "euler":
        assert e > e_n + 0.04
    else:
        assert e == pytest.approx(e_n, abs=0.02)


@pytest.mark.parametrize("integrator", ["euler", "semi_implicit_euler"])
def test_euler_step_of_a_rod_on_a_frictional_floor(integrator):
    """One step of a tilted, spinning, sliding rod touching a frictional floor: explicit
    Euler moves it with the old velocities, semi-implicit with the new; both give
    ``v + dt F/m`` and the angular momentum ``I omega + dt tau`` (about the new axis),
    the axis turning freely at the angular momentum the scheme moves it with."""
    from pysim.integrators import free_step
    tilt = np.radians(35)
    st = State.create(np.array([[5.0, 5.0, 1.35]]), 0.5, 3.0, np.array([10.0, 10.0, 20.0]),
                      axis=np.array([[np.cos(tilt), 0.0, np.sin(tilt)]]),
                      v=np.array([[0.3, -0.2, -0.5]]), periodic=(True, True, False))
    st.omega[:] = [[0.4, 1.1, -0.7]]
    model = ContactModel("hooke", 2e5, 550.0, k_t=5e4, gamma_t=10.0, mu=0.5)
    sim = Simulation(st, model, dt=2e-5, gravity=(0, 0, -10),
                     planes=[plane((0, 0, 1), (0, 0, 0))], integrator=integrator)
    assert len(sim.wall_contact_table()[0]) == 1
    dt, m = sim.dt, st.mass[0]
    ip, ia = st.inertia[0]
    x0, v0, w0, u0, q0 = (a[0].copy() for a in (st.x, st.v, st.omega, st.u, st.q))
    f0, t0 = sim.f[0].copy(), sim.torque[0].copy()
    assert np.linalg.norm(t0) > 0

    def ang(w, u):
        return ip * w + (ia - ip) * np.dot(w, u) * u

    def inv_ang(lv, u):
        return lv / ip + (1 / ia - 1 / ip) * np.dot(lv, u) * u
    sim.run(1)
    v1 = v0 + dt * f0 / m
    l1 = ang(w0, u0) + dt * t0
    if integrator == "euler":
        x1, w_turn = x0 + dt * v0, w0
    else:
        x1, w_turn = x0 + dt * v1, inv_ang(l1, u0)
    turned = free_step(*q0, *u0, *w_turn, ip, ia, 1 / ip, 1 / ia, dt)
    assert st.x[0] == pytest.approx(x1, rel=1e-12, abs=1e-14)
    assert st.v[0] == pytest.approx(v1, rel=1e-12, abs=1e-14)
    assert st.u[0] == pytest.approx(np.array(turned[4:7]), rel=1e-12, abs=1e-14)
    assert ang(st.omega[0], st.u[0]) == pytest.approx(l1, rel=1e-10, abs=1e-14)


def test_euler_integrators_refuse_deformation_and_unknown_names():
    sim = two_spheres(0.5, ContactModel("hooke", 1e5, 1.0), 1e-4)
    sim.integrator = "euler"
    with pytest.raises(ValueError, match="no box deformation or growth; use integrator 'verlet'"):
        sim.run(1, strain_rate=1e-3)
    with pytest.raises(ValueError, match=r"unknown integrator 'rk4'; valid: 'verlet', 'euler'"):
        Simulation(sim.state, sim.model, dt=1e-4, integrator="rk4")
    with pytest.raises(ValueError, match=r"unknown integrator 'Euler'; valid: 'verlet', 'euler'"):
        sim.integrator = "Euler"
    assert sim.integrator == "euler"


@pytest.mark.parametrize("wall_cohesion", [False, True])
def test_cohesive_walls_pull_a_grain_within_the_range(wall_cohesion):
    """A rod lying parallel to a base, its surface a third of the cohesion range above it:
    with ``wall_cohesion`` each spine end's wall contact pulls with ``F_c`` (two ends, the
    vertex contacts of a flat rod), without it the base does nothing; grains still
    attract each other either way."""
    f_c, d_c = 2.0e-3, 1.0e-3
    model = ContactModel("hertz", 1e3, 0.0, f_coh=f_c, d_coh=d_c, wall_cohesion=wall_cohesion)
    x = np.array([[1.0, 0.5 + d_c / 3, 0.0], [1.0, 0.5 + d_c / 3 + 1.0 + d_c / 3, 0.0]])
    axis = np.tile([1.0, 0.0, 0.0], (2, 1))
    st = State.create(x, 0.5, 1.0, np.array([4.0, 4.0, 0.0]), axis=axis,
                      periodic=(False, False, False), dimension=2)
    sim = Simulation(st, model, dt=1e-4, planes=[plane([0, 1, 0], [0, 0, 0])])
    sim.compute_forces()
    pull = -2 * f_c if wall_cohesion else 0.0
    # rod 0: pulled down by the base and up by rod 1 (one closest-point contact)
    assert sim.f[0, 1] == pytest.approx(pull + f_c, rel=1e-12, abs=1e-15)
    assert sim.f[1, 1] == pytest.approx(-f_c, rel=1e-12)
    assert sim.wall_force[0, 1] == pytest.approx(-pull, rel=1e-12, abs=1e-15)
