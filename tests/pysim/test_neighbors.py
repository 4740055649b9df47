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
