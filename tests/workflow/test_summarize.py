"""Joining the runs' tables: parameter columns come from the runs' case files."""
import json

import pandas as pd
import yaml

from workflows.scripts import summarize


def _run(root, variant, case, columns, value):
    """One finished run of study 'poly' with the observables table its analysis wrote,
    which carries the parameter columns that varied when it ran (``columns``)."""
    seed_dir = root / "poly" / variant / "seed1"
    (seed_dir / "pysim").mkdir(parents=True)
    (seed_dir / "case.yaml").write_text(yaml.safe_dump({**case, "seed": 1}))
    row = {"study": "poly", "case": variant, "engine": "pysim", "seed": 1,
           "observable": "phi_j", "value": value, "uncertainty": 0.001, **columns,
           "engine_version": "0.1.0", "case_hash": "abc", "git_revision": "r"}
    (seed_dir / "pysim" / "observables.csv").write_text(pd.DataFrame([row]).to_csv(index=False))
    (seed_dir / "pysim" / "run.json").write_text(json.dumps({"status": "ok"}))
    return seed_dir / "pysim"


def _case(sigma, rate):
    return {"particles": {"n": 500, "diameter": {"distribution": "lognormal", "sigma": sigma}},
            "protocol": {"name": "compress", "rate": rate, "dt": 1e-4}}


def test_parameter_columns_follow_the_case_files(tmp_path):
    """A slow variant added after the fast runs were analysed makes the rate vary: the
    summary gives every run its kappa, the old ones included (their own tables knew only
    sigma), and drops columns that no longer vary."""
    runs = [_run(tmp_path, "s0", _case(0.0, 0.01), {"sigma": 0.0, "dt": 1e-4}, 0.625),
            _run(tmp_path, "s0.3", _case(0.3, 0.01), {"sigma": 0.3, "dt": 5e-5}, 0.651),
            _run(tmp_path, "s0_slow", _case(0.0, 0.001), {"sigma": 0.0, "kappa": 0.001}, 0.634)]
    out = {k: tmp_path / f"{k}.csv" for k in ("summary", "comparison", "failures")}
    summarize.main(["--summary", str(out["summary"]), "--comparison", str(out["comparison"]),
                    "--failures", str(out["failures"]),
                    "--records", *[str(r / "run.json") for r in runs],
                    "--observables", *[str(r / "observables.csv") for r in runs]])
    df = pd.read_csv(out["summary"]).set_index("case")
    assert df.loc["s0", "kappa"] == 0.01 and df.loc["s0_slow", "kappa"] == 0.001
    assert df.loc["s0.3", "sigma"] == 0.3 and df.loc["s0_slow", "sigma"] == 0.0
    assert "dt" not in df.columns  # the cases all have dt 1e-4: it does not vary
