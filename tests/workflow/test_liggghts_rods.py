"""LIGGGHTS' random packings of rods (inputs/liggghts/in.rods.settle): it cannot compress
multisphere rods, so a compression case with a protocol.settle block runs on it as rods
inserted at random that settle under gravity onto a floor in a box periodic in x and y.
The converted bed holds whole rods of the case's length, across the periodic faces too,
at rest on the floor; its contact table (rod-rod contacts merged from sphere contacts,
across the periodic faces, and floor contacts from the stored wall forces) balances every
rod's weight; the bulk window's packing fraction agrees with a Monte Carlo estimate.
Without the binary only the mapping of the case to the deck runs."""
import shutil

import numpy as np
import pytest

from analysis.io import RunData
from analysis.summary import analyse_settled, settled_window
from analysis.frame import Frame
from tests.runs import prepared
from tests.cases import SETTLE_RODS, changed
from tests.conftest import needs_liggghts
from workflows import engines
from rodcase.case import ConfigError, validate_case
from workflows.checks import check_run

G = 10.0


@pytest.fixture(scope="module")
def bed(tmp_path_factory):
    if shutil.which("liggghts") is None:
        pytest.skip("LIGGGHTS is not installed")
    case, d = prepared(tmp_path_factory, "ligsettle", SETTLE_RODS)
    summary = engines.run("liggghts", case, d / "init.data", d / "run", timeout=300)
    return case, d / "run", summary


def test_case_maps_to_the_deck():
    case = validate_case(SETTLE_RODS)
    assert engines.settles("liggghts", case) and not engines.settles("lammps", case)
    assert engines.supports("liggghts", case) is None
    assert engines.deck("liggghts", case).name == "in.rods.settle"
    v = engines.deck_vars(case, "liggghts")
    assert v["spheres"] == "3" and float(v["length"]) == 1.0 and float(v["radius"]) == 0.5
    assert v["n_rods"] == "60" and float(v["width"]) == 5.0 and float(v["g"]) == G
    assert float(v["k_n"]) == 1e5 and float(v["gamma_n"]) == 300.0 and float(v["gamma_bg"]) == 1.0
    assert int(v["max_steps"]) == 400000 and float(v["settle_ratio"]) == 1e-10
    # the column holds the rods at PHI_INSERT_SETTLE of the part their centres can use
    vol = 60 * (np.pi / 4 + np.pi / 6)
    assert float(v["height"]) == pytest.approx(vol / (engines.PHI_INSERT_SETTLE * 3.0**2) + 2.0)
    # defaults of the schema, n from particles.n
    plain = validate_case(changed(SETTLE_RODS, protocol__settle={"width": 5.0}))
    plan = engines.settle_plan(plain)
    assert plan["n"] == 200 and plan["bulk"] == [2.0, 2.0] and plan["gravity"] > 0
    # other engines still compress the same case; spheres on LIGGGHTS too
    assert engines.deck("lammps", case).name == "in.rods.compress"
    spheres = validate_case(changed(SETTLE_RODS, particles__aspect_ratio=0.0))
    assert engines.deck("liggghts", spheres).name == "in.spheres.compress"


def test_what_the_settling_deck_cannot_do_is_said():
    no_settle = changed(SETTLE_RODS)
    del no_settle["protocol"]["settle"]
    assert "protocol.settle" in engines.supports("liggghts", validate_case(no_settle))
    rough = validate_case(changed(SETTLE_RODS, contact__friction=0.5, contact__k_t=1e4))
    assert "frictionless" in engines.supports("liggghts", rough)
    poly = validate_case(changed(SETTLE_RODS,
                                 particles__diameter={"distribution": "lognormal", "mean": 1.0,
                                                      "sigma": 0.1},
                                 protocol__settle={"width": 7.0}))
    assert "mono" in engines.supports("liggghts", poly)
    with pytest.raises(ConfigError, match=r"settle.width = 4.0 .* width > 2 \(L \+ D \+ 0.2 D\)"):
        validate_case(changed(SETTLE_RODS, protocol__settle={"width": 4.0}))
    with pytest.raises(ConfigError, match="settle.bulk"):
        validate_case(changed(SETTLE_RODS, protocol__settle={"width": 5.0, "bulk": [1.0]}))


def test_bulk_window_of_a_bed():
    """Rods lying flat in four layers of height D on z = 0..4: the surface is at 4, a
    window of margins (0.5, 0.5) rod lengths (L + D = 3) lies between 1.5 and 2.5, and a
    bed too thin for its margins is refused with the sizes."""
    xs, zs = np.meshgrid(np.arange(2) * 3.0 + 1.5, np.arange(4) + 0.5)
    n = xs.size
    fr = Frame.from_arrays(np.column_stack([xs.ravel(), np.zeros(n), zs.ravel()]), 0.5,
                           [6.0, 1.0, 10.0], axis=[1.0, 0.0, 0.0], length=2.0,
                           periodic=[True, True, False])
    lo, hi, top = settled_window(fr, [0.5, 0.5])
    assert (lo, hi, top) == pytest.approx((1.5, 2.5, 4.0))
    with pytest.raises(ValueError, match="no bulk"):
        settled_window(fr, [1.0, 1.0])


@pytest.mark.engines
@needs_liggghts
def test_rods_settle_whole_on_the_floor(bed):
    case, run_dir, summary = bed
    assert summary["settled"] and summary["ranks"] == 1
    assert check_run(run_dir, case) is None
    run = RunData(run_dir)
    frames = run.frames()
    steps = [f.step for f, _ in frames]
    assert steps[0] == 0 and steps == sorted(set(steps))
    frame, contacts = frames[-1]
    assert frame.step == run.thermo.step.iloc[-1]
    assert frame.n == 60 and list(frame.ids) == list(range(1, 61))
    # whole rods, also those cut by a periodic face (their spheres are unwrapped)
    np.testing.assert_allclose(frame.length, 1.0, rtol=1e-6)
    np.testing.assert_allclose(frame.radius, 0.5)
    assert list(frame.periodic) == [True, True, False]
    ends = np.concatenate(frame.ends())
    w = 5.0
    crossing = np.any((np.mod(ends[:, :2], w) != ends[:, :2]), axis=1)
    assert crossing.any()  # some rod sticks out of the box across a periodic face
    assert ends[:, 2].min() > 0.5 - 0.01  # on or above the floor
    # at rest: the kinetic energy fell to 1e-10 of its peak
    assert run.thermo.ke.iloc[-1] < 1e-10 * run.thermo.ke.max()
    assert set(contacts.j[contacts.j < 0]) == {engines.SETTLE_FLOOR_ID}
    assert np.all(contacts.i[contacts.j > 0] < contacts.j[contacts.j > 0])
    # some rod-rod contacts act across a periodic face
    a, b = frame.index_of(contacts.i[contacts.j > 0]), frame.index_of(contacts.j[contacts.j > 0])
    assert np.any(np.abs(frame.x[a, :2] - frame.x[b, :2]) > w / 2)


@pytest.mark.engines
@needs_liggghts
def test_contact_forces_balance_the_weight(bed):
    """Every rod: its rod-rod and floor rows plus its weight sum to zero (a contact
    missing across a periodic face would leave its two rods unbalanced); the floor
    carries the whole weight. Tolerance 1 % of a rod's weight."""
    case, run_dir, _summary = bed
    frame, contacts = RunData(run_dir).frames()[-1]
    row = {int(t): k for k, t in enumerate(frame.ids)}
    net = np.zeros((frame.n, 3))
    for i, j, f in zip(contacts.i, contacts.j, contacts.force):
        net[row[int(i)]] += f
        if j > 0:
            net[row[int(j)]] -= f
    weight = case["particles"]["density"] * frame.particle_measures() * G
    net[:, 2] -= weight
    assert np.abs(net).max() < 0.01 * weight.max()
    floor = contacts.j == engines.SETTLE_FLOOR_ID
    assert contacts.force[floor, 2].sum() == pytest.approx(weight.sum(), rel=0.01)
    # stiff contacts: overlaps stay far below the diameter (weight of the bed / k_n)
    assert contacts.overlap.max() < 1e-3


@pytest.mark.engines
@needs_liggghts
def test_bulk_packing_fraction_agrees_with_monte_carlo(bed):
    """phi_J of the bed is the packing fraction of its bulk window: exact slab volumes
    (analysis.packing) against random points counted inside any spherocylinder (minimum
    image across the periodic faces)."""
    case, run_dir, _summary = bed
    rows, prof, _ = analyse_settled(run_dir, case["protocol"]["settle"]["bulk"])
    val = dict((k, v) for k, v, _e in rows)
    frame, _ = RunData(run_dir).frames()[-1]
    lo, hi = val["bulk_lo"], val["bulk_hi"]
    assert 0.0 < lo < hi < val["bed_height"]
    rng = np.random.default_rng(7)
    m = 40000
    pts = np.column_stack([rng.uniform(0, 5.0, m), rng.uniform(0, 5.0, m), rng.uniform(lo, hi, m)])
    inside = np.zeros(m, bool)
    for k in range(frame.n):
        d = frame.minimum_image(pts - frame.x[k])
        t = np.clip(d @ frame.axis[k], -0.5 * frame.length[k], 0.5 * frame.length[k])
        inside |= np.linalg.norm(d - t[:, None] * frame.axis[k], axis=1) < frame.radius[k]
    phi_mc = inside.mean()
    assert val["phi_j"] == pytest.approx(phi_mc, abs=4 * np.sqrt(phi_mc * (1 - phi_mc) / m))
    assert 0.5 < val["phi_j"] < 0.8
    assert 3.0 < val["z_j"] < 12.0 and 0.0 <= val["rattler_fraction_j"] < 0.5
    assert val["pressure_bulk"] > 0
    # the profile's slabs tile the bed from the floor; a periodic frictionless bed holds
    # its weight hydrostatically: sigma_zz of a slab is the weight above its middle per area
    from analysis.packing import cumulative_measure

    assert prof.lo.iloc[0] == 0.0 and prof.hi.iloc[-1] >= val["bed_height"]
    full = prof[prof.n >= 10]
    assert len(full) >= 2
    above = frame.particle_measures().sum() - cumulative_measure(frame, 0.5 * (full.lo + full.hi))
    np.testing.assert_allclose(full.sigma_vv, G * above / 5.0**2, rtol=0.1)
