"""Caged particles of a frame from its contact table: hand-built cages (a sphere in a
tetrahedron, a rod held at eight side points), the periodic minimum image, both ends of a
row, walls, and the LP decision on random contacts placed on particles of any
orientation."""
import numpy as np
import pytest

from analysis.cages import CagedParticles, body_rows, caged_particles, contact_ends
from analysis.caging import _dof_index, constraint_rows, default_dofs, is_caged, surface_contacts
from analysis.frame import Contacts, Frame
from tests.analysis.helpers import random_unit

TETRA = np.array([[1, 1, 1], [1, -1, -1], [-1, 1, -1], [-1, -1, 1]]) / np.sqrt(3)


def table(i, j, point, normal, overlap=1e-3):
    point = np.atleast_2d(np.asarray(point, float))
    m = len(point)
    return Contacts(0, np.asarray(i, np.int64), np.asarray(j, np.int64), point,
                    np.atleast_2d(np.asarray(normal, float)),
                    np.broadcast_to(np.asarray(overlap, float), (m,)).copy(), np.zeros((m, 3)))


def sphere_in_cage(directions, centre, box=6.0, flip=()):
    """Sphere 1 (diameter 1) at ``centre`` touching spheres 2.. in ``directions`` with
    overlap 1e-3, in a periodic box; neighbours and contact points are wrapped into the
    box; rows listed in ``flip`` name the neighbour first (normal reversed)."""
    delta = 1e-3
    k = len(directions)
    x = np.vstack([centre, centre + (1.0 - delta) * directions]) % box
    frame = Frame.from_arrays(x, 0.5, [box] * 3)
    point = (centre + (0.5 - delta / 2) * directions) % box
    i, j, n = np.ones(k, int), np.arange(2, k + 2), directions.copy()
    for r in flip:
        i[r], j[r], n[r] = j[r], 1, -n[r]
    return frame, table(i, j, point, n)


@pytest.mark.parametrize("centre", [[3.0, 3.0, 3.0], [0.1, 5.95, 0.2]])
def test_a_sphere_in_a_tetrahedron_is_caged_and_not_by_three(centre):
    """Four tetrahedral contacts cage a sphere, three do not; the same across the faces
    of the periodic box (second centre: contact points and neighbours wrap), and with
    some rows naming the sphere second. Its neighbours (one contact each) are free."""
    frame, c = sphere_in_cage(TETRA, np.array(centre), flip=(1, 3))
    cp = CagedParticles().compute(frame, c)
    assert cp.caged.tolist() == [True, False, False, False, False]
    assert cp.n_caged == 1 and cp.noncaged_fraction == pytest.approx(4 / 5)
    frame3, c3 = sphere_in_cage(TETRA[:3], np.array(centre), flip=(0,))
    cp3 = CagedParticles().compute(frame3, c3)
    assert not cp3.caged.any() and cp3.noncaged_fraction == 1.0
    assert cp3.decided_by == {"count": 4}


def test_only_touching_rows_count_and_walls_act_on_their_grain():
    """A row without overlap (a cohesive or listed neighbour) is no contact: with it the
    tetrahedron loses a corner. Wall rows (j <= 0) act on i like a neighbour would."""
    frame, c = sphere_in_cage(TETRA, np.array([3.0, 3.0, 3.0]))
    c.overlap[2] = 0.0
    assert not CagedParticles().compute(frame, c).caged[0]
    walls = table([1] * 4, [-1, -2, -3, -4], 3.0 + 0.4995 * TETRA, TETRA)
    alone = Frame.from_arrays([[3.0, 3.0, 3.0]], 0.5, [6.0] * 3)
    assert CagedParticles().compute(alone, walls).caged.tolist() == [True]


def rod_frame(u, centre, half=1.5, box=8.0):
    """One rod (R = 0.5, L = 2 half) along ``u`` at ``centre``; the rows of eight side
    contacts, at spine positions +-s = +-1 and normals +-e1, +-e2 (unit vectors
    perpendicular to u), plus the two cap tips (normals +-u) as rows 8 and 9; ``(frame,
    points, normals)``."""
    u = np.asarray(u, float) / np.linalg.norm(u)
    e1 = np.cross(u, [0.3, -0.8, 0.5])
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(u, e1)
    pts, nrm = [], []
    for s in (1.0, -1.0):
        for m in (e1, -e1, e2, -e2):
            pts.append(centre + s * u + 0.4995 * m)
            nrm.append(m)
    for sign in (1.0, -1.0):
        pts.append(centre + sign * (half + 0.4995) * u)
        nrm.append(sign * u)
    frame = Frame.from_arrays([centre], 0.5, [box] * 3, axis=[u], length=2 * half)
    return frame, np.array(pts) % box, np.array(nrm)


@pytest.mark.parametrize("u", [[0, 0, 1.0], [1.0, 2.0, -0.5], [1.0, 0, 0]])
def test_a_rod_held_at_eight_side_points(u):
    """Side contacts above and below at both ends of the spine block the translations
    and rotations perpendicular to it, whatever its direction, but not the sliding along
    it; any seven of the eight leave a rotation or translation free; the two cap tips
    added block the sliding too (block_axial). The rod sits across a box corner."""
    frame, pts, nrm = rod_frame(u, np.array([0.2, 7.9, 0.1]))
    walls = -np.arange(1, 11)
    side = table([1] * 8, walls[:8], pts[:8], nrm[:8])
    assert caged_particles(frame, side)[0].tolist() == [True]
    assert caged_particles(frame, side, block_axial=True)[0].tolist() == [False]
    for k in range(8):
        keep = np.delete(np.arange(8), k)
        fewer = table([1] * 7, walls[keep], pts[keep], nrm[keep])
        assert caged_particles(frame, fewer)[0].tolist() == [False]
    every = table([1] * 10, walls, pts, nrm)
    assert caged_particles(frame, every, block_axial=True)[0].tolist() == [True]


def test_side_normals_are_made_perpendicular_to_the_spine():
    """A rod held on its sides only has no contact that moves it along its spine; noise
    of 1e-10 along u in the normals (a table's rounding) must not make the sliding
    couple to the blocked freedoms: the rows of side contacts have a zero axial column
    (caps keep theirs), and the rotation about the spine is a zero column too."""
    frame, pts, nrm = rod_frame([1.0, 2.0, -0.5], np.array([4.0, 4.0, 4.0]))
    noisy = nrm + 1e-10 * frame.axis[0]
    owner, lever, normal = contact_ends(frame, table([1] * 10, -np.arange(1, 11), pts, noisy))
    rows = body_rows(frame, owner, lever, normal)
    assert np.all(rows[:8, 2] == 0.0) and np.all(np.abs(rows[8:, 2]) == pytest.approx(1.0))
    assert np.all(rows[:, 5] == 0.0)


@pytest.mark.parametrize("dim,length,axial", [(3, 0.0, False), (3, 2.0, False), (3, 6.0, True),
                                              (2, 0.0, False), (2, 2.0, False)])
def test_random_contacts_on_placed_particles_decide_as_the_lp(rng, dim, length, axial):
    """Random surface contacts (uniform by area, 2 to 20) on particles of random
    orientation and position, given to the frame as rows in the lab frame (half as
    wall rows, half with the particle second and the normal reversed): the frame's
    verdict is is_caged on the rows in the particle's own frame."""
    blocked = _dof_index(dim, length, default_dofs(dim, length, axial))
    box = 10.0
    verdicts = []
    for _ in range(40):
        m = int(rng.integers(2, 21))
        p, n = surface_contacts(rng, m, 0.5, length, dim)
        expect = is_caged(constraint_rows(p, n), blocked)
        u = random_unit(rng, 1, dim)[0]
        # body axes -> lab: the spine (body z in 3-D, body x in 2-D) goes onto u
        if dim == 3:
            e1 = np.cross(u, random_unit(rng, 1)[0])
            e1 /= np.linalg.norm(e1)
            rot = np.column_stack([e1, np.cross(u, e1), u])
        else:
            rot = np.array([[u[0], -u[1], 0], [u[1], u[0], 0], [0, 0, 1.0]])
        pad = np.zeros((m, 3 - dim))
        p_lab = np.hstack([p, pad]) @ rot.T
        n_lab = np.hstack([n, pad]) @ rot.T
        centre = rng.uniform(0, box, 3) * (1.0 if dim == 3 else np.array([1, 1, 0]))
        frame = Frame.from_arrays([centre] + [centre] * m, 0.5, [box] * 3, axis=[u] * (m + 1),
                                  length=[length] + [0.0] * m, dimension=dim)
        first = np.arange(m) % 2 == 0
        i = np.where(first, 1, np.arange(2, m + 2))
        j = np.where(first, -1, 1)
        normal = np.where(first[:, None], n_lab, -n_lab)
        c = table(i, j, (centre + p_lab) % np.where(np.arange(3) < dim, box, np.inf), normal)
        got = CagedParticles(block_axial=axial).compute(frame, c).caged[0]
        assert got == expect
        verdicts.append(expect)
    assert any(verdicts) and not all(verdicts)


def test_needs_a_contact_table():
    frame, _ = sphere_in_cage(TETRA, np.array([3.0, 3.0, 3.0]))
    with pytest.raises(ValueError, match="contact table"):
        CagedParticles().compute(frame)
