"""Force and torque balance from contact tables, and the kink of parallel side contacts."""
import numpy as np
import pytest

from analysis.balance import ForceBalance, kink_contacts, net_loads
from analysis.frame import Contacts, Frame


def table(i, j, point, force, overlap=None):
    point = np.asarray(point, float)
    force = np.asarray(force, float)
    n = len(point)
    normal = force / np.linalg.norm(force, axis=1)[:, None]
    return Contacts(0, np.asarray(i), np.asarray(j), point, normal,
                    np.full(n, 1e-3) if overlap is None else np.asarray(overlap, float), force)


def test_net_loads_match_a_plain_loop_on_random_tables():
    rng = np.random.default_rng(3)
    n, m = 12, 40
    fr = Frame.from_arrays(rng.uniform(0, 10, (n, 3)), 0.5, [10.0, 10.0, 10.0])
    i = rng.integers(1, n + 1, m)
    j = np.where(rng.random(m) < 0.2, -1, rng.integers(1, n + 1, m))  # some wall rows
    ok = i != j
    c = table(i[ok], j[ok], rng.uniform(0, 10, (ok.sum(), 3)), rng.normal(size=(ok.sum(), 3)))
    f, t = net_loads(fr, c)
    f_ref = np.zeros((n, 3))
    t_ref = np.zeros((n, 3))
    for a, b, p, force in zip(c.i, c.j, c.point, c.force):
        for k, s in ((a, 1.0), (b, -1.0)):
            if k <= 0:
                continue
            arm = p - fr.x[k - 1]
            arm -= 10.0 * np.round(arm / 10.0)  # minimum image
            f_ref[k - 1] += s * force
            t_ref[k - 1] += np.cross(arm, s * force)
    assert np.allclose(f, f_ref) and np.allclose(t, t_ref)


def rods_on_a_rod(angle=0.0, point_x=0.9):
    """Rod 1 (L = 2, R = 0.5) lies on rod 2 below it (side-side, tilted by ``angle``)
    and is pushed down at its centre by disk 3 above. The side-side force sits at
    ``x = point_x`` (where a minimiser on the kink leaves it); rod 2 is held by two
    wall rows and disk 3 by one, so every particle's force balances."""
    d = 1.0 - 1e-3
    x = [[0.0, 0.0, 0.0], [0.0, -d, 0.0], [0.0, d, 0.0]]
    axis = [[1.0, 0.0, 0.0], [np.cos(angle), np.sin(angle), 0.0], [1.0, 0.0, 0.0]]
    fr = Frame.from_arrays(x, 0.5, [20.0, 20.0, 20.0], axis=axis, length=[2.0, 2.0, 0.0],
                           dimension=2)
    f = 1.0
    c = table([1, 1, 2, 2, 3], [2, 3, -1, -1, -2],
              [[point_x, -0.5, 0], [0, 0.5, 0], [-0.5, -d - 0.5, 0], [0.5, -d - 0.5, 0],
               [0, d + 0.5, 0]],
              [[0, f, 0], [0, -f, 0], [0, f / 2, 0], [0, f / 2, 0], [0, -f, 0]])
    return fr, c


def test_a_parallel_side_contact_on_the_kink_balances_once_its_force_may_move():
    fr, c = rods_on_a_rod()
    fb = ForceBalance(c_min=0).compute(fr, c)
    assert fb.force_max == pytest.approx(0.0, abs=1e-12)
    assert fb.torque_max > 0.5  # the point at x = 0.9 twists both rods
    assert fb.n_kink == 1
    assert fb.torque_split_max == pytest.approx(0.0, abs=1e-9)  # point moved to x = 0


def test_a_tilted_side_contact_is_not_on_the_kink():
    fr, c = rods_on_a_rod(angle=0.1)  # the far end of the overlap gaps by about 0.2
    rows, lo, hi = kink_contacts(fr, c.subset(c.j > 0))
    assert len(rows) == 0
    fb = ForceBalance(c_min=0).compute(fr, c)
    assert fb.n_kink == 0 and fb.torque_split_max == pytest.approx(fb.torque_max)


def test_kink_range_spans_the_overlapping_projection():
    fr, c = rods_on_a_rod(point_x=0.9)
    rows, lo, hi = kink_contacts(fr, c.subset(c.j > 0))
    assert rows.tolist() == [0]
    assert lo[0] == pytest.approx(-1.9) and hi[0] == pytest.approx(0.1)


def test_rattlers_are_left_out_and_empty_tables_give_nan():
    fr, c = rods_on_a_rod()
    fb = ForceBalance().compute(fr, c)  # 2-D rule: every particle here is a rattler
    assert fb.n_backbone == 0 and np.isnan(fb.force_mean)
    with pytest.raises(ValueError, match="kink_tol"):
        ForceBalance(kink_tol=-1.0)


def test_a_rattler_that_carries_force_still_loads_its_neighbours():
    """Spheres A, B, C in a column, A and C held by three wall rows each: B has two
    contacts, so with ``c_min = 3`` it is a rattler, yet it carries the force from A to C.
    A and C are balanced only with B's contacts counted."""
    d = 0.999
    fr = Frame.from_arrays([[0, 0, 0], [0, d, 0], [0, 2 * d, 0]], 0.5, [20.0, 20.0, 20.0])
    f = 1.0
    xs = (-0.2, 0.0, 0.2)
    c = table([1, 2] + [1] * 3 + [3] * 3, [2, 3] + [-1] * 3 + [-2] * 3,
              [[0, d / 2, 0], [0, 1.5 * d, 0]] + [[x, -0.5, 0] for x in xs]
              + [[x, 2 * d + 0.5, 0] for x in xs],
              [[0, -f, 0], [0, -f, 0]] + [[0, f / 3, 0]] * 3 + [[0, -f / 3, 0]] * 3)
    fb = ForceBalance(c_min=3, split_parallel=False).compute(fr, c)
    assert fb.n_backbone == 2 and np.isnan(fb.force[1])
    assert fb.mean_force == pytest.approx(f)
    assert fb.force_max == pytest.approx(0.0, abs=1e-12)
    assert fb.torque_max == pytest.approx(0.0, abs=1e-12)
