"""LIGGGHTS' deposition deck (inputs/liggghts/in.rods.deposit): multisphere rods inserted
at random fall into the walled box and settle; the converted frames hold whole rods of the
case's length inside the box, at rest on the base, and the contact table (rod-rod contacts
merged from sphere contacts, wall contacts from the walls' stored forces) balances every
rod's weight. Without the binary only the mapping of the case to the deck runs."""
import shutil

import numpy as np
import pytest

from analysis.io import RunData
from pysim.initial import write_initial
from pysim.protocols.deposit import cohesion
from tests.conftest import needs_liggghts
from tests.cases import deposit_with
from workflows import engines
from rodcase.case import validate_case
from workflows.checks import check_run

# 24 rods of d = 3 (5 spheres at spacing D/2) in a box of width 6; settled to 1e-10 of the
# peak kinetic energy (measured: ~100000 steps, 2-4 s), so that the residual vibration no
# longer hides the force balance (at the default 1e-6 rods still rattle by 6 % of a weight)
TINY = dict(particles__n=24, protocol__ke_ratio=1e-10)


@pytest.fixture(scope="module")
def deposits(tmp_path_factory):
    """A cohesionless and a cohesive (Bond number 100) deposit of the same 24 rods."""
    if shutil.which("liggghts") is None:
        pytest.skip("LIGGGHTS is not installed")
    out = {}
    for bo in (0.0, 100.0):
        d = tmp_path_factory.mktemp(f"ligdep{bo:g}")
        case = validate_case(deposit_with(**TINY, contact__bond_number=bo))
        write_initial(case, d / "init.data")
        summary = engines.run("liggghts", case, d / "init.data", d / "run", timeout=300)
        out[bo] = case, d / "run", summary
    return out


def test_case_maps_to_the_deck():
    case = validate_case(deposit_with(**TINY))
    assert engines.supports("liggghts", case) is None
    assert engines.deck("liggghts", case).name == "in.rods.deposit"
    v = engines.liggghts_deposit_vars(case)
    assert v["spheres"] == "5" and float(v["length"]) == 2.0 and float(v["radius"]) == 0.5
    # the column holds pysim's (packing fraction phi_init) and the rods' bounding spheres
    column = 24 * (np.pi / 4 * 2.0 + np.pi / 6) / (0.2 * 6.0**2)
    assert float(v["height"]) >= column + 3.0
    assert 0.0 < float(v["e_n"]) < float(v["e_wall"]) <= 1.0  # lighter m_eff: more damped
    assert float(v["f_coh"]) == 0.0
    coh = validate_case(deposit_with(**TINY, contact__bond_number=100.0))
    assert float(engines.liggghts_deposit_vars(coh)["f_coh"]) == pytest.approx(cohesion(coh)[0])
    # what the deck cannot do is said
    spheres = validate_case(deposit_with(particles__aspect_ratio=0.0))
    assert "liggghts has no deck for spheres under protocol 'deposit'" in engines.supports(
        "liggghts", spheres)
    hooke = validate_case(deposit_with(contact__law="hooke"))
    assert "Hertz" in engines.supports("liggghts", hooke)
    narrow = deposit_with(particles__aspect_ratio=5.0)  # validate_case refuses it already
    assert "bounding sphere" in engines.supports("liggghts", narrow)


def test_restitution_passed_to_liggghts_stays_above_its_limit():
    """LIGGGHTS refuses a restitution of 0.05 or less; rods of d = 2 with the quick
    deposition profile's damping do not rebound at all under pysim's law (e = 0), so the
    deck gets the floor."""
    case = validate_case(deposit_with(particles__aspect_ratio=1.0, particles__n=150,
                               container__width=8.0))
    v = engines.liggghts_deposit_vars(case)
    assert float(v["e_n"]) == engines.E_MIN > 0.05
    assert float(v["e_wall"]) > 0.05


def test_restitution_of_pysims_law():
    """Undamped: elastic; the restitution falls with the damping and rises with the
    impact speed (pysim's constant gamma_n), and vanishes when the contact never opens."""
    assert engines.hertz_restitution(1e6, 0.0, 1.0, 1.0) == 1.0
    e = [engines.hertz_restitution(1e6, g, 1.0, 1.0) for g in (10.0, 100.0, 300.0)]
    assert 1.0 > e[0] > e[1] > e[2] >= 0.0
    assert engines.hertz_restitution(1e6, 100.0, 1.0, 4.0) > e[1]
    assert engines.hertz_restitution(1e6, 1e5, 1.0, 1.0) == 0.0


@pytest.mark.engines
@needs_liggghts
def test_rods_settle_inside_the_box(deposits):
    for case, run_dir, summary in deposits.values():
        assert summary["settled"] and summary["ranks"] == 1
        assert check_run(run_dir, case) is None
        run = RunData(run_dir)
        frames = run.frames()
        steps = [f.step for f, _ in frames]
        assert steps[0] == 0 and steps == sorted(set(steps))
        frame, contacts = frames[-1]
        assert frame.step == run.thermo.step.iloc[-1]
        assert frame.n == 24 and list(frame.ids) == list(range(1, 25))
        np.testing.assert_allclose(frame.length, 2.0, rtol=1e-6)
        np.testing.assert_allclose(frame.radius, 0.5)
        w = case["container"]["width"]
        ends = np.concatenate([frame.x + frame.axis, frame.x - frame.axis])  # half length 1
        assert np.all(ends[:, :2] > 0.5 - 0.01) and np.all(ends[:, :2] < w - 0.5 + 0.01)
        assert np.all(ends[:, 2] > 0.5 - 0.01)
        # at rest: the kinetic energy fell to 1e-10 of its peak, and rods lie on the base
        assert run.thermo.ke.iloc[-1] < 1e-10 * run.thermo.ke.max()
        on_base = np.unique(contacts.i[contacts.j == -5])
        assert len(on_base) >= 1 and ends[:, 2].min() < 0.5 + 0.01
        assert set(contacts.j[contacts.j < 0]) <= {-1, -2, -3, -4, -5}
        assert np.all(contacts.i[contacts.j > 0] < contacts.j[contacts.j > 0])


@pytest.mark.engines
@needs_liggghts
def test_contact_forces_balance_the_weight(deposits):
    """Every rod: the forces of its rod-rod and wall rows plus its weight sum to zero.

    Tolerance 2 % of a rod's weight m g: a rod vibrating in its contacts with kinetic
    energy K carries an unbalanced force of about sqrt(2 m k K), k = 1.5 k_n sqrt(delta)
    the contact stiffness; if all of the final K (< 3e-9 here) were in one rod (m = 2.1)
    on its stiffest contact (delta = 0.015 D with cohesion, k = 2e5) that would be 0.02 m g.
    Measured: 5e-4 m g without cohesion, 1.2e-3 m g with. The walls together carry the
    whole weight within 1 %."""
    for bo, (case, run_dir, _summary) in deposits.items():
        frame, contacts = RunData(run_dir).frames()[-1]
        row = {int(t): k for k, t in enumerate(frame.ids)}
        net = np.zeros((frame.n, 3))
        for i, j, f in zip(contacts.i, contacts.j, contacts.force):
            net[row[int(i)]] += f
            if j > 0:
                net[row[int(j)]] -= f
        weight = case["particles"]["density"] * frame.particle_measures() * case["gravity"]
        net[:, 2] -= weight
        assert np.abs(net).max() < 0.02 * weight.max(), bo
        walls = contacts.j < 0
        assert contacts.force[walls, 2].sum() == pytest.approx(weight.sum(), rel=0.01)


@pytest.mark.engines
@needs_liggghts
def test_cohesion_holds_a_looser_deposit(deposits):
    """Bond number 100: the sjkr contacts (pull-off force F_c) overlap more than the
    cohesionless ones, about 3.6 (F_c/k_n)^(2/3) where only cohesion presses them (the
    deck's header), and the rods stick where they land: a taller, looser deposit."""
    (case0, run0, _), (case, run, _) = deposits[0.0], deposits[100.0]
    f0, c0 = RunData(run0).frames()[-1]
    f1, c1 = RunData(run).frames()[-1]
    scale = (cohesion(case)[0] / case["contact"]["k_n"]) ** (2 / 3)
    pairs = c1.j > 0
    assert np.median(c1.overlap[pairs]) > np.median(c0.overlap[c0.j > 0])
    assert 1.0 * scale < c1.overlap[pairs].max() < 6.0 * scale
    assert (f1.x[:, 2] + 0.5 * f1.length * np.abs(f1.axis[:, 2])).max() > \
        (f0.x[:, 2] + 0.5 * f0.length * np.abs(f0.axis[:, 2])).max()
