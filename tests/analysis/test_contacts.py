"""Contact numbers and rattlers on constructed packings."""
import numpy as np
import pytest

from analysis.base import NotComputedError
from analysis.contacts import (ContactNumber, contact_number_distribution, geometric_contacts,
                               remove_rattlers)
from analysis.frame import Contacts, Frame


def frame_of(x, radius, box, periodic=(True, True, True)):
    n = len(x)
    return Frame(step=0, ids=np.arange(1, n + 1), types=np.ones(n, np.int64), x=np.asarray(x, float),
                 radius=np.broadcast_to(radius, (n,)).astype(float), axis=np.tile([0, 0, 1.0], (n, 1)),
                 length=np.zeros(n), box_lo=np.zeros(3), box=np.asarray(box, float),
                 periodic=np.array(periodic))


def simple_cubic(m, spacing=1.0):
    g = np.arange(m) * spacing
    return np.array(np.meshgrid(g, g, g, indexing="ij")).reshape(3, -1).T


def test_simple_cubic_lattice_at_contact_has_six_contacts_each():
    x = simple_cubic(4) + 0.25
    fr = frame_of(x, 0.5, [4.0, 4.0, 4.0])
    c = geometric_contacts(fr, tolerance=1e-9)
    cn = ContactNumber(c_min=4).compute(fr, c)
    assert np.all(cn.per_particle == 6)
    assert cn.z == 6.0 and cn.z_rattler_free == 6.0 and cn.n_rattlers == 0


def test_walls_cut_the_lattice_bonds():
    x = simple_cubic(3) + 0.5
    fr = frame_of(x, 0.5, [3.0, 3.0, 3.0], periodic=(True, True, False))
    cn = ContactNumber(c_min=0).compute(fr, geometric_contacts(fr, tolerance=1e-9))
    # the top and bottom layers lose their bond across the (non-periodic) z faces
    z_layer = np.round(x[:, 2] - 0.5).astype(int)
    assert np.all(cn.per_particle[z_layer == 1] == 6)
    assert np.all(cn.per_particle[z_layer != 1] == 5)


def test_rattler_in_a_cage_is_removed():
    """A small sphere in the cubic hole of a lattice touches nothing and is a rattler;
    one touching a single neighbour is removed too, and its neighbour keeps 6."""
    x = simple_cubic(4)
    hole = np.array([[1.5, 1.5, 1.5]])
    # in the next hole, moved along the diagonal until it touches the corner (2, 2, 2) only
    loose = np.full((1, 3), 2.0 + 0.8 / np.sqrt(3))
    pos = np.vstack([x, hole, loose])
    r = np.r_[np.full(len(x), 0.5), 0.3, 0.3]
    fr = frame_of(pos, r, [4.0, 4.0, 4.0])
    c = geometric_contacts(fr, tolerance=1e-9)
    cn = ContactNumber(c_min=4).compute(fr, c)
    assert cn.per_particle[-2] == 0 and cn.per_particle[-1] == 1
    assert cn.rattlers[-2] and cn.rattlers[-1]
    assert cn.n_rattlers == 2
    assert cn.z_rattler_free == pytest.approx(6.0)


def test_rattler_removal_is_iterative():
    # a chain 0-1-2-3 hanging off nothing: all fall below 2 contacts in turn
    i = np.array([0, 1, 2])
    j = np.array([1, 2, 3])
    assert remove_rattlers(4, i, j, c_min=2).all()
    # a triangle survives c_min = 2
    assert not remove_rattlers(3, np.array([0, 1, 0]), np.array([1, 2, 2]), c_min=2).any()


def test_results_refuse_to_be_read_before_compute():
    with pytest.raises(NotComputedError):
        ContactNumber().z


def test_contact_number_distribution_counts_touching_partners():
    """P(C) of five spheres: a chain 1-2-3 plus the pair 4-5, 4 also on a wall. Walls,
    rows without overlap and a pair listed twice (in either order) add nothing:
    C = (1, 2, 1, 1, 1) -> P = (0, 4/5, 1/5), whose mean is 2 N_c / N."""
    fr = frame_of(np.arange(15.0).reshape(5, 3), 0.5, [30.0] * 3)
    i = np.array([1, 2, 4, 3, 1, 4])
    j = np.array([2, 3, 5, 2, 5, -1])
    overlap = np.array([1e-3, 1e-3, 1e-3, 1e-3, 0.0, 1e-3])
    z = np.zeros((6, 3))
    c = Contacts(0, i, j, z, z, overlap, z)
    p = contact_number_distribution(fr, c)
    np.testing.assert_allclose(p, [0.0, 0.8, 0.2])
    assert p @ np.arange(3) == pytest.approx(2 * 3 / 5)
    # no contacts: everyone has C = 0
    np.testing.assert_allclose(contact_number_distribution(fr, c.subset(overlap < 0)), [1.0])


def test_contact_number_distribution_of_the_cubic_lattice():
    """A simple cubic lattice squeezed by 0.1 %: every sphere has six contacts."""
    x = (simple_cubic(4) + 0.25) * 0.999
    fr = frame_of(x, 0.5, [4.0 * 0.999] * 3)
    np.testing.assert_allclose(contact_number_distribution(fr, geometric_contacts(fr)),
                               np.eye(7)[6])
