"""README.md's "Your own case" runs as written: its shell commands, taken from between the
``<!-- example:own-case -->`` and ``<!-- /example -->`` markers, run in a temporary
directory and leave tables with finite values of the key observables."""
from __future__ import annotations

import json
import math
import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

import pandas as pd
import pytest

from rodcase.case import load_case, read_yaml
from workflows.studies import validate_config

ROOT = Path(__file__).resolve().parents[2]
README = ROOT / "README.md"
MARKERS = re.compile(r"<!-- example:own-case -->(.*?)<!-- /example -->", re.S)
FENCE = re.compile(r"```sh\n(.*?)```", re.S)


def example_script() -> str:
    """The shell commands of README.md's own-case example, as written."""
    blocks = MARKERS.findall(README.read_text())
    assert len(blocks) == 1, "README.md needs one <!-- example:own-case --> ... <!-- /example -->"
    fences = FENCE.findall(blocks[0])
    assert len(fences) == 1, "the own-case example holds one ```sh block"
    return fences[0]


def option(script: str, name: str) -> str:
    found = re.findall(rf"{name}\s+(\S+)", script)
    assert found, f"the example has no {name} option"
    return found[-1]


@pytest.mark.slow
def test_readme_example_runs(tmp_path):
    script = example_script()
    assert ".venv/bin/python" in script
    # the example's paths are relative to the project root: a copy of examples/ stands in
    shutil.copytree(ROOT / "examples", tmp_path / "examples")
    env = dict(os.environ, NUMBA_NUM_THREADS="1",
               PYTHONPATH=os.pathsep.join(filter(None, [str(ROOT), os.environ.get("PYTHONPATH")])))
    proc = subprocess.run(["bash", "-euo", "pipefail", "-c",
                           script.replace(".venv/bin/python", sys.executable)],
                          cwd=tmp_path, env=env, capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stderr[-3000:]

    run_dir = tmp_path / option(script, "--run")
    assert json.loads((run_dir / "run.json").read_text())["status"] == "ok"
    obs = pd.read_csv(tmp_path / option(script, "--observables"))
    values = obs.set_index("observable")["value"]
    for name in ("phi_j", "jamming_slope", "phi_final", "pressure_final", "z_j"):
        assert math.isfinite(values[name]), f"{name} = {values[name]}"
    # frictional rods jam well below the frictionless ~0.64 and above random loose packing
    assert 0.40 < values["phi_j"] < values["phi_final"] < 0.70
    # frictional rods keep a backbone at jamming: z_J between the frictional (d + 1 = 4)
    # and frictionless (2 d_f = 10) isostatic counts
    assert 4.0 < values["z_j"] < 10.0
    assert math.isfinite(obs.set_index("observable")["uncertainty"]["phi_j"])
    curves = pd.read_csv(tmp_path / option(script, "--curves"))
    assert len(curves) >= 20
    for col in ("phi", "pressure", "z", "s_nematic"):
        assert curves[col].map(math.isfinite).all(), col
    # the packing is dense at the end: several contacts per rod
    assert curves["z"].iloc[-1] > 3


def test_example_study_is_the_example_case():
    """examples/rods_alpha2_friction_study.yaml runs the same case as the case file."""
    cfg = validate_config(read_yaml(ROOT / "examples/rods_alpha2_friction_study.yaml"))
    case = load_case(ROOT / "examples/rods_alpha2_friction.yaml")
    assert cfg["_cases"][("rods_alpha2_friction", "base", case["seed"])] == case


# every other case file in examples/, with the range its phi_J must fall in (its header
# says what to expect) and the fit window its analysis needs
OTHER_EXAMPLES = {
    "spheres.yaml": ((0.62, 0.66), None),
    "rods_alpha2.yaml": ((0.60, 0.72), None),
    "rods_2d.yaml": ((0.87, 0.91), None),
}


@pytest.mark.slow
@pytest.mark.parametrize("name", sorted(OTHER_EXAMPLES))
def test_every_example_runs_as_written(tmp_path, name):
    """The commands of the README's example on each of the other case files: a run and
    its analysis, with a finite phi_J in the range the file's header announces."""
    (lo, hi), window = OTHER_EXAMPLES[name]
    case = ROOT / "examples" / name
    env = dict(os.environ, NUMBA_NUM_THREADS="1")
    py = [sys.executable, "-m"]
    for cmd in (py + ["pysim", "init", str(case), "--out", str(tmp_path / "init.data")],
                py + ["pysim", "run", str(case), "--data", str(tmp_path / "init.data"),
                      "--out", str(tmp_path / "pysim"), "--no-progress"],
                py + ["workflows.scripts.analyse_run", "--case", str(case), "--run",
                      str(tmp_path / "pysim"), "--engine", "pysim", "--study", "example",
                      "--variant", "base", "--seed", "1", "--observables",
                      str(tmp_path / "observables.csv"), "--curves", str(tmp_path / "curves.csv"),
                      *(["--window", *window] if window else [])]):
        proc = subprocess.run(cmd, cwd=ROOT, env=env, capture_output=True, text=True,
                              timeout=600)
        assert proc.returncode == 0, proc.stderr[-3000:]
    values = pd.read_csv(tmp_path / "observables.csv").set_index("observable")["value"]
    assert lo < values["phi_j"] < hi, values["phi_j"]
    assert math.isfinite(values["z_j"])


def test_every_example_file_is_covered():
    shipped = {p.name for p in (ROOT / "examples").glob("*.yaml")}
    assert shipped == set(OTHER_EXAMPLES) | {"rods_alpha2_friction.yaml",
                                              "rods_alpha2_friction_study.yaml"}
