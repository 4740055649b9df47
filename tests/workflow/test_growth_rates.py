"""The growth runs of one aspect ratio across growth rates (workflows/scripts/growth_rates.py):
figure and rate-independence table from real, small pysim runs."""
import json
import subprocess
import sys

import numpy as np
import pandas as pd
import pytest

from tests.cases import growth_case
from tests.runs import analyse, run_case


@pytest.fixture(scope="module")
def two_rates(tmp_path_factory):
    """120 spheres contracted to 0.45 and grown at two rates (0.2 and 2 per unit time at
    dt 1e-4: 2e-5 and 2e-4 per step) to jamming, a frame every 40 steps."""
    dirs = []
    root = tmp_path_factory.mktemp("results")
    for rate in (0.2, 2.0):
        tmp = root / "w" / f"rate{rate}" / "seed1"  # the pipeline's layout
        tmp.mkdir(parents=True)
        case = growth_case(120, 8, phi_init=0.3, rate=rate, phi_grow=0.6, increment=0.01,
                           tolerance=2e-3, contraction={"phi": 0.45, "increment": 0.05})
        case["output"] = {"thermo_every": 40, "dump_every": 40}
        out = run_case(tmp, case)
        analyse(out, tmp / "case.yaml")
        dirs.append(out)
    return dirs


def test_growth_rates_figure_and_table(two_rates, tmp_path):
    fig, table = tmp_path / "g.png", tmp_path / "g.csv"
    r = subprocess.run([sys.executable, "-m", "workflows.scripts.growth_rates", "--figure",
                        str(fig), "--table", str(table), *map(str, two_rates)],
                       capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    assert fig.stat().st_size > 10_000
    t = pd.read_csv(table).set_index("observable")
    assert set(t.index) == {"phi_c_rate_independent", "phi_noncaged_rate_independent"}
    assert (t.runs == 2).all() and (t.rates == "2e-04;2e-05").all() and (t.alpha == 0).all()
    assert (t.case == "rate0.2").all() and (t.seed == 1).all()  # filed under the slowest
    # both rates grow from the same contracted start: where they agree lies inside the
    # range both cover, from 0.45 up to about phi_J
    assert t.value.between(0.45, 0.67).all()


def test_growth_rates_leaves_out_failed_runs(two_rates, tmp_path):
    failed = tmp_path / "failed"
    failed.mkdir()
    (failed / "run.json").write_text(json.dumps({"status": "failed", "error": "x"}))
    table = tmp_path / "g.csv"
    r = subprocess.run([sys.executable, "-m", "workflows.scripts.growth_rates", "--figure",
                        str(tmp_path / "g.png"), "--table", str(table), str(two_rates[0]),
                        str(failed)], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    t = pd.read_csv(table)
    assert (t.runs == 1).all() and t.value.isna().all()
