"""Contacts of spherocylinders: geometry against brute force, lattices at contact, contact
types, the 2-D bond counting and rattler rule, glued-sphere rods and walls."""
import numpy as np
import pytest

from analysis.contacts import (SIDE_SIDE, TIP_SIDE, TIP_TIP, ContactNumber, ContactTypes,
                               contact_angles, contact_types, geometric_contacts, glued_bodies,
                               merge_glued_contacts, remove_rattlers_2d)
from analysis.frame import Contacts
from analysis.theory import isostatic_z
from analysis.walls import CylinderWall, PlaneWall, wall_contacts
from tests.analysis.helpers import cubic, frame_of, random_unit


def brute_spine_distance(xa, ua, la, xb, ub, lb, k=301):
    s = np.linspace(-la / 2, la / 2, k)[:, None]
    t = np.linspace(-lb / 2, lb / 2, k)[:, None]
    pa, pb = xa + s * ua, xb + t * ub
    return np.min(np.linalg.norm(pa[:, None] - pb[None], axis=2))


def test_rod_contacts_match_brute_force(rng):
    n, box, r = 40, 6.0, 0.3
    x = rng.uniform(0, box, size=(n, 3))
    u = random_unit(rng, n)
    ln = rng.uniform(0.0, 1.5, n)
    fr = frame_of(x, r, [box] * 3, axis=u, length=ln)
    tol = 0.05
    c = geometric_contacts(fr, tolerance=tol)
    found = {(int(i), int(j)): k for k, (i, j) in enumerate(zip(c.i, c.j))}
    checked = 0
    for a in range(n):
        for b in range(a + 1, n):
            xb = x[a] + fr.minimum_image(x[b] - x[a])
            if np.linalg.norm(xb - x[a]) > (ln[a] + ln[b]) / 2 + 2 * r + tol + 0.1:
                assert (a + 1, b + 1) not in found  # too far apart to touch
                continue
            checked += 1
            d = brute_spine_distance(x[a], u[a], ln[a], xb, u[b], ln[b])
            h = max(ln[a], ln[b]) / 300  # sampling resolution
            key = (a + 1, b + 1)
            if d < 2 * r + tol - h:
                assert key in found
                k = found[key]
                assert 2 * r - c.overlap[k] <= d + 1e-12
                assert 2 * r - c.overlap[k] == pytest.approx(d, abs=h)
            elif d > 2 * r + tol + h:
                assert key not in found
    assert checked > 20 and c.n > 5
    # geometry of each row: unit normal from the spine of i to that of j, point between
    for k in range(c.n):
        a, b = c.i[k] - 1, c.j[k] - 1
        assert np.linalg.norm(c.normal[k]) == pytest.approx(1.0)
        # moving j along the normal by the overlap brings the pair to touching
        xb = x[a] + fr.minimum_image(x[b] - x[a]) + (c.overlap[k] + 1e-9) * c.normal[k]
        assert brute_spine_distance(x[a], u[a], ln[a], xb, u[b], ln[b], 101) >= 2 * r - 1e-3


def test_swapping_translating_and_rotating_leave_rod_contacts_unchanged(rng):
    n = 30
    x = rng.uniform(0, 5, size=(n, 3))
    u = random_unit(rng, n)
    ln = rng.uniform(0.5, 1.5, n)
    base = frame_of(x, 0.3, [20.0] * 3, axis=u, length=ln, periodic=False)
    c0 = geometric_contacts(base, 0.02)
    r, _ = np.linalg.qr(rng.normal(size=(3, 3)))
    moved = frame_of(x @ r.T + 7.0, 0.3, [20.0] * 3, axis=-(u @ r.T), length=ln, periodic=False)
    c1 = geometric_contacts(moved, 0.02)
    assert c1.i.tolist() == c0.i.tolist() and c1.j.tolist() == c0.j.tolist()
    np.testing.assert_allclose(c1.overlap, c0.overlap, atol=1e-12)
    np.testing.assert_allclose(c1.normal, c0.normal @ r.T, atol=1e-9)
    order = np.arange(n)[::-1]
    rev = frame_of(x[order], 0.3, [20.0] * 3, axis=u[order], length=ln[order], periodic=False)
    c2 = geometric_contacts(rev, 0.02)
    assert c2.n == c0.n
    np.testing.assert_allclose(np.sort(c2.overlap), np.sort(c0.overlap), atol=1e-12)


def test_rods_of_zero_length_are_spheres(rng):
    x = rng.uniform(0, 4, size=(50, 3))
    spheres = frame_of(x, 0.4, [4.0] * 3)
    rods = frame_of(x, 0.4, [4.0] * 3, axis=random_unit(rng, 50), length=np.r_[1e-300, np.zeros(49)])
    a, b = geometric_contacts(spheres, 0.0), geometric_contacts(rods, 0.0)
    assert a.i.tolist() == b.i.tolist() and a.j.tolist() == b.j.tolist()
    np.testing.assert_allclose(a.overlap, b.overlap, atol=1e-12)
    np.testing.assert_allclose(a.point, b.point, atol=1e-12)


def test_stacked_lattice_of_upright_rods_at_contact():
    """Upright rods (D = 1, L = 2) on a unit square grid, layers stacked tip to tip
    (period 3 in z): 4 side-side neighbours and 2 tip-tip neighbours each."""
    x = cubic(0, shape=(4, 4, 3), spacing=1.0) * [1, 1, 3] + [0.5, 0.5, 1.5]
    fr = frame_of(x, 0.5, [4.0, 4.0, 9.0], axis=[0, 0, 1.0], length=2.0)
    c = geometric_contacts(fr, tolerance=1e-9)
    cn = ContactNumber(c_min=6).compute(fr, c)
    assert np.all(cn.per_particle == 6) and cn.n_rattlers == 0
    ct = ContactTypes().compute(fr, c)
    assert ct.counts.tolist() == [len(x), 0, 2 * len(x)]  # tip-tip, tip-side, side-side
    assert np.all(ct.parallel_side == (ct.types == SIDE_SIDE))


def test_two_dimensional_lattice_counts_side_contacts_twice():
    """2-D rods along x (D = 1, L = 2) on a grid with period L + D along x and D along y:
    2 tip-tip and 2 parallel side-side contacts each, so z_tilde = 4 but z = 2 + 2 x 2 = 6,
    the isostatic count of 2-D rods."""
    g = cubic(0, shape=(4, 6, 1))
    x = g * [3.0, 1.0, 0.0] + [1.5, 0.5, 0.0]
    fr = frame_of(x, 0.5, [12.0, 6.0, 1.0], axis=[1.0, 0, 0], length=2.0)
    assert fr.dim == 2
    c = geometric_contacts(fr, tolerance=1e-9)
    cn = ContactNumber(rule="2d").compute(fr, c)
    assert cn.n_rattlers == 0
    assert cn.z_tilde == pytest.approx(4.0)
    assert cn.z_bonds == pytest.approx(6.0) == isostatic_z(2, rod=True)
    # the side contact point is the middle of the overlap of the projections
    side = contact_types(fr, c) == SIDE_SIDE
    a = fr.index_of(c.i[side])
    np.testing.assert_allclose(c.point[side, 0], fr.x[a, 0], atol=1e-12)
    # shifting alternate rows by a quarter rod keeps the bonds parallel but moves the point
    x2 = x + np.where((np.round(x[:, 1] - 0.5) % 2 == 1)[:, None], [0.5, 0, 0], [0, 0, 0])
    fr2 = frame_of(x2, 0.5, [12.0, 6.0, 1.0], axis=[1.0, 0, 0], length=2.0)
    c2 = geometric_contacts(fr2, tolerance=1e-9)
    assert ContactNumber(rule="2d").compute(fr2, c2).z_bonds == pytest.approx(6.0)


def test_tip_side_contact_of_a_t_junction():
    """Rod B stands on the middle of rod A's side: one tip-side contact."""
    fr = frame_of([[0, 0, 0.0], [0, 0, 2.0]], 0.5, [20.0] * 3, axis=[[1.0, 0, 0], [0, 0, 1.0]],
                  length=[3.0, 2.0], periodic=False)
    c = geometric_contacts(fr, tolerance=1e-9)
    assert c.n == 1 and contact_types(fr, c)[0] == TIP_SIDE
    np.testing.assert_allclose(c.point[0], [0, 0, 0.5], atol=1e-12)
    np.testing.assert_allclose(c.normal[0], [0, 0, 1.0], atol=1e-12)
    # end to end along the axis: tip-tip
    fr2 = frame_of([[0, 0, 0.0], [3.0, 0, 0]], 0.5, [20.0] * 3, axis=[1.0, 0, 0], length=2.0,
                   periodic=False)
    assert contact_types(fr2, geometric_contacts(fr2, 1e-9))[0] == TIP_TIP


def wall_table(frame, rows, points, wall_ids):
    k = len(rows)
    return Contacts(0, frame.ids[rows], np.asarray(wall_ids), np.asarray(points, float),
                    np.zeros((k, 3)), np.zeros(k), np.zeros((k, 3)))


def test_two_dimensional_rattler_rule():
    """Hand-made wall contacts (never removed) on one 2-D rod (axis x, L = 2, R = 0.5)
    and one disk: two contacts survive only on opposite flat sides."""
    fr = frame_of([[0, 0, 0.0], [5.0, 0, 0]], 0.5, [20.0, 20.0, 1.0], axis=[1.0, 0, 0],
                  length=[2.0, 0.0], periodic=False, dimension=2)

    def rattlers(points_rod, points_disk):
        pts = list(points_rod) + list(points_disk)
        rows = [0] * len(points_rod) + [1] * len(points_disk)
        return remove_rattlers_2d(fr, wall_table(fr, rows, pts, -1 - np.arange(len(pts))))

    assert rattlers([[0.3, 0.5, 0], [-0.2, -0.5, 0]], []).tolist() == [False, True]
    assert rattlers([[0.3, 0.5, 0], [-0.2, 0.5, 0]], [])[0]          # same side
    assert rattlers([[1.4, 0.1, 0], [0.0, -0.5, 0]], [])[0]          # one on a cap
    assert rattlers([[0.3, 0.5, 0]], [])[0]                          # one contact
    assert rattlers([[0.0, 0.5, 0], [0.5, -0.5, 0], [1.5, 0, 0]], [])[0] == False  # noqa: E712
    disk = [[5.5, 0, 0], [4.5, 0, 0]]
    assert rattlers([], disk)[1]                                     # disks need 3
    assert not rattlers([], disk + [[5.0, 0.5, 0]])[1]


def test_two_dimensional_rattler_removal_cascades():
    """A chain: rod 1 held by walls on opposite sides, rod 2 touching rod 1 once and a
    wall once on the same side: rod 2 goes, rod 1 stays."""
    fr = frame_of([[0, 0, 0.0], [0, 1.0, 0]], 0.5, [20.0, 20.0, 1.0], axis=[1.0, 0, 0],
                  length=2.0, periodic=False, dimension=2)
    pp = Contacts(0, np.array([1]), np.array([2]), np.array([[0.0, 0.5, 0]]),
                  np.array([[0, 1.0, 0]]), np.zeros(1), np.zeros((1, 3)))
    walls = wall_table(fr, [0, 1], [[0.2, -0.5, 0], [0.4, 1.5, 0]], [-1, -2])
    r = remove_rattlers_2d(fr, Contacts.concatenate([pp, walls]))
    # rod 2: contacts at y = 0.5 (below it, side) and 1.5 (above, side): opposite sides
    assert r.tolist() == [False, False]
    walls = wall_table(fr, [0], [[0.2, -0.5, 0]], [-1])
    r = remove_rattlers_2d(fr, Contacts.concatenate([pp, walls]))
    assert r.tolist() == [True, True]


def glued_rod_spheres(centre, direction, n_sph=3, spacing=0.5, radius=0.5):
    d = np.asarray(direction, float) / np.linalg.norm(direction)
    s = (np.arange(n_sph) - (n_sph - 1) / 2) * spacing
    return np.asarray(centre, float) + s[:, None] * d, np.full(n_sph, radius)


def test_glued_sphere_rods_merge_into_body_contacts():
    """Two rods of 3 glued spheres crossing at right angles, the second resting on the
    first: their sphere-sphere contacts become one body-body contact; contacts inside a
    body are dropped; forces add up."""
    xa, ra = glued_rod_spheres([3.0, 3.0, 3.0], [1, 0, 0])
    xb, rb = glued_rod_spheres([3.0, 3.0, 3.7], [0, 1, 0])
    fr = frame_of(np.vstack([xa, xb]), np.r_[ra, rb], [10.0] * 3)
    body = np.array([7, 7, 7, 9, 9, 9])
    bodies, row = glued_bodies(fr, body)
    assert bodies.ids.tolist() == [7, 9] and row.tolist() == [0, 0, 0, 1, 1, 1]
    np.testing.assert_allclose(bodies.x, [[3, 3, 3], [3, 3, 3.7]], atol=1e-12)
    np.testing.assert_allclose(np.abs(bodies.axis), [[1, 0, 0], [0, 1, 0]], atol=1e-12)
    np.testing.assert_allclose(bodies.length, 1.0)
    c = geometric_contacts(fr, 0.0)
    c.force = -c.normal * (1.0 + np.arange(c.n))[:, None]  # repulsive, all different
    inter = fr.index_of(c.i) // 3 != fr.index_of(c.j) // 3
    merged, mult = merge_glued_contacts(fr, c, body)
    assert inter.sum() == 9  # centre-centre, 4 centre-end and 4 end-end pairs
    assert merged.n == 1 and mult.tolist() == [9]
    assert merged.i.tolist() == [7] and merged.j.tolist() == [9]
    np.testing.assert_allclose(merged.force[0], c.force[inter].sum(axis=0))
    np.testing.assert_allclose(merged.normal[0], [0, 0, 1.0], atol=1e-12)
    assert merged.overlap[0] == pytest.approx(c.overlap[inter].max())
    # contacts between the bodies then count like those of the rods they represent
    cn = ContactNumber(c_min=0).compute(bodies, merged)
    assert cn.per_particle.tolist() == [1, 1]


def test_glued_body_across_a_periodic_face():
    xa, ra = glued_rod_spheres([0.1, 2.0, 2.0], [1, 0, 0], n_sph=4)
    fr = frame_of(np.mod(xa, 5.0), ra, [5.0] * 3)
    bodies, _ = glued_bodies(fr, np.ones(4))
    # centre at 0.1 (mod the box), spine 1.5 long along x
    assert np.mod(bodies.x[0, 0], 5.0) == pytest.approx(0.1)
    assert bodies.length[0] == pytest.approx(1.5)


def test_wall_contacts_of_rods():
    """A rod lying on the floor touches it twice; a tilted one once; a sphere once; a rod
    leaning on a cylinder wall touches it with the upper end only."""
    floor = PlaneWall(point=(0, 0, 0), normal=(0, 0, 1))
    fr = frame_of([[2, 2, 0.5], [5, 5, 0.5 + np.sin(0.3)], [8, 8, 0.5]], 0.5, [10.0] * 3,
                  axis=[[1.0, 0, 0], [np.cos(0.3), 0, np.sin(0.3)], [0, 0, 1.0]],
                  length=[2.0, 2.0, 0.0], periodic=(True, True, False))
    c = wall_contacts(fr, floor, tolerance=1e-9)
    assert sorted(c.i.tolist()) == [1, 1, 2, 3]
    np.testing.assert_allclose(c.normal, np.tile([0, 0, -1.0], (4, 1)))
    np.testing.assert_allclose(c.point[:, 2], 0.0, atol=1e-12)
    cyl = CylinderWall(center=(0.0, 0.0), radius=3.0)
    lean = frame_of([[2.5 - np.cos(1.0), 0, 1.0]], 0.5, [10.0] * 3,
                    axis=[[np.cos(1.0), 0, np.sin(1.0)]], length=2.0, periodic=False)
    cw = wall_contacts(lean, cyl, tolerance=1e-9)
    # upper end at x = 2.5 = R_c - R: touching
    assert cw.n == 1 and cw.overlap[0] == pytest.approx(0.0, abs=1e-9)
    np.testing.assert_allclose(cw.normal[0], [1.0, 0, 0])
    # a floor contact keeps a sphere with 3 neighbours from being a rattler
    sph = frame_of([[2, 2, 0.5], [3, 2, 0.5], [1, 2, 0.5], [2, 2, 1.5]], 0.5, [10.0] * 3,
                   periodic=(True, True, False))
    both = Contacts.concatenate([geometric_contacts(sph, 1e-9), wall_contacts(sph, floor, 1e-9)])
    cn = ContactNumber(c_min=4).compute(sph, both)
    assert cn.per_particle.tolist() == [4, 2, 2, 1]
    assert cn.rattlers.tolist() == [True, True, True, True]  # neighbours fall, then it falls
    cn0 = ContactNumber(c_min=2).compute(sph, both)
    assert cn0.rattlers.tolist() == [False, False, False, True]
    assert cn0.z == pytest.approx((2 * 3 + 3) / 4)


def test_unknown_particle_ids_are_not_taken_for_walls():
    fr = frame_of([[0, 0, 0.0], [1.0, 0, 0]], 0.5, [10.0] * 3)
    c = Contacts(0, np.array([1]), np.array([7]), np.zeros((1, 3)), np.array([[1.0, 0, 0]]),
                 np.zeros(1), np.zeros((1, 3)))
    with pytest.raises(KeyError, match=r"\[7\]"):
        ContactNumber().compute(fr, c)


def test_automatic_rattler_rule_follows_the_frame():
    """Default ContactNumber(): 3-D spheres need 4 contacts, 3-D rods 6, 2-D frames use
    the 2-D rule."""
    from analysis.contacts import default_c_min

    x = cubic(0, shape=(4, 4, 3), spacing=1.0) * [1, 1, 3] + [0.5, 0.5, 1.5]
    rods = frame_of(x, 0.5, [4.0, 4.0, 9.0], axis=[0, 0, 1.0], length=2.0)
    c = geometric_contacts(rods, 1e-9)
    assert default_c_min(rods) == 6
    assert ContactNumber().compute(rods, c).n_rattlers == 0
    # remove the tip-tip contacts: 4 side contacts each are too few for a 3-D rod ...
    side = contact_types(rods, c) == SIDE_SIDE
    assert ContactNumber().compute(rods, c.subset(side)).n_rattlers == len(x)
    # ... but enough for spheres
    spheres = frame_of(cubic(4) + 0.5, 0.5, [4.0] * 3)
    assert default_c_min(spheres) == 4
    cs = geometric_contacts(spheres, 1e-9)
    keep = np.abs(cs.normal[:, 2]) < 0.5  # 4 in-plane contacts each
    assert ContactNumber().compute(spheres, cs.subset(keep)).n_rattlers == 0
    g = cubic(0, shape=(4, 6, 1))
    flat = frame_of(g * [3.0, 1.0, 0.0] + [1.5, 0.5, 0.0], 0.5, [12.0, 6.0, 1.0], axis=[1.0, 0, 0],
                    length=2.0)
    cf = geometric_contacts(flat, 1e-9)
    only_sides = cf.subset(contact_types(flat, cf) == SIDE_SIDE)  # above and below: kept
    assert ContactNumber().compute(flat, only_sides).n_rattlers == 0
    assert ContactNumber(c_min=3).compute(flat, only_sides).n_rattlers == flat.n


def _table(i, j, points):
    points = np.asarray(points, dtype=float)
    c = len(points)
    return Contacts(0, np.asarray(i), np.asarray(j), points, np.tile([1.0, 0, 0], (c, 1)),
                    np.zeros(c), np.zeros((c, 3)))


def test_contact_angles_around_a_rod():
    # rod 1 along x (L = 2, R = 0.5) at (5, 5); disk 2 far away (only its id is needed);
    # a point at the tip, one on the flat side, one on the cap at 45 degrees, one beyond
    # the periodic face, and a point at the cap-side junction
    fr = frame_of([[5.0, 5.0, 0.0], [1.0, 1.0, 0.0]], [0.5, 0.5], [10.0, 10.0],
                  axis=[[1.0, 0, 0], [1.0, 0, 0]], length=[2.0, 0.0], dimension=2)
    h = 0.5 / np.sqrt(2.0)
    pts = [[6.5, 5.0, 0], [5.3, 5.5, 0], [6.0 + h, 5.0 - h, 0], [5.0 - 1.5 + 10.0, 5.0, 0],
           [6.0, 4.5, 0]]
    phi = contact_angles(fr, _table([1] * 5, [2] * 5, pts))
    np.testing.assert_allclose(phi, [0.0, np.arctan2(0.5, 0.3), np.arctan2(h, 1.0 + h),
                                     0.0, np.arctan(2 * 0.5 / 2.0)], atol=1e-12)
    # the ends on the disk (no spine) are left out
    assert phi.shape == (5,)


def test_contact_angles_of_isotropic_contacts_on_short_rods(rng):
    # random points around rods of vanishing length: P(varphi) = 2/pi, so the mean is
    # pi/4 and the fraction below pi/6 is 1/3 (binomial error about 0.005 for 10000)
    n = 200
    x = rng.uniform(0, 20.0, size=(n, 3))
    x[:, 2] = 0
    fr = frame_of(x, 0.5, [20.0, 20.0], axis=random_unit(rng, n, dim=2), dimension=2,
                  length=np.full(n, 1e-9))
    i = rng.integers(1, n + 1, 10000)
    j = (i % n) + 1
    th = rng.uniform(0, 2 * np.pi, 10000)
    pts = x[i - 1] + 0.5 * np.column_stack([np.cos(th), np.sin(th), np.zeros_like(th)])
    phi = contact_angles(fr, _table(i, j, pts))[:10000]
    assert phi.mean() == pytest.approx(np.pi / 4, abs=0.01)
    assert np.mean(phi < np.pi / 6) == pytest.approx(1 / 3, abs=0.012)


def network(pairs, ids_at):
    """A contact table of the made-up network ``pairs`` (particle ids), each contact at the
    midpoint of its two centres ``ids_at`` ({id: centre})."""
    i = np.array([p[0] for p in pairs])
    j = np.array([p[1] for p in pairs])
    points = [0.5 * (np.asarray(ids_at[a]) + np.asarray(ids_at[b])) for a, b in pairs]
    return _table(i, j, points)


#: a tetrahedron 1-2-3-4 (3 contacts each), particle 5 on 1 and 2, particle 6 on 5 only
TETRA = [(1, 2), (1, 3), (1, 4), (2, 3), (2, 4), (3, 4), (5, 1), (5, 2), (6, 5)]


@pytest.mark.parametrize("length", [0.0, 2.0])
def test_frictional_grains_are_held_by_d_contacts(length):
    """With friction a 3-D grain, sphere or rod, is held by 3 contacts: of the made-up
    network the tetrahedron stays, and the rule still cascades (6 hangs on 5 alone; once it
    goes, 5 has 2). Without friction the same network is all rattlers (spheres need 4,
    rods 6)."""
    from analysis.contacts import default_c_min

    x = np.array([[1, 1, 1], [3, 1, 1], [2, 3, 1], [2, 2, 3], [4, 4, 4], [6, 6, 6.0]])
    fr = frame_of(x, 0.5, [20.0] * 3, axis=[0, 0, 1.0], length=length)
    c = network(TETRA, dict(zip(range(1, 7), x)))
    assert default_c_min(fr, friction=0.5) == 3
    assert default_c_min(fr) == (6 if length else 4)
    dry = ContactNumber().compute(fr, c)
    assert dry.n_rattlers == 6 and dry.z_rattler_free == 0.0
    wet = ContactNumber(friction=0.5)
    cn = wet.compute(fr, c)
    assert cn.rattlers.tolist() == [False] * 4 + [True, True]
    assert cn.z_rattler_free == 3.0 and cn.z == 18 / 6
    assert wet.describe(fr) == "fewer than 3 contacts"
    assert ContactNumber().describe(fr) == f"fewer than {6 if length else 4} contacts"
    # an explicit c_min wins over the friction
    assert ContactNumber(c_min=4, friction=0.5).compute(fr, c).n_rattlers == 6


@pytest.mark.parametrize("length", [0.0, 1.0])
def test_frictional_two_dimensional_grains_are_held_by_two_contacts(length):
    """2-D with friction: a ring of four grains (2 contacts each, not on opposite flat
    sides) carries load; a grain on one contact does not. The frictionless 2-D rule
    removes the ring (disks need 3; rods' 2 contacts must sit on opposite flat sides)."""
    x = np.array([[2, 2, 0], [4, 2, 0], [4, 4, 0], [2, 4, 0], [6, 6, 0.0]])
    fr = frame_of(x, 0.5, [20.0, 20.0, 1.0], axis=[1.0, 0, 0], length=length, dimension=2,
                  periodic=(True, True, False))
    c = network([(1, 2), (2, 3), (3, 4), (4, 1), (5, 3)], dict(zip(range(1, 6), x)))
    assert ContactNumber().compute(fr, c).n_rattlers == 5
    wet = ContactNumber(friction=0.3)
    cn = wet.compute(fr, c)
    assert cn.rattlers.tolist() == [False] * 4 + [True]
    assert cn.z_rattler_free == 2.0
    assert wet.describe(fr) == "fewer than 2 contacts"
    assert ContactNumber().describe(fr).startswith("the 2-D rule")


def test_friction_must_be_a_number_at_least_zero():
    with pytest.raises(ValueError, match="friction must be a number >= 0, got -0.1"):
        ContactNumber(friction=-0.1)
    with pytest.raises(ValueError, match="friction must be a number >= 0, got nan"):
        ContactNumber(friction=float("nan"))


def test_end_bonds_count_a_side_contact_twice_when_both_ends_overlap():
    """Marschall & Teitel's rule: two bonds where both end bonds of a side contact
    overlap, whatever the tilt (here 1e-5 rad, far from parallel by the 1e-6 rad test
    of parallel_side_contacts); one bond once the tilt lifts an end out of contact
    (tilt L > overlap: here past 1e-4 rad, the deepest point of the pair overlapping by
    1e-6); one for a tip against a tip and for disks."""
    from analysis.contacts import end_bond_counts, parallel_side_contacts

    length, overlap = 0.01, 1e-6
    gap = 1.0 - overlap  # centre distance of two rods of radius 0.5

    def pair(tilt, shift=None, lengths=(length, length)):
        # rod j above rod i, its lower end overlapping i by `overlap`
        shift = (0.0, gap + 0.5 * length * np.sin(tilt)) if shift is None else shift
        x = np.array([[5.0, 5.0, 0.0], [5.0 + shift[0], 5.0 + shift[1], 0.0]])
        u = np.array([[1.0, 0.0, 0.0], [np.cos(tilt), np.sin(tilt), 0.0]])
        fr = frame_of(x, 0.5, [10.0, 10.0, 1.0], periodic=(True, True, False), axis=u,
                      length=np.array(lengths), dimension=2)
        return fr, geometric_contacts(fr)

    for tilt, bonds in ((0.0, 2), (1e-5, 2), (5e-5, 2), (2e-4, 1), (0.3, 1)):
        fr, c = pair(tilt)
        assert len(c.i) == 1
        assert end_bond_counts(fr, c).tolist() == [bonds], tilt
    fr, c = pair(1e-5)
    assert not parallel_side_contacts(fr, c).any()  # the angle test counts it once
    # ContactNumber's z_bonds counts by overlap unless told otherwise (no rattler rule:
    # a pair alone would be all rattlers)
    assert ContactNumber(c_min=0).compute(fr, c).z_bonds == pytest.approx(2.0)  # 2 x 2 bonds / 2
    assert ContactNumber(c_min=0, bond_rule="parallel").compute(fr, c).z_bonds == \
        pytest.approx(1.0)
    fr, c = pair(0.0, shift=(length + gap, 0.0))  # collinear, tip against tip
    assert end_bond_counts(fr, c).tolist() == [1]
    fr, c = pair(0.0, lengths=(0.0, 0.0))  # disks
    assert end_bond_counts(fr, c).tolist() == [1]


def test_end_bonds_count_a_tip_against_a_short_spines_side_once():
    """A tip square to the middle of a very short spine (alpha 0.001) overlaps both of
    that spine's end bonds once the overlap passes the curvature scale
    ``L^2 / (8 (R_i + R_j))``, yet it touches the side at one point: one bond, as the
    paper's Fig. 6 gives two only for a side against a side."""
    from analysis.contacts import end_bond_counts
    from analysis.geometry import end_bond_params

    length = 1e-3  # alpha 0.001 at R = 0.5
    scale = length**2 / 8.0  # the ends of i lie this much farther from j's tip
    for overlap in (0.5 * scale, 3.0 * scale):
        # rod j upright above the middle of rod i, its lower tip overlapping i
        yj = 1.0 - overlap + 0.5 * length
        x = np.array([[5.0, 5.0, 0.0], [5.0, 5.0 + yj, 0.0]])
        u = np.array([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])
        fr = frame_of(x, 0.5, [10.0, 10.0, 1.0], periodic=(True, True, False), axis=u,
                      length=np.array([length, length]), dimension=2)
        c = geometric_contacts(fr)
        assert len(c.i) == 1
        s, t = end_bond_params(x[1:] - x[:1], u[:1], [0.5 * length], u[1:],
                               [0.5 * length])
        r = x[1] - x[0] + t[0, :, None] * u[1] - s[0, :, None] * u[0]
        both_ends_of_i = bool((np.linalg.norm(r[:2], axis=1) < 1.0).all())
        assert both_ends_of_i == (overlap > scale)
        assert end_bond_counts(fr, c).tolist() == [1], overlap


def test_flat_side_fraction_counts_rods_touched_on_a_flat_side():
    """Rod 1 is touched on its flat side by a disk, rod 2 only on its cap by the same
    disk: one of the two rods has a flat-side contact."""
    from analysis.contacts import flat_side_contact_fraction

    x = np.array([[5.0, 5.0, 0.0], [5.0, 5.0 + 0.999, 0.0], [5.0 + 0.5 + 0.999, 5.999, 0.0]])
    u = np.array([[1.0, 0.0, 0.0], [1.0, 0.0, 0.0], [1.0, 0.0, 0.0]])
    fr = frame_of(x, 0.5, [10.0, 10.0, 1.0], periodic=(True, True, False), axis=u,
                  length=np.array([1.0, 0.0, 1.0]), dimension=2)
    c = geometric_contacts(fr)
    assert len(c.i) == 2
    assert flat_side_contact_fraction(fr, c) == pytest.approx(0.5)
    assert flat_side_contact_fraction(fr, c, among=np.array([True, True, False])) == 1.0
