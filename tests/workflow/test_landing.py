"""The report's first page and the verdicts printed at the end of make run."""
import pandas as pd

from workflows.scripts.landing import main


def _results(tmp_path):
    root = tmp_path / "results"
    root.mkdir()
    pd.DataFrame([{"study": "s", "case": "c", "engine": e, "seed": k, "observable": "phi_j",
                   "value": 0.64, "uncertainty": float("nan")}
                  for e in ("pysim", "lammps") for k in (1, 2)]).to_csv(root / "summary.csv",
                                                                         index=False)
    pd.DataFrame([{"study": "s", "case": "c", "observable": "phi_j", "engine_a": "pysim",
                   "mean_a": 0.64, "engine_b": "lammps", "mean_b": 0.70, "difference": 0.06,
                   "tolerance": 0.01, "se": 0.001, "verdict": "DIFFER",
                   "basis": "Welch TOST, 2 and 2 seeds"}]).to_csv(root / "comparison.csv",
                                                                  index=False)
    pd.DataFrame(columns=["study", "case", "engine", "seed", "error", "log", "run_dir"]).to_csv(
        root / "failures.csv", index=False)
    pd.DataFrame([{"id": "b-01", "where": "Table 1", "engine": "pysim", "observable": "phi_j",
                   "paper_value": 0.6405, "paper_uncertainty": 0.0005, "ours": 0.64,
                   "ours_uncertainty": 0.0, "n_seeds": 2,
                   "verdict": "conditions differ: n (ours 1000, paper 10000)"},
                  {"id": "b-02", "where": "Table 1", "engine": "", "observable": "phi_lt",
                   "paper_value": 0.6353, "verdict": "not run"}]).to_csv(
        root / "vs_paper.csv", index=False)
    return root


def test_first_page_and_printout(tmp_path, capsys):
    root = _results(tmp_path)
    page, fig = tmp_path / "landing.html", tmp_path / "diff.png"
    assert main(["--results", str(root), "--html", str(page), "--figure", str(fig),
                 "--print"]) == 0
    text = page.read_text()
    assert "s: 1 cases, runs per engine: lammps 2, pysim 2" in text
    assert "1 DIFFER" in text and "#f8d0d0" in text  # the DIFFER row is red
    assert "b-01" in text and "b-02" not in text  # rows with a run only
    assert "1 conditions differ, 1 not run" in text
    out = capsys.readouterr().out
    assert "s/c phi_j: pysim 0.64 vs lammps 0.7 -> DIFFER" in out
    assert "b-01 phi_j (pysim): paper 0.6405, ours 0.64 -> conditions differ" in out
    assert fig.stat().st_size > 1000


def test_missing_results_folder_is_one_line(tmp_path, capsys):
    assert main(["--results", str(tmp_path / "nope"), "--print"]) == 2
    assert capsys.readouterr().err.count("\n") == 1
