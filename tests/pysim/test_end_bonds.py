"""The end-bond geometry of rod pairs (2-D): conservative forces against a NumPy energy, two
bonds for parallel side contacts, and mechanically stable packings that FIRE can reach."""
import numpy as np
import pytest

from pysim.contacts import REC_COLUMNS, pair_forces
from pysim.forces import HARMONIC, HOOKE, SPINE_CONTACTS, contact_params
from pysim.simulation import ContactModel


def point_segment(p, c, u, h):
    """Closest point to ``p`` on the segment ``c + t u``, ``|t| <= h``."""
    t = np.clip((p - c) @ u, -h, h)
    return c + t * u


def end_bond_energy(x, theta, r, half, k_e, distinct=False):
    """NumPy energy of the 2-D end-bond law: for each spine end, the harmonic energy
    ``k_e/2 (delta/d)^2`` of its overlap with the closest point of the other spine;
    ``distinct``: a bond joining the same two points as an earlier one of the pair left out
    (a tip-tip contact is one bond)."""
    u = np.column_stack([np.cos(theta), np.sin(theta), np.zeros(len(x))])
    e = 0.0
    n = len(x)
    for i in range(n):
        for j in range(i + 1, n):
            rs = r[i] + r[j]
            seen = []
            for a, b in ((i, j), (j, i)):
                for s in (-half[a], half[a]):
                    p = x[a] + s * u[a]
                    q = point_segment(p, x[b], u[b], half[b])
                    ends = {tuple(p), tuple(q)}
                    if distinct and ends in seen:
                        continue
                    seen.append(ends)
                    delta = rs - np.linalg.norm(q - p)
                    if delta > 0:
                        e += 0.5 * k_e * (delta / rs) ** 2
    return e


def forces(x, theta, r, half, k_e, record=False, spine_contact="end_bonds"):
    n = len(x)
    u = np.column_stack([np.cos(theta), np.sin(theta), np.zeros(n)])
    pi, pj = np.triu_indices(n, 1)
    f = np.zeros((n, 3))
    tq = np.zeros((n, 3))
    vir = np.zeros((3, 3))
    rec_ij = np.zeros((len(pi), 2), np.int64)
    rec = np.zeros((len(pi), REC_COLUMNS))
    p = contact_params(k_e, end_bonds=SPINE_CONTACTS[spine_contact])
    pe, nc = pair_forces(x, np.zeros((n, 3)), np.zeros((n, 3)), u, r, half,
                         np.array([100.0, 100.0, 1.0]), np.array([False, False, False]),
                         pi.astype(np.int32), pj.astype(np.int32), np.zeros((len(pi), 3)),
                         HARMONIC, p, False, 0.0, f, tq, vir, record, rec_ij, rec)
    return f, tq, pe, rec_ij[:nc], rec[:nc]


@pytest.mark.parametrize("spine_contact", ["end_bonds", "end_bonds_distinct"])
@pytest.mark.parametrize("seed", range(6))
def test_end_bond_forces_and_torques_are_minus_the_energy_gradient(seed, spine_contact):
    rng = np.random.default_rng(seed)
    n = 5
    # a small cluster of rods and disks, pushed together so that several overlap slightly
    x = np.column_stack([rng.uniform(0, 2.4, n), rng.uniform(0, 2.4, n), np.zeros(n)])
    theta = rng.uniform(0, np.pi, n)
    r = rng.uniform(0.4, 0.6, n)
    half = rng.uniform(0.0, 0.8, n)
    half[0] = 0.0
    k_e = 1.0
    distinct = spine_contact == "end_bonds_distinct"
    f, tq, pe, _, _ = forces(x, theta, r, half, k_e, spine_contact=spine_contact)
    assert pe == pytest.approx(end_bond_energy(x, theta, r, half, k_e, distinct), rel=1e-12, abs=1e-15)
    assert pe > 0
    h = 1e-7
    for i in range(n):
        for a in range(2):
            xp, xm = x.copy(), x.copy()
            xp[i, a] += h
            xm[i, a] -= h
            g = (end_bond_energy(xp, theta, r, half, k_e, distinct)
                 - end_bond_energy(xm, theta, r, half, k_e, distinct)) / (2 * h)
            assert f[i, a] == pytest.approx(-g, abs=1e-6)
        if half[i] > 0:
            tp, tm = theta.copy(), theta.copy()
            tp[i] += h
            tm[i] -= h
            g = (end_bond_energy(x, tp, r, half, k_e, distinct)
                 - end_bond_energy(x, tm, r, half, k_e, distinct)) / (2 * h)
            assert tq[i, 2] == pytest.approx(-g, abs=1e-6)
    assert np.allclose(f.sum(axis=0), 0.0, atol=1e-12)  # Newton's third law


def test_parallel_side_contact_is_two_bonds_at_the_ends_of_the_overlap():
    # rod 0 (L = 2) and rod 1 (L = 2) side by side, rod 1 shifted by 0.5 along x
    x = np.array([[0.0, 0.0, 0.0], [0.5, 0.99, 0.0]])
    theta = np.zeros(2)
    r = np.full(2, 0.5)
    half = np.full(2, 1.0)
    f, tq, pe, ij, rec = forces(x, theta, r, half, 1.0, record=True)
    delta = 0.01
    assert pe == pytest.approx(2 * 0.5 * delta**2, rel=1e-9)  # two bonds of overlap 0.01
    assert f[0, 1] == pytest.approx(-2 * delta, rel=1e-9) and f[0, 0] == pytest.approx(0.0, abs=1e-15)
    # bonds at x = -0.5 and 1.0: the pair force acts at the overlap's centre x = 0.25
    assert tq[0, 2] == pytest.approx(-0.25 * 2 * delta, rel=1e-9)
    assert len(ij) == 1  # one contact row per pair
    assert rec[0, 0] == pytest.approx(0.25) and rec[0, 6] == pytest.approx(delta)
    # the closest-point law puts one contact of overlap 0.01 at the overlap's centre
    p = contact_params(1.0)
    f1 = np.zeros((2, 3))
    u = np.tile([1.0, 0.0, 0.0], (2, 1))
    pe1, _ = pair_forces(x, np.zeros((2, 3)), np.zeros((2, 3)), u, r, half,
                         np.array([100.0, 100.0, 1.0]), np.zeros(3, bool),
                         np.array([0], np.int32), np.array([1], np.int32), np.zeros((1, 3)),
                         HARMONIC, p, False, 0.0, f1, np.zeros((2, 3)), np.zeros((3, 3)), False,
                         np.zeros((1, 2), np.int64), np.zeros((1, REC_COLUMNS)))
    assert pe1 == pytest.approx(0.5 * delta**2, rel=1e-9)


@pytest.mark.parametrize("spine_contact, bonds", [("end_bonds", 2), ("end_bonds_distinct", 1)])
def test_tip_tip_contact_is_one_bond_when_distinct(spine_contact, bonds):
    """Two rods meeting tip to tip at an angle: each tip is the other spine's closest point
    to it, so the four end bonds hold the same bond twice; the distinct law counts it once,
    Marschall & Teitel's tip-to-tip contact (their Eq. 25)."""
    half = np.full(2, 1.0)
    r = np.full(2, 0.5)
    theta = np.array([0.0, 0.3])
    tip0 = np.array([1.0, 0.0, 0.0])
    gap = 0.99  # tip-to-tip distance: overlap 0.01 along the line between the tips
    n = np.array([np.cos(0.1), np.sin(0.1), 0.0])
    u1 = np.array([np.cos(0.3), np.sin(0.3), 0.0])
    x = np.array([[0.0, 0.0, 0.0], tip0 + gap * n + u1])
    f, tq, pe, ij, rec = forces(x, theta, r, half, 1.0, record=True, spine_contact=spine_contact)
    delta = 0.01
    assert pe == pytest.approx(bonds * 0.5 * delta**2, rel=1e-9)
    np.testing.assert_allclose(f[0], -bonds * delta * n, rtol=1e-9, atol=1e-15)
    assert len(ij) == 1 and rec[0, 6] == pytest.approx(delta)


def test_distinct_bonds_step_where_a_tip_passes_the_other_spines_end():
    """The price of the distinct law: rod 1 stands on rod 0 near rod 0's tip. While rod 1's
    tip lies over rod 0's spine, rod 1's tip against rod 0's side and rod 0's tip against
    rod 1's tip are two bonds; once it lies beyond, both are the tip-tip bond, counted
    once, and the energy halves. The four end bonds have no such step."""
    def energy(dx, spine_contact):
        x = np.array([[0.0, 0.0, 0.0], [1.0 + dx, 1.999, 0.0]])
        return forces(x, np.array([0.0, np.pi / 2]), np.full(2, 0.5), np.full(2, 1.0), 1.0,
                      spine_contact=spine_contact)[2]
    two = 2 * 0.5 * 0.001**2
    assert energy(-1e-6, "end_bonds") == pytest.approx(two, rel=1e-6)
    assert energy(1e-6, "end_bonds") == pytest.approx(two, rel=1e-6)
    assert energy(-1e-6, "end_bonds_distinct") == pytest.approx(two, rel=1e-6)
    assert energy(1e-6, "end_bonds_distinct") == pytest.approx(two / 2, rel=1e-6)


def test_side_contact_stays_two_bonds_when_distinct():
    """The parallel side contact of the test above: its two end bonds join different
    points, so the distinct law keeps both (the paper's Fig. 6)."""
    x = np.array([[0.0, 0.0, 0.0], [0.5, 0.99, 0.0]])
    args = (x, np.zeros(2), np.full(2, 0.5), np.full(2, 1.0), 1.0)
    f, tq, pe, _, _ = forces(*args, spine_contact="end_bonds_distinct")
    f4, tq4, pe4, _, _ = forces(*args)
    assert pe == pytest.approx(2 * 0.5 * 0.01**2, rel=1e-9) and pe == pe4
    np.testing.assert_array_equal(f, f4)
    np.testing.assert_array_equal(tq, tq4)


def test_end_bonds_are_named_and_keep_a_spring_per_bond():
    with pytest.raises(ValueError, match="valid: 'closest', 'end_bonds', 'end_bonds_distinct'$"):
        ContactModel("hooke", 1.0, spine_contact="sides")
    assert ContactModel("hooke", 1.0, mu=0.5, spine_contact="end_bonds").spring_columns == 12
    assert ContactModel("hooke", 1.0, mu=0.5).spring_columns == 3
    assert ContactModel("hooke", 1.0, spine_contact="end_bonds").spring_columns == 0


def frictional_pass(x, theta, v, w, hist, spine_contact, dt=1e-3, mu=0.5):
    """One evaluation of the Hooke law with friction (k_t = 0.5, gamma_t = 0.1) for the
    pair (0, 1) of 2-D rods of half-length 1 and radius 0.5; ``hist`` is updated."""
    u = np.column_stack([np.cos(theta), np.sin(theta), np.zeros(2)])
    f = np.zeros((2, 3))
    tq = np.zeros((2, 3))
    p = contact_params(1.0, 0.2, 0.5, 0.1, mu, end_bonds=SPINE_CONTACTS[spine_contact])
    pair_forces(x, v, w, u, np.full(2, 0.5), np.full(2, 1.0), np.array([100.0, 100.0, 1.0]),
                np.zeros(3, bool), np.array([0], np.int32), np.array([1], np.int32), hist,
                HOOKE, p, True, dt, f, tq, np.zeros((3, 3)), False,
                np.zeros((1, 2), np.int64), np.zeros((1, REC_COLUMNS)))
    return f, tq


def test_parallel_rods_sliding_hold_with_two_springs():
    """Rod 1 slides along rod 0, side by side: its two end bonds each stretch a spring
    of their own, so the pair's tangential force is twice the closest-point law's one
    spring, and each bond's spring is the one the single-contact law gives it."""
    x = np.array([[0.0, 0.0, 0.0], [0.5, 0.99, 0.0]])
    v = np.array([[0.0, 0.0, 0.0], [0.3, 0.0, 0.0]])
    w = np.zeros((2, 3))
    h_ends = np.zeros((1, 12))
    f_ends, _ = frictional_pass(x, np.zeros(2), v, w, h_ends, "end_bonds")
    h_one = np.zeros((1, 3))
    f_one, _ = frictional_pass(x, np.zeros(2), v, w, h_one, "closest")
    assert f_one[0, 0] > 0  # rod 1 drags rod 0 along +x
    assert f_ends[0, 0] == pytest.approx(2 * f_one[0, 0], rel=1e-12)
    assert f_ends[0, 1] == pytest.approx(2 * f_one[0, 1], rel=1e-12)  # two normal bonds
    # bonds 1 (rod 0's end at +1) and 2 (rod 1's end at -0.5) touch; 0 and 3 do not
    np.testing.assert_allclose(h_ends[0, 3:6], h_one[0], rtol=1e-12)
    np.testing.assert_allclose(h_ends[0, 6:9], h_one[0], rtol=1e-12)
    assert not h_ends[0, :3].any() and not h_ends[0, 9:].any()


def test_each_end_bond_keeps_its_own_history():
    """Bond 1 of the pair (rod 0's end at +1) has slid before and holds a stretched
    spring; bond 2 (rod 1's end at -0.75) has just formed: at rest the pair's tangential
    force is bond 1's spring alone, the closest-point law's with that spring, and the new
    bond's spring stays zero. A bond that leaves reach drops its spring alone, a pair
    out of reach its whole row."""
    x = np.array([[0.0, 0.0, 0.0], [0.25, 0.99, 0.0]])
    v = np.zeros((2, 3))
    hist = np.zeros((1, 12))
    hist[0, 3:6] = [0.004, 0.0, 0.0]  # below the Coulomb cap (mu f_n = 0.005)
    hist[0, 9:12] = [0.3, 0.0, 0.0]  # a stale spring on bond 3, out of reach
    f_ends, _ = frictional_pass(x, np.zeros(2), v, v, hist, "end_bonds")
    one = np.array([[0.004, 0.0, 0.0]])
    f_one, _ = frictional_pass(x, np.zeros(2), v, v, one, "closest")
    assert f_ends[0, 0] != 0.0 and f_ends[0, 0] == pytest.approx(f_one[0, 0], rel=1e-12)
    np.testing.assert_allclose(hist[0, 3:6], [0.004, 0.0, 0.0], rtol=1e-12)
    assert not hist[0, 6:9].any() and not hist[0, 9:12].any() and not hist[0, :3].any()
    x2 = x.copy()
    x2[1, 1] = 1.2  # out of reach: the whole row is dropped
    frictional_pass(x2, np.zeros(2), v, v, hist, "end_bonds")
    assert not hist.any()


@pytest.mark.slow
def test_jammed_rods_with_end_bonds_are_force_and_torque_balanced(tmp_path):
    """2-D rods (alpha 1): with end bonds FIRE reaches U/L^2 = 1e-15 with every force and
    torque small against the mean contact force; the packing is hypostatic (z < 6). The
    closest-point law leaves such packings with residuals of order the contact force."""
    import json

    from analysis.balance import ForceBalance
    from analysis.contacts import ContactNumber
    from analysis.io import RunData
    from tests.runs import run_case

    out = run_case(tmp_path, {
        "particles": {"n": 48, "dimension": 2, "aspect_ratio": 1.0,
                      "diameter": {"distribution": "bidisperse", "mean": 1.0, "ratio": 1.4}},
        "contact": {"law": "harmonic", "k_n": 1.0, "spine_contact": "end_bonds"},
        "protocol": {"name": "jammed", "phi_init": 0.4, "rate": 2e-3, "dt": 0.01},
        "output": {"thermo_every": 500, "dump_every": 100000}, "seed": 3})
    res = json.loads((out / "jammed.json").read_text())
    # U/L^2 near the 1e-15 target (the bracket on phi can close first, energies jump
    # there as contacts form)
    assert 5e-16 < res["energy_density"] < 1e-14 and 0.82 < res["phi_j"] < 0.93
    f, c = RunData(out).frames()[-1]
    bal = ForceBalance().compute(f, c)
    assert bal.n_backbone > 40
    assert bal.force_max < 1e-2 and bal.torque_max < 1e-2
    cn = ContactNumber().compute(f, c)
    assert 4.0 < cn.z_bonds < 6.0 and cn.z_rattler_free <= cn.z_bonds


def test_end_bonds_are_refused_in_three_dimensions():
    """The case schema allows end bonds in 2-D only; the Python API refuses a 3-D state
    with them too, before anything runs (and still takes a 2-D one)."""
    from pysim.simulation import Simulation
    from pysim.state import State

    model = ContactModel("harmonic", k_n=1.0, spine_contact="end_bonds")
    x = np.array([[2.0, 2.0, 2.0], [5.0, 5.0, 5.0]])
    rods3 = State.create(x, 0.5, 2.0, [12.0, 12.0, 12.0])
    with pytest.raises(ValueError, match=r"^spine_contact 'end_bonds' is a 2-D law, and this "
                                         r"state is 3-D; use spine_contact 'closest' in 3-D$"):
        Simulation(rods3, model, dt=1e-3)
    x[:, 2] = 0.0
    rods2 = State.create(x, 0.5, 2.0, [12.0, 12.0, 1.0], periodic=(True, True, False),
                         dimension=2)
    assert Simulation(rods2, model, dt=1e-3).state is rods2


@pytest.mark.parametrize("kw, message", [
    ({"k_n": float("nan")}, r"^k_n = nan is not allowed; use a finite number > 0$"),
    ({"k_n": 1.0, "gamma_n": float("nan")},
     r"^gamma_n = nan is not allowed; use a finite number >= 0$"),
    ({"k_n": 1.0, "gamma_bg": float("inf")},
     r"^gamma_bg = inf is not allowed; use a finite number >= 0$"),
])
def test_contact_model_refuses_what_the_case_schema_refuses(kw, message):
    with pytest.raises(ValueError, match=message):
        ContactModel("hooke", **kw)


def test_set_spine_contact_gives_the_new_laws_forces_at_once(tmp_path):
    """Switching the rule of a running simulation (the jammed protocol compresses under
    one rule and relaxes under another) gives the forces of a simulation built with the
    new rule, and a checkpoint keeps the rule; 3-D states refuse the 2-D rules."""
    from pysim import checkpoint
    from tests.pysim.helpers import overlapping_rods

    sim = overlapping_rods(2, 40, 1.0, 0.9, 3, "closest")
    ref = overlapping_rods(2, 40, 1.0, 0.9, 3, "end_bonds_distinct")
    ref.compute_forces()
    sim.compute_forces()
    assert not np.allclose(sim.f, ref.f)  # the rules differ on this packing
    sim.set_spine_contact("end_bonds_distinct")
    assert sim.model.spine_contact == "end_bonds_distinct"
    np.testing.assert_array_equal(sim.f, ref.f)
    np.testing.assert_array_equal(sim.torque, ref.torque)
    checkpoint.save(sim, tmp_path / "c.npz")
    assert checkpoint.load(tmp_path / "c.npz")[0].model.spine_contact == "end_bonds_distinct"
    rods3 = overlapping_rods(3, 40, 1.0, 0.5, 3, "closest")
    with pytest.raises(ValueError, match=r"^spine_contact 'end_bonds' is a 2-D law"):
        rods3.set_spine_contact("end_bonds")
    assert rods3.model.spine_contact == "closest"


def _flat_stack_energy(rule):
    """Kinetic over potential scale, ``KE / (M g D)``, of two flat rods of the cohesive-
    deposit paper (d = 10, D = 0.05 m, Hertz k_n = 1e3, k_t = 100, mu = 0.5, dt = 5e-6 s)
    dropped onto each other and a frictional base, after 1 s."""
    from pysim import walls
    from pysim.simulation import Simulation
    from pysim.state import State

    d, length, g = 0.05, 0.45, 10.0
    x = np.array([[1.0, d / 2 + 0.01, 0.0], [1.07, d / 2 + 0.01 + 1.3 * d, 0.0]])
    ang = np.array([0.01, -0.01])
    axis = np.column_stack([np.cos(ang), np.sin(ang), np.zeros(2)])
    st = State.create(x, d / 2, length, np.array([2.0, 2.0, 0.0]), axis=axis, density=5e-6,
                      periodic=(False, False, False), dimension=2)
    model = ContactModel("hertz", 1e3, 1.8347621556e-5, k_t=100.0, gamma_t=6.115873852e-6,
                         mu=0.5, spine_contact=rule)
    sim = Simulation(st, model, dt=5e-6, gravity=(0.0, -g, 0.0),
                     planes=[walls.plane([0, 1, 0], [0, 0, 0])], skin=0.02)
    sim.run(200_000)
    s = sim.state
    ke = 0.5 * np.sum(s.mass[:, None] * s.v**2) + 0.5 * np.sum(s.inertia[:, 0] * s.omega[:, 2]**2)
    return ke / (np.sum(s.mass) * g * d)


def test_flat_rods_come_to_rest_with_frictional_end_bonds():
    """A rod lying on a rod: the closest point of two nearly parallel spines jumps from one
    end of their overlap to the other as the top rod rocks, so under the closest-point law
    the stack never rests (the fed deposits' kinetic-energy floor); with a spring at each
    end bond (the spheropolygons' vertex-edge contacts) it comes to rest."""
    assert _flat_stack_energy("end_bonds") < 1e-20
    assert _flat_stack_energy("closest") > 1e-10
