"""Orientational order: limit cases (aligned, random, square lattices) and invariants."""
import numpy as np
import pytest

from analysis.order import (AngleToHorizontal, NematicOrder, OrientationCorrelation,
                            OrientationOrder2D, correlation_amplitude, correlation_peak,
                            order_parameter_2d, orientation_mode, q_tensor,
                            standing_fraction)
from tests.analysis.helpers import cubic, frame_of, random_unit, square


def rods_2d(x, theta, box=10.0, length=1.0):
    u = np.column_stack([np.cos(theta), np.sin(theta), np.zeros(len(theta))])
    return frame_of(x, 0.1, [box, box, 1.0], axis=u, length=length, dimension=2)


def test_aligned_rods_have_unit_order_and_the_uniaxial_tensor(rng):
    n = 50
    x = rng.uniform(0, 10, size=(n, 3))
    fr3 = frame_of(x, 0.2, [10.0] * 3, axis=[1.0, 0, 0], length=2.0)
    nem = NematicOrder().compute(fr3)
    np.testing.assert_allclose(nem.Q, np.diag([1.0, -0.5, -0.5]), atol=1e-14)
    assert nem.S == pytest.approx(1.0)
    assert abs(nem.director @ [1, 0, 0]) == pytest.approx(1.0)
    # head-tail symmetry: flipping half of the rods changes nothing
    u = np.tile([1.0, 0, 0], (n, 1))
    u[::2] *= -1
    fr3b = frame_of(x, 0.2, [10.0] * 3, axis=u, length=2.0)
    np.testing.assert_allclose(NematicOrder().compute(fr3b).Q, nem.Q, atol=1e-14)
    x2 = x.copy()
    x2[:, 2] = 0
    o = OrientationOrder2D().compute(rods_2d(x2, np.full(n, 0.3)))
    assert o.S2 == pytest.approx(1.0) and o.S4 == pytest.approx(1.0)
    assert o.psi2 == pytest.approx(0.3) and o.sqrtN_S2 == pytest.approx(np.sqrt(n))


def test_noisy_alignment_orders_less_than_one(rng):
    theta = rng.normal(0, 0.3, 400)
    s2, psi = order_parameter_2d(theta, 2)
    assert 0.7 < s2 < 1.0
    assert s2 == pytest.approx(np.exp(-2 * 0.3**2), abs=0.05)  # <cos 2 theta> of a Gaussian
    assert abs(psi) < 0.05


def test_random_orientations_give_order_of_one_over_sqrt_n(rng):
    """Independent uniform angles: E[N S_n^2] = 1 exactly, so sqrt(N) S_n is O(1)."""
    n, samples = 200, 400
    s2 = np.array([order_parameter_2d(rng.uniform(0, 2 * np.pi, n), 2)[0] for _ in range(samples)])
    s4 = np.array([order_parameter_2d(rng.uniform(0, 2 * np.pi, n), 4)[0] for _ in range(samples)])
    for s in (s2, s4):
        assert np.mean(n * s**2) == pytest.approx(1.0, abs=0.15)  # sd of the mean ~ 0.05
        assert np.mean(np.sqrt(n) * s) == pytest.approx(np.sqrt(np.pi) / 2, abs=0.05)  # Rayleigh
    # 3-D: Q of random unit vectors shrinks like 1/sqrt(N)
    s_small = np.mean([NematicOrder().compute(frame_of(np.zeros((50, 3)), 0.1, [5.0] * 3,
                       axis=random_unit(rng, 50), length=1.0)).S for _ in range(50)])
    s_large = np.mean([NematicOrder().compute(frame_of(np.zeros((800, 3)), 0.1, [5.0] * 3,
                       axis=random_unit(rng, 800), length=1.0)).S for _ in range(50)])
    assert s_small / s_large == pytest.approx(4.0, rel=0.25)


def test_square_lattice_tetratic_order_and_correlation():
    """Aligned rods on a square lattice: S2 = S4 = 1 and Q(r) = 1. A checkerboard of rods
    at 0 and 90 degrees: no nematic order (S2 = 0) but perfect tetratic order (S4 = 1);
    nearest neighbours are perpendicular (Q = -1), diagonal ones parallel (Q = +1)."""
    m = 8
    x = square(m) + [0.5, 0.5, 0.0]
    aligned = rods_2d(x, np.zeros(m * m), box=m, length=0.5)
    o = OrientationOrder2D().compute(aligned)
    assert o.S2 == pytest.approx(1.0) and o.S4 == pytest.approx(1.0)
    qc = OrientationCorrelation(r_max=2.0, bins=20).compute(aligned)
    np.testing.assert_allclose(qc.q[qc.counts > 0], 1.0)
    ij = np.round(x[:, :2] - 0.5).astype(int)
    theta = np.where((ij[:, 0] + ij[:, 1]) % 2 == 0, 0.0, np.pi / 2)
    checker = rods_2d(x, theta, box=m, length=0.5)
    o = OrientationOrder2D().compute(checker)
    assert o.S2 == pytest.approx(0.0, abs=1e-12) and o.S4 == pytest.approx(1.0)
    qc = OrientationCorrelation(r_max=1.6, bins=16).compute(checker)
    k1 = np.searchsorted(qc.edges, 1.0, side="right") - 1
    k2 = np.searchsorted(qc.edges, np.sqrt(2), side="right") - 1
    assert qc.q[k1] == pytest.approx(-1.0) and qc.counts[k1] == 2 * m * m
    assert qc.q[k2] == pytest.approx(1.0) and qc.counts[k2] == 2 * m * m
    # a global rotation leaves S_n unchanged and turns the director
    rot = rods_2d(x, theta + 0.2, box=m, length=0.5)
    o2 = OrientationOrder2D().compute(rot)
    assert o2.S4 == pytest.approx(1.0) and o2.psi4 == pytest.approx(0.2)


def test_q_tensor_invariants(rng):
    u = random_unit(rng, 30)
    q = q_tensor(u)
    assert np.trace(q) == pytest.approx(0.0, abs=1e-14)
    np.testing.assert_allclose(q, q.T)
    r, _ = np.linalg.qr(rng.normal(size=(3, 3)))
    np.testing.assert_allclose(np.linalg.eigvalsh(q_tensor(u @ r.T)), np.linalg.eigvalsh(q),
                               atol=1e-13)


def test_order_relative_to_gravity_and_angle_to_horizontal(rng):
    x = rng.uniform(0, 10, size=(40, 3))
    up = frame_of(x, 0.2, [10.0] * 3, axis=[0, 0, 1.0], length=1.0)
    flat = frame_of(x, 0.2, [10.0] * 3, axis=[1.0, 1.0, 0], length=1.0)
    assert NematicOrder().compute(up).gravity_order == pytest.approx(1.0)
    assert NematicOrder().compute(flat).gravity_order == pytest.approx(-0.5)
    assert AngleToHorizontal().compute(up).mean_deg == pytest.approx(90.0)
    assert AngleToHorizontal().compute(flat).mean == pytest.approx(0.0)
    # isotropic rods: f(beta) = cos(beta), <beta> = pi/2 - 1 (i.e. 32.7 degrees)
    n = 20000
    iso = frame_of(rng.uniform(0, 10, (n, 3)), 0.2, [10.0] * 3, axis=random_unit(rng, n), length=1.0)
    a = AngleToHorizontal(bins=9).compute(iso)
    mid = 0.5 * (a.edges[1:] + a.edges[:-1])
    exact = (np.sin(a.edges[1:]) - np.sin(a.edges[:-1])) / np.diff(a.edges)
    np.testing.assert_allclose(a.density, exact, atol=0.05)
    assert a.mean == pytest.approx(np.pi / 2 - 1, abs=0.01)
    assert np.all(np.isfinite(mid))


def test_mean_angle_by_layer():
    """Upright rods in the lower layer, flat rods in the upper one."""
    x = cubic(0, shape=(3, 3, 2), spacing=2.0) + 1.0
    u = np.where((x[:, 2] < 2)[:, None], [0, 0, 1.0], [1.0, 0, 0])
    fr = frame_of(x, 0.2, [6.0, 6.0, 4.0], axis=u, length=1.0, periodic=(True, True, False))
    a = AngleToHorizontal(layers=[0, 2, 4, 6]).compute(fr)
    np.testing.assert_allclose(a.layer_mean[:2], [np.pi / 2, 0.0])
    assert np.isnan(a.layer_mean[2]) and a.layer_count.tolist() == [9, 9, 0]
    assert a.mean == pytest.approx(np.pi / 4)


def test_three_dimensional_orientation_correlation_of_a_lattice():
    """Layers of rods along x and along z alternating in z: of the 6 neighbours at
    distance 2, the 4 in the same layer are parallel (P2 = 1) and the 2 above and below
    perpendicular (P2 = -1/2): Q = (4 - 1) / 6 = 1/2; second neighbours along z at
    distance 4 are beyond r_max, those at 2 sqrt(2) mix: 4 parallel, 8 perpendicular."""
    x = cubic(4, spacing=2.0) + 1.0
    layer = np.round((x[:, 2] - 1.0) / 2).astype(int)
    u = np.where((layer % 2 == 0)[:, None], [1.0, 0, 0], [0, 0, 1.0])
    fr = frame_of(x, 0.2, [8.0] * 3, axis=u, length=1.0)
    qc = OrientationCorrelation(r_max=3.0, bins=6).compute(fr)
    k = np.searchsorted(qc.edges, 2.0, side="right") - 1
    assert qc.counts[k] == 3 * len(x)
    assert qc.q[k] == pytest.approx(0.5)
    k2 = np.searchsorted(qc.edges, 2 * np.sqrt(2), side="right") - 1
    assert qc.counts[k2] == 6 * len(x)
    assert qc.q[k2] == pytest.approx((4 * 1.0 + 8 * -0.5) / 12, abs=1e-12)


def test_2d_order_refuses_3d_frames():
    fr = frame_of([[1, 1, 1.0]], 0.2, [5.0] * 3, axis=[1.0, 0, 0.5], length=1.0)
    with pytest.raises(ValueError, match="2-D frame"):
        OrientationOrder2D().compute(fr)


def test_finite_size_order_separates_disorder_from_order(rng):
    """``finite_size_order`` takes one sample per run (the mean over its dense frames):
    runs of independent uniform angles give ``sqrt(N) S_n`` with rms 1 and mean
    ``sqrt(pi)/2`` at every N, so ``<S_2>`` falls as ``1/sqrt(N)``; runs of rods aligned
    within a fixed spread keep ``S_2`` (``sqrt(N) S_2`` grows as ``sqrt(N)``). Frames
    below ``phi_min`` and frames without rods (NaN order) are left out."""
    import pandas as pd

    from analysis.order import finite_size_order

    rows = []
    for n in (256, 1024, 4096):
        for seed in range(400):
            for alpha, theta in ((1.0, rng.uniform(0, 2 * np.pi, n)),
                                 (4.0, rng.normal(0.0, 0.5, n))):
                s2 = order_parameter_2d(theta, 2)[0]
                s4 = order_parameter_2d(theta, 4)[0]
                for phi in (0.75, 0.8):  # two frames of one run: the same orientations
                    rows.append({"alpha": alpha, "n": n, "seed": seed, "phi": phi,
                                 "sqrt_n_s2": np.sqrt(n) * s2, "sqrt_n_s4": np.sqrt(n) * s4})
    rows.append({"alpha": 1.0, "n": 256, "seed": 0, "phi": 0.5, "sqrt_n_s2": 50.0,
                 "sqrt_n_s4": 50.0})  # dilute: below phi_min
    rows.append({"alpha": 1.0, "n": 256, "seed": 0, "phi": 0.8, "sqrt_n_s2": np.nan,
                 "sqrt_n_s4": np.nan})
    t = finite_size_order(pd.DataFrame(rows), phi_min=0.7).set_index(["alpha", "n"])
    assert list(t.loc[1.0].seeds) == [400] * 3 and list(t.loc[1.0].frames) == [800] * 3
    for n in (256, 1024, 4096):
        # 400 samples: the rms of N S^2 (mean 1, sd 1) is 1 within some 0.1
        for m in ("s2", "s4"):
            assert t.loc[(1.0, n), f"rms_sqrt_n_{m}"] == pytest.approx(1.0, abs=0.1)
            assert t.loc[(1.0, n), f"mean_sqrt_n_{m}"] == pytest.approx(np.sqrt(np.pi) / 2,
                                                                        abs=0.08)
            # standard error of a Rayleigh sample: sqrt((4 - pi)/4 / 400)
            assert t.loc[(1.0, n), f"sem_sqrt_n_{m}"] == pytest.approx(
                np.sqrt((4 - np.pi) / 4 / 400), rel=0.15)
        # a Gaussian spread of 0.5 rad: S_2 = exp(-2 0.5^2) at every N
        assert t.loc[(4.0, n), "mean_s2"] == pytest.approx(np.exp(-0.5), abs=0.02)
    assert t.loc[(1.0, 256), "mean_s2"] / t.loc[(1.0, 4096), "mean_s2"] == \
        pytest.approx(4.0, rel=0.15)
    assert t.loc[(4.0, 4096), "mean_sqrt_n_s2"] / t.loc[(4.0, 256), "mean_sqrt_n_s2"] == \
        pytest.approx(4.0, rel=0.05)


def test_orientation_mode_and_standing_fraction():
    """The mode is the centre of the fullest 5-degree bin; standing means within 15
    degrees of the vertical."""
    flat = np.radians([1.0, 2.0, 3.0, 4.0, 7.0, 50.0, 89.0])
    assert orientation_mode(flat) == pytest.approx(2.5)
    tilted = np.radians([48.0, 51.0, 52.0, 53.0, 5.0, 88.0])
    assert orientation_mode(tilted) == pytest.approx(52.5)
    assert orientation_mode(np.radians([10.0, 80.0])) == pytest.approx(12.5)  # tie: lower
    assert orientation_mode(np.radians([90.0]), bins=9) == pytest.approx(85.0)
    assert standing_fraction(np.radians([0.0, 74.0, 76.0, 90.0])) == pytest.approx(0.5)
    assert standing_fraction(np.radians([0.0, 74.0, 76.0, 90.0]), within=20.0) == 0.75
    with pytest.raises(ValueError, match="undefined"):
        orientation_mode([])
    with pytest.raises(ValueError, match="undefined"):
        standing_fraction([])


def test_correlation_peak_and_amplitude():
    r = np.arange(0.125, 12.0, 0.25)
    bump = 0.3 + 0.2 * np.exp(-((r - 5.125) / 0.4) ** 2)
    assert correlation_peak(r, bump, 3.75, 6.25) == pytest.approx(5.125)
    # a curve running down through the window has no peak there, nor one with too few shells
    assert np.isnan(correlation_peak(r, 1.0 / r, 3.75, 6.25))
    assert np.isnan(correlation_peak(r, bump, 4.9, 5.2))
    # a bump no taller than twice its standard error is not a peak
    assert np.isnan(correlation_peak(r, bump, 3.75, 6.25, err=np.full(len(r), 0.15)))
    assert correlation_peak(r, bump, 3.75, 6.25, err=np.full(len(r), 0.05)) == pytest.approx(5.125)
    # empty shells are skipped
    holes = bump.copy()
    holes[::2] = np.nan
    assert np.isfinite(correlation_peak(r, holes, 3.75, 6.25))
    wave = np.cos(r)
    assert correlation_amplitude(r, wave, 1.5, 11.0) == pytest.approx(2.0, abs=0.01)
    assert correlation_amplitude(r, wave, 1.5, 2.9) == pytest.approx(
        np.cos(1.625) - np.cos(2.875))
    assert np.isnan(correlation_amplitude(r, np.full(len(r), np.nan), 1.5, 11.0))
    with pytest.raises(ValueError, match="lo < hi"):
        correlation_amplitude(r, wave, 3.0, 2.0)


def test_orientation_correlation_standard_error(rng):
    """q_err is the standard error of the pairs' values in each shell, computed directly."""
    n = 300
    x = np.column_stack([rng.uniform(0, 10, n), rng.uniform(0, 10, n), np.zeros(n)])
    theta = rng.uniform(0, np.pi, n)
    fr = rods_2d(x, theta)
    qc = OrientationCorrelation(r_max=2.0, bins=4).compute(fr)
    d = x[:, None, :2] - x[None, :, :2]
    d -= 10.0 * np.round(d / 10.0)
    r = np.linalg.norm(d, axis=2)
    val = np.cos(2 * (theta[:, None] - theta[None, :]))
    iu = np.triu_indices(n, 1)
    r, val = r[iu], val[iu]
    for k in range(4):
        v = val[(r >= qc.edges[k]) & (r < qc.edges[k + 1])]
        assert qc.counts[k] == len(v)
        assert qc.q[k] == pytest.approx(v.mean())
        assert qc.q_err[k] == pytest.approx(v.std(ddof=1) / np.sqrt(len(v)))
