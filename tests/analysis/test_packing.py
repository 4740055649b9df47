"""Packing fraction: global, slab profiles, layers and the filled part of a container."""
import numpy as np
import pytest

from analysis.frame import Frame
from analysis.packing import (EnclosingPackingFraction, FilledPackingFraction, PackingProfile,
                              bed_grains, cumulative_measure, layer_edges, period_average,
                              packing_fraction, profile_change, slab_packing_fraction,
                              surface_height)
from tests.analysis.helpers import cubic, frame_of, random_unit, square


def test_cubic_lattice_profile_is_flat_at_pi_over_6():
    """Spheres of diameter 1 on a unit cubic lattice: phi = pi/6 globally and in every
    slab whose edges sit at the centre planes or between layers (each sphere splits
    symmetrically), whatever the slab thickness in multiples of 1/2."""
    x = cubic(4) + 0.5
    fr = frame_of(x, 0.5, [4.0, 4.0, 4.0], periodic=(True, True, False))
    assert packing_fraction(fr) == pytest.approx(np.pi / 6)
    for t in (0.5, 1.0, 2.0):
        prof = PackingProfile(thickness=t).compute(fr)
        np.testing.assert_allclose(prof.phi, np.pi / 6, rtol=1e-12)
    # a slab through the sphere equators [0.25, 0.75] holds 2 (caps of height 0.25)
    cap = np.pi * 0.25**2 * (3 * 0.5 - 0.25) / 3
    inner = np.pi / 6 / 2 - cap  # half sphere minus the cap below 0.25
    phi = slab_packing_fraction(fr, [0.25, 0.75])
    assert phi[0] == pytest.approx(16 * 2 * inner / (16 * 0.5))


def test_slabs_sum_to_the_grains_and_wrap_periodically(rng):
    n = 60
    x = rng.uniform(0, 8, size=(n, 3))
    u = random_unit(rng, n)
    fr = frame_of(x, 0.3, [8.0, 8.0, 8.0], axis=u, length=rng.uniform(0, 2, n))
    edges = np.linspace(0, 8, 17)
    prof = PackingProfile(edges=edges).compute(fr)
    # periodic z: every grain's volume lies in exactly one box period
    assert prof.grain_measure.sum() == pytest.approx(fr.particle_volumes().sum(), rel=1e-12)
    # shifting everything by a period along z changes nothing
    fr2 = frame_of(x + [0, 0, 8.0], 0.3, [8.0, 8.0, 8.0], axis=u, length=fr.length)
    np.testing.assert_allclose(PackingProfile(edges=edges).compute(fr2).phi, prof.phi,
                               rtol=1e-10, atol=1e-14)


def test_slab_fraction_of_a_random_rod_against_sampling(rng):
    u = random_unit(rng, 1)
    fr = frame_of([[2.0, 2.0, 2.0]], 0.4, [4.0, 4.0, 4.0], axis=u, length=[2.0],
                  periodic=(True, True, False))
    edges = np.array([0.5, 1.5, 2.2, 3.5])
    got = slab_packing_fraction(fr, edges) * 16 * np.diff(edges)
    from analysis.geometry import inside
    p = rng.uniform([0.5, 0.5, 0.5], [3.5, 3.5, 3.5], size=(400_000, 3))
    ins = inside(p, fr.x[0], fr.axis[0], 0.4, 2.0)
    k = np.searchsorted(edges, p[:, 2]) - 1
    for s in range(3):
        frac = np.mean(ins & (k == s))
        assert got[s] == pytest.approx(27 * frac, abs=4 * 27 * np.sqrt(frac / len(p)) + 1e-12)


def test_upright_rods_fill_their_layers_and_the_filled_part():
    """Upright rods (D = 1, L = 2) on a unit square grid standing on z = 0: tops at 3.
    The filled part is [0, 3]; its fraction is V / 3 = (pi/4 * 2 + pi/6) / 3."""
    xy = cubic(0, shape=(5, 5, 1)) + [0.5, 0.5, 1.5]
    fr = frame_of(xy, 0.5, [5.0, 5.0, 10.0], axis=[0, 0, 1.0], length=2.0,
                  periodic=(True, True, False))
    v = np.pi / 4 * 2 + np.pi / 6
    f = FilledPackingFraction().compute(fr)
    assert f.top == pytest.approx(3.0) and f.height == pytest.approx(3.0)
    assert f.phi == pytest.approx(v / 3)
    assert surface_height(fr, method="max") == pytest.approx(3.0)
    # layers: the cylinder part [0.5, 2.5] is at pi/4
    phi = slab_packing_fraction(fr, layer_edges(0.5, 1.0, 2))
    np.testing.assert_allclose(phi, np.pi / 4, rtol=1e-12)
    # a container of given cross-section area scales the fraction
    assert FilledPackingFraction(area=50.0).compute(fr).phi == pytest.approx(v * 25 / (50 * 3))


def test_filled_part_ignores_empty_columns_and_counts_only_grains_below_the_top():
    """One tall rod sticking out of a flat bed: the column surface averages it with the
    bed columns, and its part above the surface is not counted."""
    xy = cubic(0, shape=(4, 4, 1)) + [0.5, 0.5, 0.5]
    x = np.vstack([xy, [[0.5, 0.5, 2.5]]])
    ln = np.r_[np.zeros(16), 2.0]
    fr = frame_of(x, 0.5, [4.0, 4.0, 10.0], axis=[0, 0, 1.0], length=ln,
                  periodic=(True, True, False))
    top = surface_height(fr, column=1.0)
    assert top == pytest.approx((15 * 1.0 + 4.0) / 16)
    f = FilledPackingFraction(column=1.0).compute(fr)
    below = cumulative_measure(fr, [top])[0]
    assert f.grain_measure == pytest.approx(below)
    assert below < fr.particle_volumes().sum()


def test_enclosing_cylinder_leaves_out_grains_above_a_gap():
    """Pournin et al.'s density: upright rods (D = 1, L = 2) standing on z = 0.7 fill
    [0.7, 3.7]; a sphere flying clear above them is an outlier, one reaching into the
    bed's height range is not and raises the top to its own."""
    xy = cubic(0, shape=(5, 5, 1)) + [0.5, 0.5, 2.2]
    v = np.pi / 4 * 2 + np.pi / 6
    sphere = np.pi / 6

    def frame(extra):
        x = np.vstack([xy, extra]) if len(extra) else xy
        ln = np.r_[np.full(25, 2.0), np.zeros(len(extra))]
        return frame_of(x, 0.5, [5.0, 5.0, 10.0], axis=[0, 0, 1.0], length=ln,
                        periodic=(True, True, False))

    bed = EnclosingPackingFraction(area=25.0).compute(frame([]))
    assert (bed.bottom, bed.top, bed.outliers) == (pytest.approx(0.7), pytest.approx(3.7), 0)
    assert bed.phi == pytest.approx(25 * v / (25 * 3.0))
    fly = frame([[2.5, 2.5, 5.0], [1.5, 1.5, 4.3]])  # [4.5, 5.5] and [3.8, 4.8]: one chain
    assert list(bed_grains(fly)) == [True] * 25 + [False, False]
    f = EnclosingPackingFraction(area=25.0).compute(fly)
    assert f.outliers == 2 and f.phi == pytest.approx(bed.phi) and f.top == pytest.approx(3.7)
    reach = EnclosingPackingFraction(area=25.0).compute(frame([[2.5, 2.5, 4.1]]))  # [3.6, 4.6]
    assert reach.outliers == 0 and reach.top == pytest.approx(4.6)
    assert reach.phi == pytest.approx((25 * v + sphere) / (25 * 3.9))
    # the default area is the box cross-section; an empty frame has no cylinder
    assert EnclosingPackingFraction().compute(frame([])).phi == pytest.approx(bed.phi)
    with pytest.raises(ValueError, match="no particles"):
        EnclosingPackingFraction().compute(frame([]).subset(np.zeros(25, bool)))


def test_two_dimensional_profile_of_a_disk_lattice():
    x = square(6) + [0.5, 0.5, 0.0]
    fr = frame_of(x, 0.5, [6.0, 6.0, 1.0], periodic=(True, False, True))
    assert fr.dim == 2 and fr.vertical == 1
    assert packing_fraction(fr) == pytest.approx(np.pi / 4)
    np.testing.assert_allclose(PackingProfile(thickness=0.5).compute(fr).phi, np.pi / 4)


def test_period_average_and_errors():
    np.testing.assert_allclose(period_average([1, 2, 3, 4, 5], 3), [1.5, 2, 3, 4, 4.5])
    # empty layers (NaN) are left out of the window, not spread over it
    np.testing.assert_allclose(period_average([1, np.nan, 3, np.nan, np.nan, np.nan], 3),
                               [1, 2, 3, 3, np.nan, np.nan])
    np.testing.assert_allclose(period_average([2.0], 4), [2.0])  # shorter than a period
    with pytest.raises(ValueError, match=">= 1"):
        period_average([1, 2], 0)
    # one period of any periodic signal averages to its mean, for even and odd sampling
    for f in (3, 4):
        sig = np.tile(np.random.default_rng(f).normal(size=f), 6)
        np.testing.assert_allclose(period_average(sig, f)[f:-f], sig[:f].mean())
    np.testing.assert_allclose(period_average([1.0, np.nan, 3.0, 5.0], 2), [1, 2, 11 / 3, 13 / 3])
    fr = frame_of([[0.5, 0.5, 0.5]], 0.5, [1.0, 1.0, 1.0])
    with pytest.raises(ValueError, match="strictly increasing"):
        slab_packing_fraction(fr, [1.0, 0.5])
    with pytest.raises(ValueError, match="exactly one"):
        PackingProfile()


def test_frame_dimension_inference():
    x3 = np.array([[0.5, 0.5, 0.5], [1.5, 0.5, 0.0]])
    assert Frame.from_arrays(x3, 0.5, [2.0, 2.0, 2.0]).dim == 3
    rods2d = Frame.from_arrays([[0.5, 0.5], [1.5, 0.5]], 0.5, [2.0, 2.0], axis=[[1, 0], [0, 1]],
                               length=1.0)
    assert rods2d.dim == 2 and rods2d.measure == 4.0
    tilted = Frame.from_arrays(np.zeros((1, 3)), 0.5, [2.0] * 3, axis=[[1, 0, 1]], length=1.0)
    assert tilted.dim == 3


def test_profile_change_fits_the_middle_of_the_deposit():
    """The rise of a straight-line fit over 10-90 % of the height; the base's ordered layer
    and the loose top do not count."""
    y = np.linspace(0.25, 9.75, 20)
    phi = 0.6 + 0.05 * y / 10.0
    assert profile_change(y, phi, top=10.0) == pytest.approx(0.05 * 0.8)
    flat = np.full(20, 0.6)
    flat[0], flat[-1] = 0.9, 0.2  # outside the middle 80 %
    assert profile_change(y, flat, top=10.0) == pytest.approx(0.0, abs=1e-12)
    assert profile_change(y, flat, top=10.0, inner=(0.0, 1.0)) < -0.1
    assert np.isnan(profile_change(y[:2], phi[:2], top=10.0))
    with pytest.raises(ValueError, match="inner"):
        profile_change(y, phi, top=10.0, inner=(0.9, 0.1))
