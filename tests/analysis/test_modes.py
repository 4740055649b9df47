"""The analytic Hessian of 2-D packings (:mod:`analysis.modes`) against finite differences
of pysim's own forces and torques, on overlapping rods (end bonds) and disks; the
gradient against the forces; translations as zero modes; the participation ratio and the
mode character on modes built by hand."""
import numpy as np
import pytest

from analysis import modes
from analysis.frame import Frame
from tests.pysim.helpers import overlapping_rods


def frame_of(sim) -> Frame:
    s = sim.state
    return Frame.from_arrays(s.x, s.radius, s.box, axis=s.u, length=s.length,
                             periodic=s.periodic, dimension=2)


def fd_hessian(sim, dof, step=1e-7):
    """Central differences of pysim's generalised forces ``(F_x, F_y, tau_z)``: the slow
    reference."""
    s = sim.state
    x0, u0 = s.x.copy(), s.u.copy()

    def q():
        sim.compute_forces()
        return np.where(dof[:, 1] < 2, sim.f[dof[:, 0], np.minimum(dof[:, 1], 1)],
                        sim.torque[dof[:, 0], 2])

    h = np.empty((len(dof), len(dof)))
    for b, (i, c) in enumerate(dof):
        out = []
        for sign in (1.0, -1.0):
            if c < 2:
                s.x[i, c] = x0[i, c] + sign * step
            else:
                a = sign * step
                s.u[i, 0] = u0[i, 0] * np.cos(a) - u0[i, 1] * np.sin(a)
                s.u[i, 1] = u0[i, 0] * np.sin(a) + u0[i, 1] * np.cos(a)
            out.append(q())
            s.x[:] = x0
            s.u[:] = u0
        h[:, b] = -(out[0] - out[1]) / (2 * step)
    sim.compute_forces()
    return h


@pytest.mark.parametrize("alpha, spine_contact", [(1.0, "end_bonds"), (1.0, "end_bonds_distinct"),
                                                  (0.0, "closest")])
def test_hessian_matches_finite_differences_of_the_forces(alpha, spine_contact):
    sim = overlapping_rods(2, 30, alpha, 0.9, 4, spine_contact)
    frame = frame_of(sim)
    ij, rec = sim.contact_table()
    assert len(ij) > 20 and rec[:, 6].max() > 1e-2  # a dense, overlapping packing
    dof = modes.dofs(frame)
    assert len(dof) == (3 if alpha > 0 else 2) * 30
    distinct = spine_contact == "end_bonds_distinct"
    hk, hs, grad = modes.hessian_parts(frame, ij, dof, k_n=1.0, end_bonds=alpha > 0,
                                       distinct=distinct)
    if distinct:  # the packing has repeated bonds (tip-tip contacts) that this leaves out
        hk4, _, _ = modes.hessian_parts(frame, ij, dof, k_n=1.0, end_bonds=True)
        assert np.abs(hk4 - hk).max() > 0.1 * np.abs(hk).max()
    sim.compute_forces()
    gen = np.where(dof[:, 1] < 2, sim.f[dof[:, 0], np.minimum(dof[:, 1], 1)],
                   sim.torque[dof[:, 0], 2])
    np.testing.assert_allclose(grad, -gen, atol=1e-12 * np.abs(gen).max())
    h = hk + hs
    ref = fd_hessian(sim, dof)
    assert np.abs(h - ref).max() < 1e-6 * np.abs(ref).max()
    np.testing.assert_allclose(h, h.T, atol=1e-12)
    # the stress part carries the bond forces: it is of their order, the stiffness part of k_n
    assert 0 < np.abs(hs).max() < 0.5 * np.abs(hk).max()
    # rigid translations cost nothing in a periodic box
    for c in (0, 1):
        shift = (dof[:, 1] == c).astype(float)
        assert np.abs(h @ shift).max() < 1e-12 * np.abs(h).max()


def test_disk_stress_part_is_minus_force_over_distance_across_the_normal():
    """Two overlapping disks: ``H_s`` on disk i is ``-(f/D)(1 - n n^T)``."""
    frame = Frame.from_arrays([[0.0, 0.0], [0.9, 0.3]], [0.5, 0.5], [10.0, 10.0, 0.0],
                              periodic=(True, True, False), dimension=2)
    dof = modes.dofs(frame)
    hk, hs, _ = modes.hessian_parts(frame, [[0, 1]], dof, k_n=2.0, end_bonds=False)
    dist = np.hypot(0.9, 0.3)
    n = np.array([0.9, 0.3]) / dist
    f = 2.0 * (1.0 - dist) / 1.0**2
    np.testing.assert_allclose(hs[:2, :2], -(f / dist) * (np.eye(2) - np.outer(n, n)),
                               atol=1e-15)
    np.testing.assert_allclose(hk[:2, :2], 2.0 * np.outer(n, n), atol=1e-15)
    np.testing.assert_allclose(hs[:2, 2:], -hs[:2, :2], atol=1e-15)


def test_participation_ratio_and_character_of_hand_built_modes():
    dof = np.array([(0, 0), (0, 1), (0, 2), (1, 0), (1, 1), (1, 2)])
    axis = np.array([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])
    one = np.zeros(6)
    one[2] = 1.0  # rotation of particle 0 alone
    spread = np.array([1.0, 0.0, 0.0, 1.0, 0.0, 0.0]) / np.sqrt(2)  # both move along x
    vecs = np.column_stack([one, spread])
    np.testing.assert_allclose(modes.participation_ratio(vecs, dof), [0.5, 1.0])
    ch = modes.mode_character(vecs, dof, axis)
    np.testing.assert_allclose(ch[0], [1.0, 0.0, 0.0])
    # along x: parallel to particle 0's spine, perpendicular to particle 1's
    np.testing.assert_allclose(ch[1], [0.0, 0.5, 0.5])
    w2, v = modes.normal_modes(np.diag([4.0, 1.0, 9.0, 4.0, 1.0, 9.0]), np.array(
        [1.0, 1.0, 9.0, 4.0, 4.0, 9.0]))
    np.testing.assert_allclose(w2, [0.25, 1.0, 1.0, 1.0, 1.0, 4.0])


def test_bands_split_at_the_widest_gaps_of_log_omega():
    rng = np.random.default_rng(3)
    low = 10 ** rng.uniform(-8, -7, 40)  # omega^2
    middle = 10 ** rng.uniform(-4.5, -4, 7)
    high = 10 ** rng.uniform(-2, 0, 200)
    w2 = rng.permutation(np.concatenate([[0.0, -1e-17, 1e-15], low, middle, high]))
    zero = 1e-12
    three = modes.bands(w2, 3, zero)
    assert np.sum(three == -1) == 3
    assert [np.sum(three == k) for k in range(3)] == [40, 7, 200]
    assert np.all(three[np.isin(w2, middle)] == 1)
    # two bands: the gap between low and middle (3 decades of omega^2) is the widest
    two = modes.bands(w2, 2, zero)
    assert [np.sum(two == k) for k in range(2)] == [40, 207]
    # a lone mode inside a gap halves it: it joins the nearer side of the wider half
    lone = modes.bands(np.concatenate([low, [1e-3], high]), 2, zero)
    assert [np.sum(lone == k) for k in range(2)] == [40, 201]


def test_a_floor_band_holds_the_modes_below_the_resolution():
    rng = np.random.default_rng(4)
    floor = np.concatenate([[0.0, 1e-17], rng.uniform(-1e-15, 1e-15, 30)])  # translations, noise
    middle = 10 ** rng.uniform(-9.5, -9, 3)
    high = 10 ** rng.uniform(-3, 0, 100)
    w2 = rng.permutation(np.concatenate([floor, middle, high]))
    three = modes.bands(w2, 3, 1e-12, floor=True)
    # every mode has a band: the fractions sum to one, as the paper's do
    assert [np.sum(three == k) for k in range(3)] == [32, 3, 100]
    assert np.all(three[np.isin(w2, middle)] == 1)
    # without the floor the noise is left out of every band
    plain = modes.bands(w2, 3, 1e-12)
    assert np.sum(plain == -1) == 32 and np.sum(plain >= 0) == 103
    assert np.all(modes.bands(w2, 1, 1e-12, floor=True) == 0)


def test_bands_refuse_more_bands_than_modes():
    with pytest.raises(ValueError, match="n_bands must be at least 1"):
        modes.bands(np.ones(3), 0, 1e-12)
    with pytest.raises(ValueError, match="2 nonzero modes cannot form 3 bands"):
        modes.bands(np.array([0.0, 1.0, 2.0]), 3, 1e-12)


def test_band_means_follow_the_stable_states_band_sizes():
    w2 = np.array([0.0, 1e-16, 4.0, 1e-4, 1e-2, 9.0, 4e-4, 1.0])
    # after the two lowest (skipped): omega 1e-2, 2e-2, 0.1, 1, 2, 3
    np.testing.assert_allclose(modes.band_means(w2, [2, 1], 1e-12, skip=2), [0.015, 0.1])
    np.testing.assert_allclose(modes.band_means(w2, [3, 3], 1e-12, skip=2), [0.13 / 3, 2.0])
    with pytest.raises(ValueError, match=r"band sizes \[4, 3\] do not fit 6 modes"):
        modes.band_means(w2, [4, 3], 1e-12, skip=2)
    # a group mostly below the resolution has no mean; one mostly above counts the
    # unresolved modes as omega = 0; an empty group has none
    means = modes.band_means(w2, [2, 3, 0], 1e-12)
    assert np.isnan(means[0]) and np.isnan(means[2])
    np.testing.assert_allclose(means[1], (1e-2 + 2e-2 + 0.1) / 3)
    assert np.isnan(modes.band_means(w2, [3], 1e-12)[0])
    np.testing.assert_allclose(modes.band_means(w2, [4], 1e-12), [0.03 / 4])
