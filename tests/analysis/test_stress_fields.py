"""Stress tensors of constructed force networks: hydrostatic lattices, a column under
gravity with a floor, uniaxial loads and walls."""
import numpy as np
import pytest

from analysis.contacts import geometric_contacts
from analysis.frame import Contacts
from analysis.stress import (StressField, StressProfile, WallStress, element_trace,
                             major_axis_angle, major_axis_order, particle_major_angles,
                             particle_stress, pressure, principal_stresses, stress_tensor)
from analysis.walls import CylinderWall, PlaneWall, wall_contacts
from tests.analysis.helpers import cubic, frame_of, square


def linear_forces(contacts, k):
    """Repulsive linear forces on i: -k delta n."""
    contacts.force = -k * contacts.overlap[:, None] * contacts.normal
    return contacts


def loaded_lattice(dim, a, k, m):
    """A periodic cubic (square) lattice of ``m^d`` unit spheres (disks) at spacing ``a``
    with linear repulsion ``k``: ``(frame, contacts)``."""
    if dim == 3:
        fr = frame_of(cubic(m, spacing=a) + 0.3, 0.5, [m * a] * 3)
    else:
        fr = frame_of(square(m, spacing=a) + [0.3, 0.3, 0.0], 0.5, [m * a, m * a, 1.0])
    return fr, linear_forces(geometric_contacts(fr, 0.0), k)


def virial_pressure(frame, contacts, dim):
    """P = (1 / (d V)) sum_pairs r_ij . f_ij with r_ij the centre separation and f_ij the
    repulsion along it (independent of the branch-vector bookkeeping)."""
    a = frame.index_of(contacts.i)
    b = frame.index_of(contacts.j)
    r = frame.minimum_image(frame.x[b] - frame.x[a])
    return float(np.sum(np.sum(r * -contacts.force, axis=1)) / (dim * frame.measure))


@pytest.mark.parametrize("dim", [2, 3])
def test_hydrostatic_lattice_is_isotropic_and_equals_the_virial_pressure(dim):
    """A cubic (square) lattice of unit spheres (disks) at spacing 0.98 with linear
    repulsion: sigma = -P I with P the virial pressure f / a^(d-1)."""
    a, k, m = 0.98, 1e4, 5
    fr, c = loaded_lattice(dim, a, k, m)
    assert c.n == dim * m**dim
    f = k * (1 - a)
    p = virial_pressure(fr, c, dim)
    assert p == pytest.approx(f / a ** (dim - 1), rel=1e-12)
    s = stress_tensor(fr, c)
    np.testing.assert_allclose(s[:dim, :dim], -p * np.eye(dim), rtol=1e-12, atol=1e-9 * p)
    assert pressure(fr, c) == pytest.approx(p, rel=1e-12)
    # coarse-grained in slabs one lattice spacing thick, or in elements of two spacings:
    # the same tensor everywhere (each cell holds its share of whole particles)
    prof = StressProfile(thickness=a).compute(fr, c)
    np.testing.assert_allclose(prof.pressure, p, rtol=1e-12)
    np.testing.assert_allclose(prof.k_ratio, 1.0, rtol=1e-12)
    field = StressField(element=m * a / 1).compute(fr, c)
    np.testing.assert_allclose(field.sigma.reshape(-1, 3, 3)[0], s, rtol=1e-12, atol=1e-9 * p)
    vals, _ = principal_stresses(s, dim)
    np.testing.assert_allclose(vals, -p, rtol=1e-12)


def test_column_under_gravity_with_a_floor():
    """Simple cubic stack of unit spheres (4 x 4 columns, 5 layers) on a floor: the bond
    below a sphere of layer j (counted from the top) carries j m g, the floor the whole
    weight. Per layer sigma_zz = -(f_above + f_below) a / 2 / a^3 per sphere;
    sigma_xx = 0; the floor stress is the weight per area."""
    mg, n_layers = 2.0, 5
    x = cubic(0, shape=(4, 4, n_layers)) + 0.5
    fr = frame_of(x, 0.5, [4.0, 4.0, 10.0], periodic=(True, True, False))
    c = geometric_contacts(fr, 1e-9)
    c = Contacts.concatenate([c, wall_contacts(fr, PlaneWall((0, 0, 0), (0, 0, 1)), 1e-9)])
    layer_from_top = n_layers - np.round(x[:, 2] - 0.5).astype(int)  # 1 at the top
    rows = fr.index_of(c.i)
    vertical = np.abs(c.normal[:, 2]) > 0.5
    f = np.zeros((c.n, 3))
    # bond between layer j (above) and j+1, and the floor below layer n: load j m g
    # the bond carries the weight of the upper sphere and all above it: its layer number
    # from the top (the floor: the bottom sphere's)
    upper = layer_from_top[rows].copy()
    pp = np.isin(c.j, fr.ids)
    upper[pp] = np.minimum(upper[pp], layer_from_top[fr.index_of(c.j[pp])])
    load = upper * mg
    f[vertical, 2] = load[vertical] * np.sign(c.normal[vertical, 2])  # pushes i away from j
    c.force = -f  # force on i: against the normal (repulsive)
    # every sphere is in equilibrium: contact forces balance its weight
    net = np.zeros((fr.n, 3))
    np.add.at(net, rows, c.force)
    np.add.at(net, fr.index_of(c.j[pp]), -c.force[pp])
    np.testing.assert_allclose(net[:, 2], mg)
    prof = StressProfile(thickness=1.0, top=float(n_layers)).compute(fr, c)
    j = np.arange(n_layers, 0, -1)  # slab k (from the bottom) holds layer n - k
    expect = -((j - 1) + j) * mg * 0.5
    np.testing.assert_allclose(prof.sigma_vv[:n_layers], expect / 1.0, rtol=1e-12)
    np.testing.assert_allclose(prof.sigma_hh[:n_layers], 0.0, atol=1e-12)
    np.testing.assert_allclose(prof.depth[:n_layers], n_layers - np.arange(n_layers) - 0.5)
    # the grains fill a cross-section of 16: a slab's measure is 16 x thickness however
    # wide the box; the same stack read in a box of twice the area keeps its stresses
    wide = frame_of(x, 0.5, [8.0, 4.0, 10.0], periodic=(False, True, False))
    inner = (x[:, 0] > 0.5) & (x[:, 0] < 3.5)  # bonds across x = 0 would wrap at 8: drop
    keep = np.isin(c.i, fr.ids[inner]) & (np.isin(c.j, fr.ids[inner]) | (c.j <= 0))
    sub = c.subset(np.nonzero(keep)[0])
    a = StressProfile(thickness=1.0, top=float(n_layers)).compute(fr, sub)
    b = StressProfile(thickness=1.0, top=float(n_layers), area=16.0).compute(wide, sub)
    assert np.abs(a.sigma_vv).max() > mg  # the kept bonds still carry load
    np.testing.assert_allclose(b.sigma, a.sigma, rtol=1e-12, atol=1e-12)
    ws = WallStress(PlaneWall((0, 0, 0), (0, 0, 1)), area=16.0).compute(fr, c)
    assert ws.normal_force == pytest.approx(fr.n * mg)
    assert ws.sigma_n == pytest.approx(fr.n * mg / 16.0) and ws.tau == pytest.approx(-fr.n * mg / 16)
    assert ws.n_contacts == 16


def test_uniaxial_load_gives_the_major_axis():
    """Forces only on the bonds along one lattice direction: that direction is the major
    (most compressive) principal axis, in 3-D (vertical) and in 2-D (rotated lattice)."""
    x = cubic(4) + 0.5
    fr = frame_of(x, 0.5, [4.0] * 3)
    c = geometric_contacts(fr, 1e-9)
    c.force = -np.where((np.abs(c.normal[:, 2]) > 0.5)[:, None], c.normal, 0.0)
    s = stress_tensor(fr, c)
    assert major_axis_angle(s, 3) == pytest.approx(np.pi / 2)
    vals, vec = principal_stresses(s, 3)
    assert vals[0] < 0 and vals[1] == pytest.approx(0.0) and abs(vec[2, 0]) == pytest.approx(1.0)
    theta = 0.4
    rot = np.array([[np.cos(theta), -np.sin(theta), 0], [np.sin(theta), np.cos(theta), 0], [0, 0, 1]])
    x2 = (square(6) @ rot.T) + [20.0, 20.0, 0.0]
    fr2 = frame_of(x2, 0.5, [60.0, 60.0, 1.0], periodic=False)
    c2 = geometric_contacts(fr2, 1e-9)
    along = np.abs(c2.normal @ rot[:, 0]) > 0.5
    c2.force = -np.where(along[:, None], c2.normal, 0.0)
    assert major_axis_angle(stress_tensor(fr2, c2), 2) == pytest.approx(theta)
    field = StressField(element=60.0).compute(fr2, c2)
    assert field.major_angle.ravel()[0] == pytest.approx(theta)
    assert field.angle_hist.sum() * np.diff(field.angle_edges)[0] == pytest.approx(1.0)
    assert field.major_order == pytest.approx(-np.cos(2 * theta))
    assert StressField(element=4.0).compute(fr, c).major_order == pytest.approx(1.0)
    assert np.isnan(StressField(element=60.0, min_count=37).compute(fr2, c2).major_order)


@pytest.mark.parametrize("dim", [2, 3])
def test_major_axis_order_of_vertical_horizontal_and_uniform_axes(dim):
    """1 for vertical major axes, -1 (2-D) or -1/2 (3-D) for horizontal ones, and 0 on
    average for directions spread uniformly: over the angle in 2-D, over the sphere in
    3-D (elevation theta with sin(theta) uniform); NaN entries and zero weights do not
    count."""
    assert major_axis_order([np.pi / 2, -np.pi / 2 if dim == 2 else np.pi / 2], dim) == 1.0
    assert major_axis_order([0.0, np.nan], dim) == pytest.approx(-1.0 if dim == 2 else -0.5)
    rng = np.random.default_rng(7)
    uniform = (rng.uniform(-np.pi / 2, np.pi / 2, 200_000) if dim == 2
               else np.arcsin(rng.uniform(0.0, 1.0, 200_000)))
    assert major_axis_order(uniform, dim) == pytest.approx(0.0, abs=0.01)
    assert major_axis_order([np.pi / 2, 0.0], dim, weights=[1.0, 0.0]) == 1.0
    assert np.isnan(major_axis_order([np.nan], dim))


def test_particle_stress_of_wall_rows_and_cylinder_wall_profile():
    """Spheres pressed radially against a cylinder wall with force f each, in two bands:
    the wall's normal stress per band is n f / (2 pi R_c dh)."""
    rc, f = 3.0, 5.0
    ang = np.linspace(0, 2 * np.pi, 12, endpoint=False)
    x = np.vstack([np.column_stack([2.5 * np.cos(ang), 2.5 * np.sin(ang), np.full(12, z)])
                   for z in (0.5, 1.5)]) + [5.0, 5.0, 0.0]
    fr = frame_of(x, 0.5, [10.0, 10.0, 10.0], periodic=False)
    wall = CylinderWall(center=(5.0, 5.0), radius=rc)
    c = wall_contacts(fr, wall, 1e-9)
    assert c.n == 24
    c.force = -f * c.normal
    ws = WallStress(wall, edges=[0.0, 1.0, 2.0, 3.0]).compute(fr, c)
    np.testing.assert_allclose(ws.sigma_n_profile, [12 * f / (2 * np.pi * rc)] * 2 + [0.0])
    np.testing.assert_allclose(ws.force, 0.0, atol=1e-12)
    ps = particle_stress(fr, c)
    # each sphere: l = R n (to the wall), F = -f n: sigma^i = -R f n n
    n0 = c.normal[0]
    np.testing.assert_allclose(ps[fr.index_of(c.i[:1])[0]], -0.5 * f * np.outer(n0, n0), atol=1e-12)


@pytest.mark.parametrize("dim", [2, 3])
def test_slab_stress_errors_are_the_spread_over_columns(dim):
    """``slab_stress_errors``: zero for a uniformly loaded lattice; with random contact
    forces, the standard deviation over the container's columns of the column stresses
    (summed particle stresses over the column's measure, computed here with masks) over
    the square root of the number of columns, for sigma_vv and the mean of sigma_hh."""
    from analysis.stress import slab_stress_errors

    a, k, m = 0.98, 1e4, 8
    fr, c = loaded_lattice(dim, a, k, m)
    v = fr.vertical
    edges = np.array([0.0, 2 * a, 5 * a, m * a])
    cols = 2 if dim == 3 else 4
    vv, hh = slab_stress_errors(fr, c, edges, 0.0, m * a, cols)
    np.testing.assert_allclose(vv, 0.0, atol=1e-9 * k)
    np.testing.assert_allclose(hh, 0.0, atol=1e-9 * k)
    c.force = c.force * np.random.default_rng(3).uniform(0.2, 2.0, size=(c.n, 1))
    vv, hh = slab_stress_errors(fr, c, edges, 0.0, m * a, cols)
    s_i = particle_stress(fr, c)
    horiz = [ax for ax in range(dim) if ax != v]
    col_of = [np.minimum((fr.x[:, ax] / (m * a / cols)).astype(int), cols - 1) for ax in horiz]
    col = col_of[0] if dim == 2 else col_of[0] * cols + col_of[1]
    measure = (m * a / cols) ** (dim - 1)
    for s in range(len(edges) - 1):
        in_slab = (fr.x[:, v] >= edges[s]) & (fr.x[:, v] < edges[s + 1])
        tens = np.array([s_i[in_slab & (col == q)].sum(axis=0) for q in range(cols ** (dim - 1))])
        tens /= measure * (edges[s + 1] - edges[s])
        n = len(tens)
        assert vv[s] == pytest.approx(tens[:, v, v].std(ddof=1) / np.sqrt(n), rel=1e-12)
        t_hh = np.mean([tens[:, ax, ax] for ax in horiz], axis=0)
        assert hh[s] == pytest.approx(t_hh.std(ddof=1) / np.sqrt(n), rel=1e-12)
        assert vv[s] > 0
    with pytest.raises(ValueError, match="columns must be at least 2"):
        slab_stress_errors(fr, c, edges, 0.0, m * a, 1)


def test_element_trace_of_a_hydrostatic_lattice_and_its_counts():
    """In a loaded square lattice every element holding whole particles carries the
    box's trace, -tr sigma = 2 P, and counts its grain centres."""
    a, k, m = 0.98, 1e4, 6
    fr, c = loaded_lattice(2, a, k, m)
    p = virial_pressure(fr, c, 2)
    trace, count = element_trace(fr, c, [0.0, 3 * a, 6 * a], 0.0, m * a, 2)
    assert trace.shape == count.shape == (2, 2)
    np.testing.assert_allclose(trace, 2.0 * p, rtol=1e-12)
    np.testing.assert_array_equal(count, 9)
    with pytest.raises(ValueError, match="columns must be at least 1, got 0"):
        element_trace(fr, c, [0.0, 3 * a], 0.0, m * a, 0)


def test_particle_major_angles_follow_each_grains_load():
    """Grains loaded only along a lattice direction turned by theta have their own major
    axis along it; a grain without contacts has no direction and is left out."""
    theta = 0.4
    rot = np.array([[np.cos(theta), -np.sin(theta), 0], [np.sin(theta), np.cos(theta), 0],
                    [0, 0, 1]])
    x = np.vstack([(square(6) @ rot.T) + [20.0, 20.0, 0.0], [[50.0, 50.0, 0.0]]])
    fr = frame_of(x, 0.5, [60.0, 60.0, 1.0], periodic=False)
    c = geometric_contacts(fr, 1e-9)
    along = np.abs(c.normal @ rot[:, 0]) > 0.5
    c.force = -np.where(along[:, None], c.normal, 0.0)
    ang = particle_major_angles(fr, c)
    assert len(ang) == 36  # the lone grain at (50, 50) is left out
    np.testing.assert_allclose(ang, theta, atol=1e-12)
    assert major_axis_order(ang, 2) == pytest.approx(-np.cos(2 * theta))
