"""Interim tables of a profile still running: the finished runs only."""
import json

import pandas as pd
import yaml

from tests.workflow.helpers import CASE_TAP, reference_tables as _refs
from workflows.scripts.interim import main


def _run(root, seed, status=None, value=None):
    """Seed ``seed`` of tapping_x/an6: finished (``value``), failed or under way."""
    d = root / "tapping_x" / "an6" / f"seed{seed}"
    (d / "pysim").mkdir(parents=True)
    case = {**CASE_TAP, "protocol": {**CASE_TAP["protocol"], "taps": 2000}, "seed": seed}
    (d / "case.yaml").write_text(yaml.safe_dump(case))
    if status is not None:
        (d / "pysim" / "run.json").write_text(json.dumps(
            {"status": status, **({} if status == "ok" else {"error": "blew up"})}))
    if value is not None:
        pd.DataFrame([{"study": "tapping_x", "case": "an6", "engine": "pysim", "seed": seed,
                       "observable": "phi_tap2000", "value": value, "uncertainty": float("nan")}]
                     ).to_csv(d / "pysim" / "observables.csv", index=False)


def test_the_finished_runs_make_the_tables(tmp_path, capsys):
    root = tmp_path / "results"
    _run(root, 1, "ok", 0.755)
    _run(root, 2)  # under way
    _run(root, 3, "failed")
    assert main(["--references", str(_refs(tmp_path)), "--results", str(root)]) == 0
    summary = pd.read_csv(root / "summary.csv")
    assert list(summary.seed) == [1] and summary.value.iloc[0] == 0.755
    assert list(pd.read_csv(root / "failures.csv").seed) == [3]
    table = pd.read_csv(root / "vs_paper.csv")
    assert table.verdict.iloc[0] == "agrees" and table.n_seeds.iloc[0] == 1
    assert "FAILED tapping_x/an6/seed3/pysim: blew up" in capsys.readouterr().err


def test_a_missing_folder_is_one_line(tmp_path, capsys):
    try:
        main(["--results", str(tmp_path / "nowhere")])
    except SystemExit as exc:
        assert exc.code == 2
    assert "no such folder" in capsys.readouterr().err
