"""Every bad case gets the same treatment: validation before anything runs, a one-line
error that names the file, the key, the bad value and what is allowed, exit status 2,
no traceback, and nothing written."""
import copy
import subprocess
import sys

import numpy as np
import pytest
import yaml

from rodcase.case import ConfigError, validate_case
from workflows.studies import validate_config

GOOD = {
    "particles": {"n": 500, "diameter": {"distribution": "mono", "mean": 1.0}},
    "contact": {"law": "hooke", "k_n": 1e5, "gamma_n": 100.0, "gamma_bg": 1.0},
    "protocol": {"name": "compress", "phi_init": 0.3, "rate": 0.005, "phi_final": 0.7, "dt": 1e-4},
    "seed": 1,
}


class _Drop:
    """The key is left out of the case (a stable repr: test ids must be the same in
    every pytest-xdist worker)."""

    def __repr__(self):
        return "DROP"


DROP = _Drop()

# (path, bad value, the message after "<file>: ")
CASES = [
    (("particles", "n"), 0, "particles.n = 0 is not allowed; use a number >= 2 and <= 20000000"),
    (("particles", "n"), -3, "particles.n = -3 is not allowed; use a number >= 2 and <= 20000000"),
    (("particles", "n"), 2.5, "particles.n = 2.5 is not allowed; use a value of type integer"),
    (("particles", "n"), "many", "particles.n = 'many' is not allowed; use a value of type integer"),
    (("particles", "n"), 10, "particles.n = 10 is too small for a periodic box at packing fraction "
                             "0.7 (side 1.96 < twice the particle length plus skin); use n >= 19"),
    (("particles", "diameter", "mean"), 0,
     "particles.diameter.mean = 0 is not allowed; use a number > 0"),
    (("particles", "diameter", "mean"), -1.0,
     "particles.diameter.mean = -1.0 is not allowed; use a number > 0"),
    (("particles", "diameter", "distribution"), "gauss",
     "particles.diameter.distribution = 'gauss' is not allowed; use one of 'mono', 'lognormal', "
     "'bidisperse'"),
    (("particles", "diameter", "sigma"), 0.2,
     "particles.diameter.sigma = 0.2 needs distribution: lognormal (mono diameters have sigma 0)"),
    (("particles", "diameter", "sigma"), 1.5,
     "particles.diameter.sigma = 1.5 is not allowed; use a number >= 0 and <= 1"),
    (("particles", "aspect_ratio"), -1.0,
     "particles.aspect_ratio = -1.0 is not allowed; use a number >= 0 and <= 100"),
    (("particles", "dimension"), 4, "particles.dimension = 4 is not allowed; use one of 2, 3"),
    (("particles", "density"), 0, "particles.density = 0 is not allowed; use a number > 0"),
    (("particles", "glued_spacing"), 0,
     "particles.glued_spacing = 0 is not allowed; use a number > 0 and <= 1"),
    (("contact", "law"), "hook",
     "contact.law = 'hook' is not allowed; use one of 'hooke', 'hertz', 'harmonic'"),
    (("contact", "k_n"), 0, "contact.k_n = 0 is not allowed; use a number > 0"),
    (("contact", "k_n"), DROP,
     "contact.k_n is required (or give restitution and contact_time)"),
    (("contact", "gamma_n"), -1, "contact.gamma_n = -1 is not allowed; use a number >= 0"),
    (("contact", "friction"), -0.1,
     "contact.friction = -0.1 is not allowed; use a number >= 0 and <= 10"),
    (("contact", "spine_contact"), "end_bonds_distinct",
     "contact.spine_contact = end_bonds_distinct is for 2-D rods; got dimension 3"),
    (("contact", "spine_contact"), "sides",
     "contact.spine_contact = 'sides' is not allowed; use one of 'closest', 'end_bonds', "
     "'end_bonds_distinct'"),
    (("contact", "stiffness"), 5,
     "unknown key 'contact.stiffness'; allowed here: bond_number, bond_stiffening, cohesion_range, contact_time, "
     "friction, gamma_bg, gamma_n, "
     "gamma_rot, gamma_t, k_n, k_t, law, limit_damping, max_overlap, restitution, "
     "spine_contact, tangential_spring, wall_cohesion, wall_friction"),
    (("contact", "wall_cohesion"), True,
     "contact.wall_cohesion is for the deposit protocol; got protocol compress"),
    (("protocol", "name"), "shake",
     "protocol.name = 'shake' is not allowed; use one of 'compress', 'growth', 'jammed', "
     "'quasistatic', 'tapping', 'deposit', 'ls', 'mls', 'fb'"),
    (("protocol", "name"), DROP, "missing key 'protocol.name'"),
    (("protocol", "phi_init"), 0.5, "protocol.phi_init = 0.5 cannot be reached by random "
                                    "insertion in 3-D; use a value <= 0.35 and compress"),
    (("protocol", "phi_init"), 0, "protocol.phi_init = 0 is not allowed; use a number > 0 and < 1"),
    (("protocol", "phi_final"), 1.2,
     "protocol.phi_final = 1.2 is not allowed; use a number > 0 and < 1"),
    (("protocol", "phi_final"), 0.2, "protocol.phi_final = 0.2 must be above phi_init = 0.3"),
    (("protocol", "dt"), 1e-2, "protocol.dt = 0.01 is above 0.1 of the contact time t_c = "
                               "0.00534; use dt <= 0.000534 (t_c/50 is usual)"),
    (("protocol", "dt"), 0, "protocol.dt = 0 is not allowed; use a number > 0"),
    (("protocol", "rate"), -0.1, "protocol.rate = -0.1 is not allowed; use a number > 0"),
    (("protocol", "phi_fast"), 0.5,
     "protocol: phi_fast and rate_fast go together; give both or neither"),
    (("protocol", "phi_fnial"), 0.7,
     "unknown key 'protocol.phi_fnial'; allowed here: dt, integrator, k_d, name, phi_fast, "
     "phi_final, phi_init, pressure_final, rate, rate_fast, settle"),
    (("seed",), -1, "seed = -1 is not allowed; use a number >= 0"),
    (("seed",), DROP, "missing key 'seed'"),
    (("output",), {"dump_every": 0}, "output.dump_every = 0 is not allowed; use a number >= 1"),
    (("output",), {"thermo_every": "often"},
     "output.thermo_every = 'often' is not allowed; use a value of type integer"),
    (("extra",), 1,
     "unknown key 'extra'; allowed here: contact, container, gravity, output, particles, "
     "protocol, seed"),
]


def mutate(path, value):
    case = copy.deepcopy(GOOD)
    d = case
    for k in path[:-1]:
        d = d[k]
    if value is DROP:
        del d[path[-1]]
    else:
        d[path[-1]] = value
    return case


def test_there_are_at_least_thirty():
    assert len(CASES) >= 30


@pytest.mark.parametrize("path, value, message", CASES, ids=[".".join(c[0]) + f"={c[1]!r}" for c in CASES])
def test_case_validation_message(path, value, message):
    with pytest.raises(ConfigError) as exc:
        validate_case(mutate(path, value), "case.yaml")
    assert str(exc.value) == f"case.yaml: {message}"


def test_too_many_particles_for_memory():
    with pytest.raises(ConfigError, match=r"^case.yaml: particles.n = 20000000 needs about 38.1 "
                                          r"GiB, more than this machine's [0-9.]+ GiB; use fewer "
                                          r"particles$"):
        validate_case(mutate(("particles", "n"), 20_000_000), "case.yaml")


@pytest.mark.parametrize("path, value, message", CASES[::3], ids=[".".join(c[0]) for c in CASES[::3]])
def test_cli_exit_2_one_line_nothing_written(tmp_path, path, value, message):
    cp = tmp_path / "case.yaml"
    cp.write_text(yaml.safe_dump(mutate(path, value)))
    for cmd in (["run", str(cp), "--out", str(tmp_path / "out")],
                ["init", str(cp), "--out", str(tmp_path / "init.data")]):
        r = subprocess.run([sys.executable, "-m", "pysim", *cmd], capture_output=True, text=True)
        assert r.returncode == 2
        assert r.stderr == f"error: {cp}: {message}\n"
        assert r.stdout == ""
    assert sorted(p.name for p in tmp_path.iterdir()) == ["case.yaml"]


def test_not_yaml_and_missing_file(tmp_path):
    bad = tmp_path / "case.yaml"
    bad.write_text("particles: [1, 2\n")
    r = subprocess.run([sys.executable, "-m", "pysim", "run", str(bad), "--out", str(tmp_path / "o")],
                       capture_output=True, text=True)
    assert r.returncode == 2 and r.stderr.startswith(f"error: {bad}:") and "not valid YAML" in r.stderr
    assert r.stderr.count("\n") == 1
    missing = tmp_path / "nope.yaml"
    r = subprocess.run([sys.executable, "-m", "pysim", "run", str(missing), "--out", str(tmp_path / "o")],
                       capture_output=True, text=True)
    assert (r.returncode, r.stderr) == (2, f"error: {missing}: no such file\n")
    assert not (tmp_path / "o").exists()


CONFIG_CASES = [
    ({"studies": {}}, "studies = {} is not allowed; use at least 1 entries"),
    ({"studies": {"s": {"engines": [], "seeds": [1], "case": {}}}},
     "studies.s.engines = [] is not allowed; use a list with min 1 items"),
    ({"studies": {"s": {"engines": ["gromacs"], "seeds": [1], "case": {}}}},
     "studies.s.engines.0 = 'gromacs' is not allowed; use one of 'pysim', 'lammps', 'lammps-body', "
     "'liggghts'"),
    ({"studies": {"s": {"engines": ["pysim"], "seeds": [], "case": {}}}},
     "studies.s.seeds = [] is not allowed; use a list with min 1 items"),
    ({"studies": {"Bad-Name": {"engines": ["pysim"], "seeds": [1], "case": {}}}},
     "studies: name 'Bad-Name' is not allowed; use a name matching ^[a-z][a-z0-9_]*$"),
    ({"studies": {"s": {"engines": ["pysim"], "seeds": [1], "case": {}, "variant": {}}}},
     "unknown key 'studies.s.variant'; allowed here: analysis, case, description, "
     "engine_seeds, engines, extends, seeds, variants"),
    ({"engines": {"lammps": {"ranks": 0}}, "studies": {"s": {"engines": ["pysim"], "seeds": [1],
                                                            "case": {}}}},
     "engines.lammps.ranks = 0 is not allowed; use a number >= 1"),
    ({"engines": {"pysim": {"timeout": float("inf")}},
      "studies": {"s": {"engines": ["pysim"], "seeds": [1], "case": {}}}},
     "engines.pysim.timeout = inf is not allowed; use a finite number > 0"),
    ({"studies": {"s": {"engines": ["pysim"], "seeds": [1], "case": {},
                        "analysis": {"c_min": -1}}}},
     "studies.s.analysis.c_min = -1 is not allowed; use a number >= 0 and <= 100"),
    ({"studies": {"s": {"engines": ["pysim"], "seeds": [1], "case": {},
                        "analysis": {"c_min": 2.5}}}},
     "studies.s.analysis.c_min = 2.5 is not allowed; use a value of type integer"),
    ({"studies": {"s": {"engines": ["pysim"], "seeds": [1], "case": {},
                        "analysis": {"cmin": 3}}}},
     "unknown key 'studies.s.analysis.cmin'; allowed here: c_min, caging, jamming_window, "
     "modes_energies, modes_variants"),
    ({"studies": {"s": {"engines": ["pysim"], "seeds": [1], "case": {},
                        "variants": {"a1": {}, "a4": {}},
                        "analysis": {"modes_variants": ["a1", "a2"]}}}},
     "studies.s.analysis.modes_variants names ['a2'], not among the study's variants "
     "['a1', 'a4']"),
    ({"studies": {"s": {"engines": ["pysim"], "seeds": [1], "case": {},
                        "analysis": {"jamming_window": [float("nan"), 1e-2]}}}},
     "studies.s.analysis.jamming_window.0 = nan is not allowed; use a finite number > 0"),
]


@pytest.mark.parametrize("config, message", CONFIG_CASES)
def test_config_validation_message(config, message):
    with pytest.raises(ConfigError) as exc:
        validate_config(config, "cfg.yaml")
    assert str(exc.value) == f"cfg.yaml: {message}"


def test_variant_errors_name_the_variant():
    study = {"engines": ["pysim"], "seeds": [1], "case": {k: v for k, v in GOOD.items() if k != "seed"},
             "variants": {"fast": {"protocol": {"rate": -1}}}}
    with pytest.raises(ConfigError) as exc:
        validate_config({"studies": {"s": study}}, "cfg.yaml")
    assert str(exc.value) == ("cfg.yaml: studies.s.variants.fast.protocol.rate = -1 is not "
                              "allowed; use a number > 0")


def test_growth_box_is_checked_up_to_phi_max():
    """Long rods jam far below 0.75: growth's phi_max bounds the box check, so fewer rods
    fill it, and phi_grow must lie below it."""
    rods = {"particles": {"n": 1000, "aspect_ratio": 11.0, "diameter": {"mean": 1.0}},
            "contact": {"law": "hooke", "k_n": 1e5, "gamma_n": 10.0, "gamma_bg": 0.1},
            "protocol": {"name": "growth", "phi_init": 0.05, "rate": 0.05, "phi_grow": 0.3,
                         "dt": 1e-4},
            "seed": 1}
    with pytest.raises(ConfigError, match=r"particles.n = 1000 is too small for a periodic box "
                                          r"at packing fraction 0.75 \(side 23 < twice"):
        validate_case(copy.deepcopy(rods), "case.yaml")
    ok = copy.deepcopy(rods)
    ok["protocol"]["phi_max"] = 0.45  # side 27.3 > 2 (L + D + 0.2 D) = 24.4
    assert validate_case(ok, "case.yaml")["protocol"]["phi_max"] == 0.45
    bad = copy.deepcopy(ok)
    bad["protocol"]["phi_grow"] = 0.5
    with pytest.raises(ConfigError, match=r"^case.yaml: protocol.phi_grow = 0.5 must be below "
                                          r"phi_max = 0.45$"):
        validate_case(bad, "case.yaml")


def cli(tmp_path, *args, env=None):
    """``python -m pysim ARGS`` (the venv's python); the output folder is tmp_path/out."""
    return subprocess.run([sys.executable, "-m", "pysim", *map(str, args)], capture_output=True,
                          text=True, env=env)


def assert_refused(r, tmp_path, start):
    """Exit status 2, one line on stderr that starts with ``start``, nothing on stdout and
    no output folder."""
    assert r.returncode == 2, r.stderr
    assert r.stderr.startswith(start), r.stderr
    assert r.stderr.count("\n") == 1 and "Traceback" not in r.stderr
    assert r.stdout == ""
    assert not (tmp_path / "out").exists()


def good_case_file(tmp_path):
    cp = tmp_path / "case.yaml"
    cp.write_text(yaml.safe_dump(GOOD))
    return cp


@pytest.mark.parametrize("content, message", [
    (None, "no such file; give a LAMMPS data file of atom_style sphere or ellipsoid, as "
           "python -m pysim init writes"),
    ("garbage\n", "not a LAMMPS data file (no 'N atoms' line with N >= 1 in its header); give "
                  "a LAMMPS data file of atom_style sphere or ellipsoid, as python -m pysim "
                  "init writes"),
    (b"\x89PNG\r\n\x1a\n\x00\xff\xfe", "not a text file; give a LAMMPS data file"),
    ("# t\n\n2 atoms\n0 9 xlo xhi\n0 9 ylo yhi\n0 9 zlo zhi\n\nAtoms\n\n1 1 1 1 1 1 1\n",
     "the header says 2 atoms, the Atoms section has 1 lines"),
    ("# t\n\n1 atoms\n0 9 xlo xhi\n0 9 ylo yhi\n\nAtoms\n\n1 1 1 1 1 1 1\n",
     "the header needs the box, lines 'lo hi xlo xhi', 'lo hi ylo yhi' and 'lo hi zlo zhi' "
     "with lo < hi"),
    ("# t\n\n1 atoms\n0 9 xlo xhi\n0 9 ylo yhi\n0 9 zlo zhi\n\nAtoms\n\n1 1 1 1\n",
     "an Atoms line has 4 columns; atom_style sphere and ellipsoid lines have 7 or more"),
    ("# t\n\n1 atoms\n0 9 xlo xhi\n0 9 ylo yhi\n0 9 zlo zhi\n\nAtoms\n\n1 1 1 1 1 nan 1\n",
     "holds a value that is not finite (nan or inf)"),
])
def test_cli_bad_data_file_is_one_line_before_anything_is_written(tmp_path, content, message):
    """A missing or broken --data file: one line naming the file and what a data file
    holds, exit status 2, and no output folder (it used to be a traceback after the folder
    was made)."""
    data = tmp_path / "init.data"
    if isinstance(content, bytes):
        data.write_bytes(content)
    elif content is not None:
        data.write_text(content)
    r = cli(tmp_path, "run", good_case_file(tmp_path), "--out", tmp_path / "out", "--data", data)
    assert_refused(r, tmp_path, f"error: {data}: {message}")


def test_cli_data_file_of_another_case(tmp_path):
    from pysim.io import write_sphere_data

    data = tmp_path / "init.data"
    write_sphere_data(data, np.full((3, 3), 1.0) * np.arange(3)[:, None], np.ones(3),
                      [9.0, 9.0, 9.0], 1.0)
    r = cli(tmp_path, "run", good_case_file(tmp_path), "--out", tmp_path / "out", "--data", data)
    assert_refused(r, tmp_path, f"error: {data} holds 3 particles, the case says particles.n = "
                                "500; give the data file of this case")


@pytest.mark.parametrize("old, new, message", [
    ("k_n: 100000.0", "k_n: .nan", "contact.k_n = nan is not allowed; use a finite number > 0"),
    ("gamma_bg: 1.0", "gamma_bg: .inf",
     "contact.gamma_bg = inf is not allowed; use a finite number >= 0"),
    ("rate: 0.005", "rate: -.inf", "protocol.rate = -inf is not allowed; use a finite number > 0"),
    ("seed: 1", "seed: .nan", "seed = nan is not allowed; use an integer >= 0"),
    ("  n: 500\n", "  n: 500\n  n: 600\n",
     ":11: key 'n' is given twice in one mapping (lines 10 and 11); keep one"),
    ("seed: 1\n", "seed: 1\nseed: 2\n",
     ":18: key 'seed' is given twice in one mapping (lines 17 and 18); keep one"),
])
def test_cli_non_finite_numbers_and_repeated_keys(tmp_path, old, new, message):
    """NaN and infinity pass every bound of the schema and a repeated key used to keep its
    last value silently: both are one-line errors now."""
    cp = good_case_file(tmp_path)
    text = cp.read_text()
    assert old in text
    cp.write_text(text.replace(old, new))
    r = cli(tmp_path, "run", cp, "--out", tmp_path / "out")
    sep = "" if message.startswith(":") else ": "
    assert_refused(r, tmp_path, f"error: {cp}{sep}{message}\n")


def test_repeated_keys_of_a_merge_may_be_overridden(tmp_path):
    """YAML merge keys (``<<``, as the shipped profiles use them) are overridden on purpose."""
    from rodcase.case import read_yaml

    p = tmp_path / "c.yaml"
    p.write_text("a: &base {x: 1, y: 2}\nb: {<<: *base, y: 3}\n")
    assert read_yaml(p) == {"a": {"x": 1, "y": 2}, "b": {"x": 1, "y": 3}}


@pytest.mark.parametrize("threads", [0, -1, 3])
def test_cli_threads_out_of_range(tmp_path, threads):
    import os

    env = dict(os.environ, NUMBA_NUM_THREADS="2")
    for cmd in (["run", good_case_file(tmp_path), "--out", tmp_path / "out"],
                ["init", good_case_file(tmp_path), "--out", tmp_path / "out"]):
        r = cli(tmp_path, *cmd, "--threads", threads, env=env)
        assert_refused(r, tmp_path, f"error: --threads {threads} is not allowed; use 1 to 2 "
                                    "(at most Numba's pool, NUMBA_NUM_THREADS")


def test_friction_without_k_t_takes_the_linear_laws_default():
    """With the linear law, friction alone gives k_t = 2/7 k_n and gamma_t = gamma_n / 2
    (a given k_t or gamma_t stays); with another law k_t must be given, and the message
    says what the linear law would use."""
    case = validate_case({**GOOD, "contact": {**GOOD["contact"], "friction": 0.5}})
    assert case["contact"]["k_t"] == pytest.approx(2 / 7 * 1e5)
    assert case["contact"]["gamma_t"] == pytest.approx(50.0)
    given = validate_case({**GOOD, "contact": {**GOOD["contact"], "friction": 0.5, "k_t": 1e4}})
    assert given["contact"]["k_t"] == 1e4 and given["contact"]["gamma_t"] == 0.0
    with pytest.raises(ConfigError, match=r"contact.k_t = 0.0 must be > 0 when friction = 0.5 "
                                          r"> 0 \(law hertz; for the linear law it defaults"):
        validate_case({**GOOD, "contact": {**GOOD["contact"], "law": "hertz",
                                           "friction": 0.5}})
