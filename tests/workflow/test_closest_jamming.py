"""Hard-sphere packings through the pipeline's scripts: analyse_run on real, small LS runs
with the closest-jamming search, the study's figure and limits table
(workflows/scripts/closest_jamming.py), and their rows in vs_paper against Baranau &
Tallarek's table."""
import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from analysis.vs_paper import match, read_references
from tests.runs import analyse, run_case
from workflows.vs_paper import run_table

pytestmark = pytest.mark.slow  # two hard-sphere runs with the search: about 20 s

ROOT = Path(__file__).resolve().parents[2]
#: 200 spheres from Poisson starts, LS at rate 10 (fast), the search cut at rate 0.02
CASE = {"particles": {"n": 200, "diameter": {"distribution": "mono", "mean": 1.0}},
        "protocol": {"name": "ls", "rate": 10.0, "closest_jamming": {"final_rate": 0.02}},
        "output": {"dump_every": 1000}}


@pytest.fixture(scope="module")
def results(tmp_path_factory):
    """Two seeds in the pipeline's layout, analysed, with their summary.csv."""
    root = tmp_path_factory.mktemp("results")
    dirs = []
    for seed in (1, 2):
        tmp = root / "hs" / "sigma0_r10" / f"seed{seed}"
        tmp.mkdir(parents=True)
        out = run_case(tmp, {**CASE, "seed": seed})
        pysim = tmp / "pysim"
        out.rename(pysim)
        analyse(pysim, tmp / "case.yaml", "hs", "sigma0_r10", seed)
        dirs.append(pysim)
    summary = pd.concat([pd.read_csv(d / "observables.csv") for d in dirs])
    summary.to_csv(root / "summary.csv", index=False)
    return root, dirs


def test_observables_of_a_hard_sphere_run(results):
    _root, dirs = results
    for d in dirs:
        obs = pd.read_csv(d / "observables.csv").set_index("observable")["value"]
        meta = json.loads((d / "run.json").read_text())
        assert obs["phi"] == meta["phi"] and obs["phi_j"] == meta["phi_j"]
        assert obs["phi"] < obs["phi_j"] < 0.66
        assert obs["reduced_pressure"] >= 1e12  # the search ended at Z >= 1e12
        # the search cut at rate 0.02 stops short of jamming: fewer contacts than the
        # isostatic 6 (a full search reaches 5.97-5.98 at N = 500 and 2048)
        assert 4.5 < obs["z_j"] < 6.0 and obs["z_j_with_rattlers"] < obs["z_j"]
        assert 0 < obs["rattler_fraction_j"] < 0.3  # 2.4-2.8 % after a full search
        blocks = pd.read_csv(d / "curves.csv")
        assert list(blocks.stage.unique()) == ["ls", "mls"]


def test_limits_table_figure_and_vs_paper_rows(results, tmp_path):
    root, dirs = results
    table = root / "hs" / "closest_jamming.csv"
    fig = tmp_path / "cj.png"
    r = subprocess.run([sys.executable, "-m", "workflows.scripts.closest_jamming", "--figure",
                        str(fig), "--table", str(table), *map(str, dirs)],
                       capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    assert fig.stat().st_size > 10_000
    t = pd.read_csv(table).set_index("observable")
    phi_j = [pd.read_csv(d / "observables.csv").set_index("observable")["value"]["phi_j"]
             for d in dirs]
    assert t.loc["phi_lt", "value"] == pytest.approx(min(phi_j), rel=1e-12)
    assert t.loc["phi_rcp", "value"] == pytest.approx(max(phi_j), rel=1e-12)
    assert (t.loc[["phi_lt", "phi_rcp"], "case"] == "n200_sigma0_ls_fast").all()
    assert (t.like == "sigma0_r10").all() and (t.packings == 2).all()

    runs, res = run_table([root])
    pseudo = runs[runs.case == "n200_sigma0_ls_fast"].iloc[0]
    assert pseudo.protocol == "ls" and pseudo.rate == 10.0 and pseudo.n == 200
    refs = read_references(ROOT / "references")
    got = match(refs[refs.paper == "baranau2014"], runs, res).set_index("id")
    # phi_LT after fast LS or FB compressions (abstract): ours from the table, at another N
    row = got.loc["baranau2014-01"]
    assert row.ours == pytest.approx(min(phi_j)) and row.runs == "hs/n200_sigma0_ls_fast"
    assert row.verdict == "conditions differ: n (ours 200, paper 10000)"
    # Table 4 pools both algorithms: LS alone is another protocol
    assert "protocol (ours ls, paper fb+ls)" in got.loc["baranau2014-51", "verdict"]
    # z_j is per packing, pooled over the two seeds
    z = got.loc["baranau2014-05"]
    assert z.n_seeds == 2 and z.verdict.startswith("conditions differ: n")
    assert np.isfinite(z.ours_uncertainty)
