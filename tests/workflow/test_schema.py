"""Bad cases and configurations give one-line errors naming key, value and what is
allowed, exit status 2, and write nothing."""
import copy
import subprocess
import sys
from pathlib import Path

import pytest
import yaml

from rodcase.case import ConfigError, validate_case
from tests.cases import DEP, FEED, TAP, changed
from workflows.studies import load_config, validate_config

GOOD_CASE = {
    "particles": {"n": 500, "diameter": {"distribution": "mono", "mean": 1.0}},
    "contact": {"law": "hooke", "k_n": 1e5, "gamma_n": 100.0, "gamma_bg": 1.0},
    "protocol": {"name": "compress", "phi_init": 0.3, "rate": 0.005, "phi_final": 0.7, "dt": 1e-4},
    "seed": 1,
}


def with_value(path, value):
    case = copy.deepcopy(GOOD_CASE)
    d = case
    for k in path[:-1]:
        d = d[k]
    if value is KeyError:
        del d[path[-1]]
    else:
        d[path[-1]] = value
    return case


def test_good_case_gets_defaults():
    case = validate_case(GOOD_CASE)
    assert case["contact"]["friction"] == 0.0
    assert case["output"] == {"thermo_every": 1000, "dump_every": 4000}


@pytest.mark.parametrize("path, value, message", [
    (("particles", "n"), -5, r"particles\.n = -5 is not allowed; use a number >= 2"),
    (("particles", "diameter", "mean"), 0, r"particles\.diameter\.mean = 0 .*> 0"),
    (("contact", "law"), "hook", r"contact\.law = 'hook' is not allowed; use one of 'hooke'"),
    (("protocol", "name"), "shake", r"protocol\.name = 'shake'.*one of 'compress'"),
    (("protocol", "phi_final"), 1.2, r"protocol\.phi_final = 1\.2 .*< 1"),
    (("protocol", "phi_init"), 0.5, r"phi_init = 0\.5 cannot be reached by random insertion"),
    (("protocol", "dt"), 1e-2, r"protocol\.dt = 0\.01 is above 0\.1 of the contact time"),
    (("particles", "n"), "many", r"particles\.n = 'many' .*type integer"),
    (("particles", "n"), 10, r"particles\.n = 10 is too small for a periodic box"),
    (("contact", "k_n"), KeyError, r"contact\.k_n is required \(or give restitution and contact_time\)"),
])
def test_bad_case_values(path, value, message):
    with pytest.raises(ConfigError, match=message) as exc:
        validate_case(with_value(path, value), "case.yaml")
    assert "\n" not in str(exc.value)
    assert str(exc.value).startswith("case.yaml: ")


def test_unknown_key_is_a_typo():
    case = copy.deepcopy(GOOD_CASE)
    case["protocol"]["phi_fnial"] = 0.7
    with pytest.raises(ConfigError, match=r"unknown key 'protocol\.phi_fnial'; allowed here: dt, integrator, k_d, name"):
        validate_case(case, "case.yaml")


def config_with(**study_changes):
    study = {"engines": ["pysim", "lammps"], "seeds": [1], "case": copy.deepcopy(GOOD_CASE)}
    del study["case"]["seed"]
    study.update(study_changes)
    return {"studies": {"s": study}}


def test_config_errors():
    with pytest.raises(ConfigError, match=r"studies\.s\.engines\.0 = 'gromacs'"):
        validate_config(config_with(engines=["gromacs"]), "cfg.yaml")
    with pytest.raises(ConfigError, match=r"studies\.s\.seeds = \[\] .*1 items"):
        validate_config(config_with(seeds=[]), "cfg.yaml")
    with pytest.raises(ConfigError, match=r"studies = \{\} .*at least 1 entries"):
        validate_config({"studies": {}}, "cfg.yaml")
    bad_variant = config_with(variants={"fast": {"protocol": {"rate": -1}}})
    with pytest.raises(ConfigError, match=r"studies\.s\.variants\.fast\.protocol\.rate = -1"):
        validate_config(bad_variant, "cfg.yaml")


def test_yaml_exponents_without_sign_are_numbers(tmp_path):
    p = tmp_path / "cfg.yaml"
    p.write_text(yaml.safe_dump(config_with()).replace("100000.0", "1.0e5"))
    cfg = load_config(p)
    assert cfg["_cases"][("s", "base", 1)]["contact"]["k_n"] == 1e5


def test_cli_bad_case_exit_2_no_traceback_no_output(tmp_path):
    case = with_value(("protocol", "phi_final"), 1.5)
    p = tmp_path / "case.yaml"
    p.write_text(yaml.safe_dump(case))
    out = tmp_path / "out"
    r = subprocess.run([sys.executable, "-m", "pysim", "run", str(p), "--out", str(out)],
                       capture_output=True, text=True)
    assert r.returncode == 2
    assert "Traceback" not in r.stderr
    assert r.stderr.strip().count("\n") == 0
    assert "protocol.phi_final = 1.5" in r.stderr
    assert not out.exists()


def tap_case(**changes):
    return changed(TAP, **changes)


@pytest.mark.parametrize("changes, message", [
    ({"container": KeyError}, r"container is required by protocol 'tapping'"),
    ({"gravity": 0.0}, r"gravity = 0\.0 must be > 0 for protocol 'tapping'"),
    ({"particles__dimension": 2}, r"particles\.dimension = 2: protocol 'tapping' is 3-D"),
    ({"container__diameter": 2e-3}, r"container\.diameter = 0\.002 must exceed 1\.5 times the "
                                    r"longest grain \(L \+ D = 0\.001569\)"),
    ({"container__shape": "box"}, r"container\.shape = 'box': protocol 'tapping' runs in a "
                                  r"cylinder; use 'cylinder'"),
    ({"container__shape": "cone"}, r"container\.shape = 'cone' is not allowed; use one of "
                                   r"'cylinder', 'box'"),
    ({"contact__contact_time": KeyError}, r"restitution and contact_time go together"),
    ({"contact__restitution": 1.5}, r"contact\.restitution = 1\.5 .*<= 1"),
    ({"contact__law": "hertz"}, r"contact\.restitution needs law: hooke, not 'hertz'"),
    ({"contact__k_n": 50.0}, r"contact\.k_n = 50\.0 contradicts restitution 0\.4 and "
                             r"contact_time 0\.0006 \(which give [0-9.]+\)"),
    ({"protocol__intensity": KeyError}, r"missing key 'protocol\.intensity'"),
    ({"protocol__phi_init": 0.4}, r"protocol\.phi_init = 0\.4 .*<= 0\.3"),
])
def test_bad_tapping_cases(changes, message):
    with pytest.raises(ConfigError, match=message) as exc:
        validate_case(tap_case(**changes), "case.yaml")
    assert "\n" not in str(exc.value)


def test_limit_damping_reaches_every_engines_deck():
    """The clip is pysim's kernel flag, LAMMPS' ``limit_damping`` keyword and LIGGGHTS'
    ``limitForce`` option; LAMMPS' body styles have none and refuse the case."""
    from workflows.engines import deck_vars, supports

    case = validate_case(tap_case(contact__limit_damping=True), "case.yaml")
    assert case["contact"]["limit_damping"] is True
    for engine in ("pysim", "lammps", "liggghts"):
        assert supports(engine, case) is None
    assert deck_vars(case, "lammps")["limit_damping"] == "1"
    assert deck_vars(case, "liggghts")["limit_force"] == "on"
    plain = validate_case(tap_case(), "case.yaml")
    assert "limit_damping" not in deck_vars(plain, "lammps")  # the decks' default: off
    assert "limit_force" not in deck_vars(plain, "liggghts")
    assert "no limit_damping option" in supports("lammps-body", case)
    with pytest.raises(ConfigError, match=r"limit_damping"):
        validate_case(tap_case(contact__limit_damping="yes"), "case.yaml")


def test_container_only_for_tapping():
    case = copy.deepcopy(GOOD_CASE)
    case["container"] = {"shape": "cylinder", "diameter": 20.0}
    with pytest.raises(ConfigError, match=r"container is only used by protocols 'tapping' and "
                                          r"'deposit', not 'compress'; remove it"):
        validate_case(case, "case.yaml")


def dep_case(**changes):
    return changed(DEP, **changes)


@pytest.mark.parametrize("changes, message", [
    ({"container": KeyError}, r"protocol 'deposit' needs container: \{shape: box, width: \.\.\.\}"),
    ({"container": {"shape": "cylinder", "diameter": 6.0}},
     r"protocol 'deposit' needs container: \{shape: box"),
    ({"container__diameter": 6.0}, r"container\.diameter is not used by shape 'box' \(it takes "
                                   r"width\); remove it"),
    ({"container__width": 4.0}, r"container\.width = 4\.0 must exceed 1\.5 times the longest "
                                r"grain \(L \+ D = 3\)"),
    ({"gravity": 0.0}, r"gravity = 0\.0 must be > 0 for protocol 'deposit'"),
    ({"contact__bond_number": -1.0}, r"contact\.bond_number = -1\.0 .*>= 0"),
    ({"protocol__max_time": KeyError}, r"missing key 'protocol\.max_time'"),
    ({"protocol__ke_ratio": 0.0}, r"protocol\.ke_ratio = 0\.0 .*> 0"),
])
def test_bad_deposit_cases(changes, message):
    with pytest.raises(ConfigError, match=message) as exc:
        validate_case(dep_case(**changes), "case.yaml")
    assert "\n" not in str(exc.value)


def test_bond_number_needs_gravity():
    case = copy.deepcopy(GOOD_CASE)
    case["contact"]["bond_number"] = 10.0
    with pytest.raises(ConfigError, match=r"contact\.bond_number = 10\.0 needs gravity > 0 "
                                          r"\(F_c = Bo_g m g\), not 0\.0"):
        validate_case(case, "case.yaml")


def test_tapping_container_needs_its_diameter():
    with pytest.raises(ConfigError, match=r"container\.diameter is required for shape "
                                          r"'cylinder'"):
        validate_case(tap_case(container={"shape": "cylinder", "width": 5e-3}), "case.yaml")


def test_engine_seeds_run_an_engine_on_fewer_seeds():
    """studies.<study>.engine_seeds: LAMMPS on seed 1 beside pysim on seeds 1-3; seeds
    outside the study's, or an engine the study does not run, are clear errors."""
    from workflows.studies import runs

    config = validate_config(config_with(seeds=[1, 2, 3], engine_seeds={"lammps": [1]}))
    got = sorted((r.engine, r.seed) for r in runs(config))
    assert got == [("lammps", 1), ("pysim", 1), ("pysim", 2), ("pysim", 3)]
    with pytest.raises(ConfigError, match=r"engine_seeds\.lammps = \[1, 4\] has seeds \[4\] "
                                          r"that are not in studies\.s\.seeds = \[1, 2, 3\]"):
        validate_config(config_with(seeds=[1, 2, 3], engine_seeds={"lammps": [1, 4]}), "c.yaml")
    with pytest.raises(ConfigError, match=r"engine_seeds\.liggghts: liggghts is not among"):
        validate_config(config_with(engine_seeds={"liggghts": [1]}), "c.yaml")
    with pytest.raises(ConfigError, match=r"engine_seeds.*gromacs"):
        validate_config(config_with(engine_seeds={"gromacs": [1]}), "c.yaml")


@pytest.mark.parametrize("path", sorted((Path(__file__).resolve().parents[2] / "workflows" /
                                         "config").glob("*.yaml")), ids=lambda p: p.name)
def test_every_shipped_profile_validates(path):
    from workflows.studies import runs

    config = load_config(path)
    assert runs(config), f"{path.name} expands to no run"


FREE = {"mode": "free", "ke_stop": 1e-8, "max_time": 2.0}


def test_paper_variants_validate_and_run_on_pysim_only():
    """contact.tangential_spring: keep and protocol.preparation.mode: free are pysim's:
    the LAMMPS and LIGGGHTS runs of such a case are skipped with a message naming the key;
    without them (the defaults) every engine still runs the case."""
    from workflows.studies import runs
    from workflows.engines import supports

    plain = validate_case(tap_case(), "case.yaml")
    assert "tangential_spring" not in plain["contact"]  # absent means reset: the same case
    assert "preparation" not in plain["protocol"]
    assert "integrator" not in plain["protocol"]
    keep = validate_case(tap_case(contact__tangential_spring="keep"), "case.yaml")
    free = validate_case(tap_case(protocol__preparation=dict(FREE)), "case.yaml")
    assert free["protocol"]["preparation"]["check_time"] == pytest.approx(0.25 / 30.0)
    euler = validate_case(tap_case(protocol__integrator="euler"), "case.yaml")
    verlet = validate_case(tap_case(protocol__integrator="verlet"), "case.yaml")
    assert supports("lammps", verlet) is None
    for case, key in ((keep, "contact.tangential_spring = keep"),
                      (free, "protocol.preparation.mode = free"),
                      (euler, "protocol.integrator = euler")):
        assert supports("pysim", case) is None
        for engine in ("lammps", "liggghts"):
            assert key in supports(engine, case)
    for engine in ("pysim", "lammps"):
        assert supports(engine, plain) is None
    study = {"engines": ["pysim", "lammps"], "seeds": [1], "case": tap_case(seed=KeyError),
             "variants": {"keep": {"contact": {"tangential_spring": "keep"}}, "reset": {}}}
    skipped = []
    got = runs(validate_config({"studies": {"s": study}}), skipped)
    assert sorted((r.variant, r.engine) for r in got) == [
        ("keep", "pysim"), ("reset", "lammps"), ("reset", "pysim")]
    assert len(skipped) == 1 and "variant 'keep'" in skipped[0] and "lammps" in skipped[0]
    assert "contact.tangential_spring = keep" in skipped[0]


@pytest.mark.parametrize("changes, message", [
    ({"contact__tangential_spring": "slide"},
     r"contact\.tangential_spring = 'slide' is not allowed; use one of 'reset', 'keep'"),
    ({"protocol__preparation": {"mode": "free", "max_time": 2.0}},
     r"missing key 'protocol\.preparation\.ke_stop' \(required by mode free\)"),
    ({"protocol__preparation": {"mode": "free", "ke_stop": 1e-8}},
     r"missing key 'protocol\.preparation\.max_time'"),
    ({"protocol__preparation": {"mode": "capped", "ke_stop": 1e-8}},
     r"protocol\.preparation\.ke_stop is used by mode free only, not 'capped'; remove it"),
    ({"protocol__preparation": {**FREE, "check_time": 1e-6}},
     r"protocol\.preparation\.check_time = 1e-06 is below the time step dt = 2e-05"),
    ({"protocol__preparation": {**FREE, "max_time": 1e-3}},
     r"protocol\.preparation\.max_time = 0\.001 is below check_time = 0\.00833333"),
    ({"protocol__preparation": {**FREE, "ke_stop": 0.0}},
     r"protocol\.preparation\.ke_stop = 0\.0 is not allowed; use a number > 0"),
    ({"protocol__preparation": {"mode": "still"}},
     r"protocol\.preparation\.mode = 'still' is not allowed; use one of 'capped', 'free'"),
    ({"protocol__integrator": "rk4"},
     r"protocol\.integrator = 'rk4' is not allowed; use one of 'verlet', 'euler', "
     r"'semi_implicit_euler'"),
])
def test_bad_paper_variants(changes, message):
    with pytest.raises(ConfigError, match=message) as exc:
        validate_case(tap_case(**changes), "case.yaml")
    assert "\n" not in str(exc.value)


def test_wall_friction_alone_gets_the_derived_tangential_spring():
    """friction 0 with wall_friction > 0: the walls need k_t and gamma_t; the schema
    derives them from the restitution law as it does for friction (before, k_t stayed 0
    and the walls were frictionless without a word)."""
    case = validate_case(tap_case(contact__friction=0.0, contact__wall_friction=0.3))
    c = case["contact"]
    assert c["k_t"] == pytest.approx(2 / 7 * c["k_n"]) and c["gamma_t"] == pytest.approx(
        c["gamma_n"] / 2)
    smooth = validate_case(tap_case(contact__friction=0.0))
    assert smooth["contact"]["k_t"] == 0.0 and smooth["contact"]["gamma_t"] == 0.0
    # given k_n: the linear law's default too; another law must give k_t
    direct = validate_case(with_value(("contact", "wall_friction"), 0.3))
    assert direct["contact"]["k_t"] == pytest.approx(2 / 7 * 1e5)
    hertz = with_value(("contact", "wall_friction"), 0.3)
    hertz["contact"]["law"] = "hertz"
    with pytest.raises(ConfigError, match=r"contact\.k_t = 0\.0 must be > 0 when wall_friction "
                                          r"= 0\.3 > 0"):
        validate_case(hertz, "case.yaml")


def feed_case(**changes):
    return changed(FEED, **changes)


@pytest.mark.parametrize("changes, message", [
    ({"particles__dimension": 3}, r"protocol\.feed is implemented in 2-D only \(pysim\); got "
                                  r"particles\.dimension = 3"),
    ({"protocol__rain_speed": 1.0, "protocol__rain_time": 5.0},
     r"protocol\.feed and protocol\.rain_speed exclude each other"),
    ({"protocol__feed__rate": 6000.0}, r"protocol\.feed\.rate = 6000\.0 feeds more than one "
                                       r"grain per step \(dt = 0\.0002\); use rate <= 5000"),
    ({"protocol__feed__rate": 0.0}, r"protocol\.feed\.rate = 0\.0 is not allowed; use a number "
                                    r"> 0"),
    ({"protocol__feed__rate": KeyError}, r"missing key 'protocol\.feed\.rate'"),
    ({"protocol__feed__height": KeyError}, r"missing key 'protocol\.feed\.height'"),
    ({"protocol__feed__speed": -1.0}, r"protocol\.feed\.speed = -1\.0 .*>= 0"),
    ({"protocol__feed__gap": 1.0}, r"unknown key 'protocol\.feed\.gap'; allowed here: height, "
                                   r"rate, speed"),
    ({"protocol__feed__height": 6.0}, r"protocol\.feed\.height = 6\.0 is not above the deposit "
                                      r"even at packing fraction 1 \(5\.356\) plus half a grain "
                                      r"\(1\); use a height > 6\.356"),
])
def test_bad_feed_cases(changes, message):
    with pytest.raises(ConfigError, match=message) as exc:
        validate_case(feed_case(**changes), "case.yaml")
    assert "\n" not in str(exc.value) and str(exc.value).startswith("case.yaml: ")


def test_bond_stiffening_is_off_unless_asked():
    """contact.bond_stiffening: absent, the law is the case's at every Bond number."""
    case = validate_case(dep_case(contact__bond_number=1e4))
    c = case["contact"]
    assert (c["k_n"], c["k_t"], c["gamma_n"], c["gamma_t"]) == (1e6, 1e5, 300.0, 100.0)
    assert case["protocol"]["dt"] == 1e-4 and "bond_stiffening" not in c


def test_bond_stiffening_scales_the_law_once():
    """Above the reference Bond number, s = Bo_g / reference: k_n, k_t times s, the
    dampings times sqrt(s), dt times s^(-2/5) (deposition.yaml's hand-stiffened Bo_g = 1e4
    variants: 1e8, 1e7, 3000, 1000 and 1.6e-5 from s = 100); validating the stiffened case
    again (the engines read case.yaml back) changes nothing; below the reference nothing
    changes; a factor that does not match is an error."""
    case = validate_case(dep_case(contact__bond_number=1e4,
                                  contact__bond_stiffening={"reference": 100.0}))
    c = case["contact"]
    assert c["k_n"] == pytest.approx(1e8) and c["k_t"] == pytest.approx(1e7)
    assert c["gamma_n"] == pytest.approx(3000.0) and c["gamma_t"] == pytest.approx(1000.0)
    assert case["protocol"]["dt"] == pytest.approx(1e-4 * 100 ** -0.4)
    assert case["protocol"]["dt"] == pytest.approx(1.6e-5, rel=0.01)
    assert c["bond_stiffening"] == {"reference": 100.0, "factor": 100.0}
    assert validate_case(case) == case
    weak = validate_case(dep_case(contact__bond_number=50.0,
                                  contact__bond_stiffening={"reference": 100.0}))
    assert weak["contact"]["k_n"] == 1e6 and weak["contact"]["bond_stiffening"]["factor"] == 1.0
    bad = copy.deepcopy(case)
    bad["contact"]["bond_number"] = 1e3
    with pytest.raises(ConfigError, match=r"contact\.bond_stiffening\.factor = 100\.0 does not "
                                          r"match bond_number / reference = 10; remove factor"):
        validate_case(bad, "case.yaml")
