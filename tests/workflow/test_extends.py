"""A study that extends another profile's study: merged, validated, errors in one line."""
import re

import pytest
import yaml

from rodcase.case import ConfigError
from workflows.studies import load_config, validate_config

BASE = {"results": "results", "studies": {"base": {
    "description": "the base", "engines": ["pysim"], "seeds": [1, 2],
    "case": {"particles": {"n": 100, "diameter": {"mean": 1.0}},
             "contact": {"law": "hooke", "k_n": 1e5, "gamma_n": 300.0, "gamma_bg": 1.0},
             "protocol": {"name": "compress", "phi_init": 0.3, "rate": 0.02,
                          "phi_final": 0.7, "dt": 1e-4},
             "output": {"thermo_every": 500, "dump_every": 2000}},
    "variants": {"slow": {}, "fast": {"protocol": {"rate": 0.04}}}}}}


def _write(tmp_path, name, cfg):
    p = tmp_path / name
    p.write_text(yaml.safe_dump(cfg))
    return p


def test_extends_merges_the_case_and_replaces_the_variants(tmp_path):
    base = _write(tmp_path, "base.yaml", BASE)
    cfg = {"studies": {"more": {"extends": f"{base}#base", "seeds": [3],
                                "case": {"particles": {"n": 200}},
                                "variants": {"slower": {"protocol": {"rate": 0.01}}}}}}
    out = validate_config(cfg, "more.yaml")
    assert set(out["_cases"]) == {("more", "slower", 3)}
    case = out["_cases"][("more", "slower", 3)]
    assert case["particles"]["n"] == 200 and case["protocol"]["rate"] == 0.01
    assert case["contact"]["k_n"] == 1e5  # from the base
    assert out["studies"]["more"]["engines"] == ["pysim"]
    # without variants of its own, the study keeps the base's; one study needs no '#'
    out = validate_config({"studies": {"same": {"extends": str(base)}}}, "same.yaml")
    assert {v for _, v, _ in out["_cases"]} == {"slow", "fast"}


def test_a_chain_and_the_shipped_profiles(tmp_path):
    base = _write(tmp_path, "base.yaml", BASE)
    mid = _write(tmp_path, "mid.yaml", {"studies": {"mid": {"extends": f"{base}#base",
                                                            "seeds": [5]}}})
    out = validate_config({"studies": {"top": {"extends": f"{mid}#mid",
                                               "case": {"particles": {"n": 150}}}}})
    assert {s for _, _, s in out["_cases"]} == {5}
    # tapping_long_2000_more extends tapping_long_2000, which extends tapping_long,
    # which extends tapping_paper: the case comes through the chain
    cfg = load_config("workflows/config/tapping_long.yaml")
    case = cfg["_cases"][("tapping_long_2000_more", "an9", 4)]
    assert case["protocol"]["taps"] == 2000 and case["protocol"]["frames_per_tap"] == 1
    assert case["particles"]["n"] == 1414 and case["contact"]["max_overlap"] == 0.5


@pytest.mark.parametrize("ref, message", [
    ("nope.yaml#x", "no profile 'nope.yaml'"),
    ("{base}#other", "has no study 'other'; use one of ['base']"),
    ("{two}", "has studies ['a', 'b']; name one as"),
    ("{loop}#loop", "comes back to itself"),
])
def test_bad_extends_are_one_line(tmp_path, ref, message):
    base = _write(tmp_path, "base.yaml", BASE)
    two = _write(tmp_path, "two.yaml", {"studies": {"a": BASE["studies"]["base"],
                                                    "b": BASE["studies"]["base"]}})
    loop = tmp_path / "loop.yaml"
    loop.write_text(yaml.safe_dump({"studies": {"loop": {"extends": f"{loop}#loop"}}}))
    cfg = {"studies": {"s": {"extends": ref.format(base=base, two=two, loop=loop)}}}
    with pytest.raises(ConfigError, match=re.escape(message)) as exc:
        validate_config(cfg, "cfg.yaml")
    # one line, naming the file and study where the bad reference stands
    assert "\n" not in str(exc.value)
    assert str(exc.value).startswith(f"{loop}: studies.loop" if "loop" in ref
                                     else "cfg.yaml: studies.s")
