"""Cell/Verlet lists against the all-pairs reference on random inputs."""
import numpy as np
import pytest

from pysim.initial import random_spheres
from pysim.neighbors import all_pairs, build_pairs, needs_rebuild


@pytest.mark.parametrize("periodic", [(True, True, True), (True, True, False), (False, False, False)])
@pytest.mark.parametrize("n, side", [(300, 12.0), (40, 3.1), (60, 7.0)])
def test_build_pairs_equals_all_pairs(rng, periodic, n, side):
    box = np.array([side, side * 1.1, side * 0.9])
    x = rng.uniform(0, 1, (n, 3)) * box
    r = rng.uniform(0.3, 0.7, n)
    per = np.array(periodic)
    pi, pj = build_pairs(x, r, box, per, 0.2)
    ai, aj = all_pairs(x, r, box, per, 0.2)
    assert np.array_equal(pi, ai) and np.array_equal(pj, aj)


def test_needs_rebuild_never_misses_a_pair(rng):
    """Under random motion and box compression, every pair within the interaction range
    is in the list whenever needs_rebuild says the list is still good."""
    x, d, box = random_spheres(np.ones(200), 0.3, seed=3)
    r = d / 2
    per = np.ones(3, bool)
    skin = 0.2
    pi, pj = build_pairs(x, r, box, per, skin)
    x_ref, box_ref = x.copy(), box.copy()
    checked = 0
    for _ in range(400):
        s = np.exp(-0.002)
        box = box * s
        x = x * s + rng.normal(0, 0.004, x.shape)
        x %= box
        if needs_rebuild(x, x_ref, box, box_ref, per, r.max(), skin, 1.0):
            pi, pj = build_pairs(x, r, box, per, skin)
            x_ref, box_ref = x.copy(), box.copy()
            continue
        ti, tj = all_pairs(x, r, box, per, 0.0)  # pairs within r_i + r_j (touching range)
        listed = set(zip(pi.tolist(), pj.tolist()))
        assert set(zip(ti.tolist(), tj.tolist())) <= listed
        checked += 1
    assert checked > 100


@pytest.mark.parametrize("box", [(4.0, 16.0, 2.0), (9.0, 3.0, 6.0), (5.0, 5.0, 5.0)])
def test_spatial_order_runs_the_longest_axis_slowest(rng, box):
    """Cells in row-major order with the box axes from the longest (slowest) to the
    shortest (fastest); equal axes keep x, y, z. A permutation of all particles."""
    from pysim.neighbors import spatial_order

    box = np.array(box)
    x = rng.uniform(0.0, 1.0, (2000, 3)) * box
    order = spatial_order(x, box)
    assert sorted(order.tolist()) == list(range(len(x)))
    axes = np.argsort(-box, kind="stable")
    cells = np.floor(x[order] / box * (box // 1.0)).astype(int)[:, axes]
    keys = [tuple(c) for c in cells]
    assert keys == sorted(keys)  # lexicographic: slowest axis first


@pytest.mark.parametrize("box", [(9.0, 12.0, 15.0), (15.0, 9.0, 12.0), (12.0, 12.0, 9.0)])
def test_rod_list_is_every_pair_by_spine_distance_whatever_the_axes(rng, box):
    """The rods' list (cells in the particles' order, the longest axis slowest) holds
    exactly the pairs whose spines are closer than ``r_c_i + r_c_j + skin``, checked on
    all pairs, and the same pairs when the axes are relabelled."""
    from pysim.neighbors import build_list, spine_separations

    box = np.array(box)
    n = 150
    x = rng.uniform(0.0, 1.0, (n, 3)) * box
    u = rng.normal(size=(n, 3))
    u /= np.linalg.norm(u, axis=1, keepdims=True)
    half = rng.uniform(0.0, 1.5, n)
    r = rng.uniform(0.3, 0.6, n)
    per = np.array([True, True, True])
    skin = 0.3
    pi, pj, *_ = build_list(x, u, r + half, half, box, per, skin)
    ai, aj = np.triu_indices(n, 1)
    sep = np.empty(len(ai))
    spine_separations(x, u, half, box, per, ai.astype(np.int32), aj.astype(np.int32), sep)
    keep = sep < r[ai] + r[aj] + skin
    assert np.array_equal(pi, ai[keep]) and np.array_equal(pj, aj[keep])
    assert keep.sum() > n  # a list worth checking
    for p in ([2, 0, 1], [1, 2, 0], [0, 2, 1]):
        qi, qj, *_ = build_list(np.ascontiguousarray(x[:, p]), np.ascontiguousarray(u[:, p]),
                                r + half, half, box[p].copy(), per, skin)
        assert np.array_equal(qi, pi) and np.array_equal(qj, pj)
