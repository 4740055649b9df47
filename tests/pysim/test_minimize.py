"""L-BFGS energy minimisation (:func:`pysim.minimize.lbfgs`): it balances every force
and torque of overlapping rods in 2-D and 3-D, lowers the energy, leaves a state that
FIRE accepts at once, and refuses what has no energy to minimise."""
import numpy as np
import pytest

from pysim import walls
from pysim.minimize import lbfgs
from pysim.rotation import axes
from pysim.simulation import ContactModel, Simulation
from tests.pysim.helpers import overlapping_rods


@pytest.mark.parametrize("dim, spine_contact", [(2, "end_bonds"), (3, "closest")])
def test_lbfgs_balances_overlapping_rods(dim, spine_contact):
    sim = overlapping_rods(dim, 40, 1.0, 0.95 if dim == 2 else 0.7, 3, spine_contact)
    assert sim.state.packing_fraction() == pytest.approx(0.95 if dim == 2 else 0.7)
    sim.compute_forces()
    e0 = sim.thermo().pe
    assert np.abs(sim.f).max() > 1e-2  # far from balanced
    # the energy is of order 1: its rounding (1e-16) bounds what a line search on it can
    # resolve to forces of some sqrt(1e-16 k_n U) = 1e-8
    it, fmax, tmax = lbfgs(sim, f_tol=1e-7, max_iter=20_000)
    assert fmax < 1e-7 and tmax < 1e-7, (it, fmax, tmax)
    # the returned residuals are those of the final state, and so is the energy
    sim.compute_forces()
    assert np.linalg.norm(sim.f, axis=1).max() == pytest.approx(fmax, abs=1e-15)
    assert 0 < sim.thermo().pe < 0.5 * e0  # still overlapping (jammed), much relaxed
    # spines stay unit vectors, in the plane in 2-D, and the quaternions follow them
    s = sim.state
    assert np.allclose(np.linalg.norm(s.u, axis=1), 1.0)
    u_of_q = np.empty_like(s.u)
    axes(s.q, u_of_q)
    np.testing.assert_allclose(u_of_q, s.u, atol=1e-12)
    if dim == 2:
        assert np.all(s.u[:, 2] == 0) and np.all(s.x[:, 2] == 0)
    assert np.all((s.x >= 0) & (s.x <= s.box))
    # FIRE, given the same tolerance, finds nothing left to do
    it_fire, f_fire, t_fire = sim.minimize(f_tol=1e-7, max_iter=10)
    assert it_fire == 0 and f_fire < 1e-7 and t_fire < 1e-7


def test_lbfgs_refuses_what_has_no_energy():
    sim = overlapping_rods(2, 40, 1.0, 0.9, 1, "closest")
    st = sim.state
    fric = Simulation(st, ContactModel("hooke", 1.0, k_t=1.0, mu=0.5), dt=0.01,
                      check_dt=False, max_overlap=1.0)
    with pytest.raises(ValueError, match=r"friction \(mu = 0.5\)"):
        lbfgs(fric, 1e-10)
    grav = Simulation(st, ContactModel("harmonic", 1.0), dt=0.01, gravity=(0, -1, 0),
                      check_dt=False, max_overlap=1.0)
    with pytest.raises(ValueError, match="walls or gravity"):
        lbfgs(grav, 1e-10)
    wall = Simulation(st, ContactModel("harmonic", 1.0), dt=0.01, check_dt=False,
                      max_overlap=1.0, planes=[walls.plane((0, 1, 0), (0, 0, 0))])
    with pytest.raises(ValueError, match="walls or gravity"):
        lbfgs(wall, 1e-10)
    with pytest.raises(ValueError, match="f_tol = 0"):
        lbfgs(sim, 0.0)


def test_fire_checks_until_every_check_every_iterations():
    """``Simulation.minimize(until=...)``: FIRE run in checked pieces follows the same
    trajectory as in one piece (its velocities and step size carry over), and stops at
    the first check that answers true, with velocities zeroed."""
    import copy

    sim = overlapping_rods(2, 40, 1.0, 0.95, 3, "end_bonds")
    twin = copy.deepcopy(sim)
    it, fmax, _ = sim.minimize(f_tol=1e-14, max_iter=2500)
    calls = []
    it2, fmax2, _ = twin.minimize(f_tol=1e-14, max_iter=2500, check_every=700,
                                  until=lambda s: calls.append(s.state.step) or False)
    assert it == it2 == 2500 and len(calls) == 3  # after 700, 1400, 2100; not at the end
    np.testing.assert_array_equal(twin.state.x, sim.state.x)
    np.testing.assert_array_equal(twin.state.u, sim.state.u)
    assert fmax2 == fmax
    stopped = copy.deepcopy(twin)
    it3, _, _ = stopped.minimize(f_tol=1e-14, max_iter=2500, check_every=300,
                                 until=lambda s: np.abs(s.f).max() < 10 * fmax)
    assert it3 % 300 == 0 and 0 < it3 < 2500
    assert np.abs(stopped.f).max() < 10 * fmax
    assert not stopped.state.v.any() and not stopped.state.omega.any()
    with pytest.raises(ValueError, match="check_every"):
        stopped.minimize(f_tol=1e-14, until=lambda s: True, check_every=0)


def test_lbfgs_does_not_depend_on_the_scale_of_the_energy():
    """L-BFGS scales the energy to a gradient of one over the mean overlap, so it does
    not depend on ``k_n``: with the forces of a packing near jamming (1e-14 of those of
    k_n = 1), it balances the same packing to the same relative tolerance and ends where
    it does with k_n = 1. Unscaled, it took the same first move of one length unit
    against gradients 1e14 times smaller, and ended elsewhere.

    A state balanced to ``f_tol`` is defined only to about ``f_tol / k_soft`` along its
    softest modes (here some ten times ``f_tol``: the two ends differed by 1.2e-6 at
    ``f_tol`` = 1e-7 and by 1.0e-7 at 1e-8, measured 2026-11-25), so the ends are balanced
    to 1e-8 and compared to 1e-6."""
    ends = []
    for k_n in (1.0, 1e-14):
        sim = overlapping_rods(2, 40, 1.0, 0.95, 3, "end_bonds", k_n)
        it, fmax, tmax = lbfgs(sim, f_tol=1e-8 * k_n, max_iter=20_000)
        assert it > 10 and fmax < 1e-8 * k_n and tmax < 1e-8 * k_n, (k_n, it, fmax, tmax)
        ends.append(sim.state.x.copy())
    np.testing.assert_allclose(ends[1], ends[0], atol=1e-6)


def test_lbfgs_turns_nearly_round_rods():
    """Rotations are scaled by the half-length, so rods of alpha 0.02, whose rotational
    stiffness is some (L/2R)^2 = 4e-4 of the translational one, are balanced in torque
    as well as in force: L-BFGS runs until its line search can resolve no more (forces
    some 1e-8 of the start, energy of order k_n) with the torques below 2e-7 of the start.
    Scaled by the radius it stopped at 5.6e-7, after twice the iterations."""
    sim = overlapping_rods(2, 40, 0.02, 0.95, 3, "end_bonds")
    sim.compute_forces()
    f0 = np.linalg.norm(sim.f, axis=1).max()
    t0 = np.linalg.norm(sim.torque, axis=1).max()
    it, fmax, tmax = lbfgs(sim, f_tol=1e-30, max_iter=2000)
    assert fmax < 1e-7 * f0 and tmax < 2e-7 * t0, (it, fmax / f0, tmax / t0)


@pytest.mark.parametrize("dim", [2, 3])
def test_coordinate_and_gradient_kernels_match_numpy(dim, rng):
    """``set_coordinates`` and ``gradient`` (the kernels of L-BFGS' energy function) give
    the bits of the NumPy vector forms they replace, on random inputs: positions
    ``h z`` wrapped into the box, spines ``w / |w|`` with ``w = h z / l``, the gradient
    ``-F`` and ``(u x tau) / (|w| l)``, and the largest force and torque."""
    from pysim import integrators as itg
    from pysim.minimize import gradient, set_coordinates

    n, rods = 40, np.array([1, 4, 5, 17, 30, 39])
    box = np.array([7.0, 6.0, 5.0 if dim == 3 else 1.0])
    periodic = np.array([True, True, dim == 3])
    scale = rng.uniform(0.05, 2.0, len(rods))
    h = 0.37
    zs = rng.normal(0.0, 10.0, n * dim + len(rods) * dim)
    x = np.zeros((n, 3))
    u = np.tile([0.0, 0.0, 1.0], (n, 1))
    w_norm = np.empty(len(rods))
    set_coordinates(zs, h, x, u, rods, scale, dim, box, periodic, w_norm)
    z = h * zs
    x_ref = np.zeros((n, 3))
    x_ref[:, :dim] = z[:n * dim].reshape(n, dim)
    itg.wrap(x_ref, box, periodic)
    w = z[n * dim:].reshape(len(rods), dim) / scale[:, None]
    norm = np.linalg.norm(w, axis=1)
    u_ref = np.tile([0.0, 0.0, 1.0], (n, 1))
    u_ref[rods, :dim] = w / norm[:, None]
    u_ref[rods, dim:] = 0.0
    np.testing.assert_array_equal(x, x_ref)
    np.testing.assert_array_equal(u, u_ref)
    np.testing.assert_array_equal(w_norm, norm)
    assert np.all((x[:, :dim] >= 0) & (x[:, :dim] < box[:dim]))

    f = rng.normal(size=(n, 3))
    torque = rng.normal(size=(n, 3))
    grad = np.empty_like(zs)
    fmax, tmax = gradient(f, torque, u, rods, w_norm, scale, dim, grad)
    g_ref = np.empty_like(zs)
    g_ref[:n * dim] = -f[:, :dim].ravel()
    gw = np.cross(u[rods], torque[rods]) / norm[:, None]
    g_ref[n * dim:] = (gw[:, :dim] / scale[:, None]).ravel()
    np.testing.assert_array_equal(grad, g_ref)
    assert fmax == np.sqrt(np.max(np.sum(f**2, axis=1)))
    assert tmax == np.sqrt(np.max(np.sum(torque**2, axis=1)))
