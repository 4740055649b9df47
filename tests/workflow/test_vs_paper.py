"""vs_paper.csv from results folders, the study notebooks' verdict blocks, and the
repository's reference tables."""
import copy
from pathlib import Path

import numpy as np
import pandas as pd
import yaml

from analysis.vs_paper import read_references
from tests.workflow.helpers import CASE_TAP, reference_tables as _refs
from workflows.scripts.vs_paper import main
from workflows.vs_paper import (BLOCK_BEGIN, BLOCK_END, STUDY_DOCS, carry_forward, case_terms,
                                family, markdown_table, run_table, with_block)

ROOT = Path(__file__).resolve().parents[2]

CASE_2D = {"particles": {"n": 1024, "dimension": 2, "aspect_ratio": 1.0,
                         "diameter": {"distribution": "bidisperse", "mean": 1.0, "ratio": 1.4}},
           "contact": {"law": "harmonic", "friction": 0.0},
           "protocol": {"name": "jammed", "rate": 1e-6}}


def test_case_terms():
    t = case_terms(CASE_2D)
    assert t["family"] == "jamming_2d" and t["alpha"] == 1.0 and t["d"] == 2.0
    assert t["bidisperse"] == 1.4 and t["container"] == "periodic" and t["rate"] == 1e-6
    assert t["rod_contact"] == "closest" and t["compress_contact"] == "closest"
    paper_law = copy.deepcopy(CASE_2D)
    paper_law["contact"]["spine_contact"] = "end_bonds_distinct"
    paper_law["protocol"]["compress_spine_contact"] = "closest"
    t = case_terms(paper_law)
    assert t["rod_contact"] == "end_bonds_distinct" and t["compress_contact"] == "closest"
    paper_law["particles"]["aspect_ratio"] = 0.0  # disks have no spine: no rule to check
    t = case_terms(paper_law)
    assert np.isnan(t["rod_contact"]) and np.isnan(t["compress_contact"])
    # a quasistatic compression is the rate's zero limit; the paper's phi_J rows ask for
    # its continuous compression, so the protocol stays a condition that differs
    qs = copy.deepcopy(CASE_2D)
    qs["protocol"] = {"name": "quasistatic", "dphi": 1e-3}
    t = case_terms(qs)
    assert t["rate"] == 0.0 and t["protocol"] == "quasistatic"
    from analysis.vs_paper import unmet_conditions
    row = read_references(ROOT / "references").set_index("id").loc["marschall2018-02"]
    assert [u.split(" ")[0] for u in unmet_conditions(t, row)] == ["protocol"]
    t = case_terms(CASE_TAP)
    assert t["family"] == "tapping" and t["e_n"] == 0.4 and t["Gamma"] == 2.0
    assert t["tap"] == 1000 and t["sigma"] == 0.0 and t["container"] == "cylinder"
    dep = {"particles": {"n": 300, "dimension": 2, "aspect_ratio": 9.0,
                         "diameter": {"mean": 1.0}},
           "contact": {"law": "hertz", "bond_number": 1e3},
           "container": {"shape": "box", "width": 200.0}, "protocol": {"name": "deposit"}}
    t = case_terms(dep)
    assert family(dep) == "deposition" and t["bo_g"] == 1e3 and t["d"] == 10.0
    assert t["width_over_length"] == 20.0 and t["feed"] == "column"
    assert t["grain_density"] == 1.0  # the schema's default
    # a stress in the paper's own units, for grains of a density it does not state, is
    # never compared with ours
    from analysis.vs_paper import unmet_conditions
    refs = read_references(ROOT / "references").set_index("id")
    row = refs.loc["hidalgo-04"]
    assert unmet_conditions(t, row)[-3:] == ["grain_density (ours 1, paper unstated)",
                                             "rod_contact (ours closest, paper end_bonds)",
                                             "wall_cohesion (ours no, paper yes)"]
    assert np.isnan(t["tangential_spring"])  # frictionless: nothing to check
    dep["contact"]["friction"] = 0.5
    assert case_terms(dep)["tangential_spring"] == "reset"
    # the paper's walls are particles of the grains' law: cohesive where the grains are
    dep["contact"]["wall_cohesion"] = True
    assert case_terms(dep)["wall_cohesion"] == "yes"
    dep["contact"] = {"law": "hertz"}
    assert case_terms(dep)["wall_cohesion"] == "yes"  # no cohesion: nothing to differ
    assert np.isnan(case_terms(CASE_TAP)["wall_cohesion"])


def _results(tmp_path, n=1000, taps=2000, values=(0.75, 0.76)):
    root = tmp_path / "results"
    case = {**CASE_TAP, "protocol": {**CASE_TAP["protocol"], "taps": taps},
            "particles": {**CASE_TAP["particles"], "n": n}}
    rows = []
    for seed, v in enumerate(values, start=1):
        d = root / "tapping_x" / "an6" / f"seed{seed}"
        d.mkdir(parents=True)
        (d / "case.yaml").write_text(yaml.safe_dump(case))
        rows.append({"study": "tapping_x", "case": "an6", "engine": "pysim", "seed": seed,
                     "observable": "phi_tap2000", "value": v, "uncertainty": float("nan")})
    pd.DataFrame(rows).to_csv(root / "summary.csv", index=False)
    return root


def test_script_writes_the_table_and_the_notebook_block(tmp_path):
    refs = _refs(tmp_path)
    results = _results(tmp_path)
    docs = tmp_path / "docs"
    docs.mkdir()
    (docs / "tapping.md").write_text("# Tapping\n\nNotes.\n")
    out = tmp_path / "vs_paper.csv"
    assert main(["--references", str(refs), "--results", str(results), "--out", str(out),
                 "--docs", str(docs), "--figure", str(tmp_path / "f.png")]) == 0
    table = pd.read_csv(out)
    assert list(table.verdict) == ["agrees", "not run"]
    assert table.iloc[0].n_seeds == 2 and abs(table.iloc[0].ours - 0.755) < 1e-12
    assert (tmp_path / "f.png").stat().st_size > 0
    text = (docs / "tapping.md").read_text()
    assert text.startswith("# Tapping\n\n" + BLOCK_BEGIN) and text.count(BLOCK_END) == 1
    # a second run replaces the block, never stacks a second one
    assert main(["--references", str(refs), "--results", str(results),
                 "--docs", str(docs)]) == 0
    assert (docs / "tapping.md").read_text() == text


def test_keep_carries_the_earlier_answers_that_these_results_do_not_give(tmp_path):
    refs = _refs(tmp_path)
    results = _results(tmp_path)
    out = tmp_path / "vs_paper.csv"
    assert main(["--references", str(refs), "--results", str(results), "--out", str(out)]) == 0
    earlier = pd.read_csv(out)
    # the earlier table also answered the second row, from a run not on this machine
    earlier.loc[1, ["verdict", "ours", "runs"]] = ["differs", 0.6, "elsewhere/an9"]
    earlier.to_csv(tmp_path / "earlier.csv", index=False)
    # this time no folder answers anything: both answers are kept, in the references' order
    empty = tmp_path / "empty"
    empty.mkdir()
    assert main(["--references", str(refs), "--results", str(empty), "--out", str(out),
                 "--keep", str(tmp_path / "earlier.csv")]) == 0
    table = pd.read_csv(out)
    assert list(table.verdict) == ["agrees", "differs"] and table.runs.iloc[1] == "elsewhere/an9"
    # a new answer from the same runs replaces the old one, and is not doubled
    earlier.loc[0, "ours"] = 0.1
    earlier.to_csv(tmp_path / "earlier.csv", index=False)
    assert main(["--references", str(refs), "--results", str(results),
                 "--out", str(out), "--keep", str(tmp_path / "earlier.csv")]) == 0
    table = pd.read_csv(out)
    assert len(table) == 2 and abs(table.ours.iloc[0] - 0.755) < 1e-12
    # so does one from the same study over other runs (a trend over the runs at hand)
    earlier.loc[0, "runs"] = "tapping_x/an6; tapping_x/an7"
    earlier.to_csv(tmp_path / "earlier.csv", index=False)
    assert main(["--references", str(refs), "--results", str(results),
                 "--out", str(out), "--keep", str(tmp_path / "earlier.csv")]) == 0
    table = pd.read_csv(out)
    assert list(table.runs) == ["tapping_x/an6", "elsewhere/an9"]
    # but a verdict is not given up for 'not run', nor a fuller 'not run' for a thinner one
    table.loc[0, "verdict"] = "not run"
    table.to_csv(tmp_path / "new.csv", index=False)
    for verdict in ("agrees", "not run"):
        earlier.loc[0, "verdict"] = verdict
        got, n = carry_forward(pd.read_csv(tmp_path / "new.csv"), earlier)
        assert n == 1 and got.runs.iloc[0] == "tapping_x/an6; tapping_x/an7"
    earlier.loc[0, "runs"] = "tapping_x/an7"  # other runs of the study: both stand
    got, n = carry_forward(pd.read_csv(tmp_path / "new.csv"), earlier)
    assert n == 1 and list(got.runs) == ["tapping_x/an6", "tapping_x/an7", "elsewhere/an9"]
    # a value measured on another variant of a study now partly rerun is kept beside
    # the new one: a rerun of one variant supersedes only the rows it shares runs with
    earlier.loc[0, ["verdict", "runs"]] = ["agrees", "tapping_x/an9"]
    fresh = pd.read_csv(tmp_path / "new.csv")
    fresh.loc[0, "verdict"] = "agrees"
    got, n = carry_forward(fresh, earlier)
    assert n == 1 and list(got.runs) == ["tapping_x/an6", "tapping_x/an9", "elsewhere/an9"]
    # a 'not run' over all the runs behind an old verdict stands: the rule or the
    # reference changed (a fit that now waits for a point it used to do without)
    earlier.loc[0, ["verdict", "runs"]] = ["agrees", "tapping_x/an6"]
    got, n = carry_forward(pd.read_csv(tmp_path / "new.csv"), earlier)
    assert n == 0 and list(got.verdict) == ["not run", "differs"]
    assert list(got.runs) == ["tapping_x/an6", "elsewhere/an9"]
    # an old verdict whose runs were all judged again goes, even where the new table has
    # no row for its study (a changed reference left the study out of a trend)
    earlier.loc[0, ["verdict", "runs"]] = ["agrees", "other_study/an6"]
    got, n = carry_forward(pd.read_csv(tmp_path / "new.csv"), earlier,
                           at_hand={"other_study/an6", "tapping_x/an6"})
    assert n == 0 and list(got.runs) == ["tapping_x/an6", "elsewhere/an9"]
    got, n = carry_forward(pd.read_csv(tmp_path / "new.csv"), earlier, at_hand={"tapping_x/an6"})
    assert n == 1 and "other_study/an6" in set(got.runs)
    assert main(["--references", str(refs), "--results", str(empty), "--out", str(out),
                 "--keep", str(tmp_path / "none.csv")]) == 2


def test_a_run_at_other_conditions(tmp_path):
    refs = _refs(tmp_path)
    results = _results(tmp_path, n=500, taps=4134)
    out = tmp_path / "vs_paper.csv"
    assert main(["--references", str(refs), "--results", str(results), "--out", str(out)]) == 0
    v = pd.read_csv(out).verdict.iloc[0]
    assert v == "conditions differ: n (ours 500, paper 1000)"


def test_a_run_that_stops_before_the_rows_tap(tmp_path):
    # the value holds at tap 2000: a run of 400 taps has no phi_tap2000
    refs = _refs(tmp_path)
    results = _results(tmp_path, taps=400)
    summary = pd.read_csv(results / "summary.csv").assign(observable="phi_tap300")
    summary.to_csv(results / "summary.csv", index=False)
    out = tmp_path / "vs_paper.csv"
    assert main(["--references", str(refs), "--results", str(results), "--out", str(out)]) == 0
    r = pd.read_csv(out).iloc[0]
    assert r.verdict == "not run" and r.note == "no run reports phi_tap2000"


def test_band_fractions_of_modes_csv_join_the_runs(tmp_path):
    root = tmp_path / "results"
    rows = []
    for seed in (1, 2):
        d = root / "j2d" / "alpha4" / f"seed{seed}"
        d.mkdir(parents=True)
        (d / "case.yaml").write_text(yaml.safe_dump({**CASE_2D, "particles": {
            **CASE_2D["particles"], "aspect_ratio": 4.0}}))
        rows.append({"study": "j2d", "case": "alpha4", "engine": "pysim", "seed": seed,
                     "observable": "phi_j", "value": 0.86, "uncertainty": float("nan")})
    pd.DataFrame(rows).to_csv(root / "summary.csv", index=False)
    pd.DataFrame({"variant": ["alpha4", "alpha4"], "seed": ["seed1", "seed2"],
                  "mode_fraction_low": [0.06, 0.07], "mode_fraction_middle": [0.001, 0.0],
                  "mode_fraction_high": [0.939, 0.93], "bonds": [2800, 2790],
                  "phi_minus_phi_j_u1e9": [4e-4, 5e-4]}
                 ).to_csv(root / "j2d" / "modes.csv", index=False)
    runs, results = run_table([root])
    low = results[results.observable == "mode_fraction_low"].sort_values("seed")
    assert list(low.seed) == [1, 2] and list(low.value) == [0.06, 0.07]
    far = results[results.observable == "phi_minus_phi_j_u1e9"].sort_values("seed")
    assert list(far.value) == [4e-4, 5e-4]
    assert set(low.engine) == {"pysim"} and set(low.case) == {"alpha4"}
    assert "bonds" not in set(results.observable)
    assert len(runs) == 2


def test_a_jammed_state_that_did_not_converge_measures_nothing(tmp_path):
    """Seed 2's bisection ended without a stable state (``converged`` 0): its ``phi_j`` is
    no jamming point and stays out, its ``converged`` row and its run row stay."""
    root = tmp_path / "results"
    rows = []
    for seed, ok in ((1, 1.0), (2, 0.0)):
        d = root / "j2d" / "alpha1" / f"seed{seed}"
        d.mkdir(parents=True)
        (d / "case.yaml").write_text(yaml.safe_dump(CASE_2D))
        rows += [{"study": "j2d", "case": "alpha1", "engine": "pysim", "seed": seed,
                  "observable": name, "value": value, "uncertainty": float("nan")}
                 for name, value in (("phi_j", 0.89 + seed / 1000), ("converged", ok))]
    pd.DataFrame(rows).to_csv(root / "summary.csv", index=False)
    runs, results = run_table([root])
    assert list(results[results.observable == "phi_j"].value) == [0.891]
    assert sorted(results[results.observable == "converged"].seed) == [1, 2]
    assert len(runs) == 2


def _one_3d_run(tmp_path, case: str, phi_j: float) -> Path:
    """A results folder with one 3-D run of study ``w`` (its case and summary row)."""
    root = tmp_path / "results"
    d = root / "w" / case / "seed1"
    d.mkdir(parents=True)
    (d / "case.yaml").write_text(yaml.safe_dump({**CASE_2D, "particles": {
        **CASE_2D["particles"], "dimension": 3}}))
    pd.DataFrame([{"study": "w", "case": case, "engine": "pysim", "seed": 1,
                   "observable": "phi_j", "value": phi_j, "uncertainty": float("nan")}]
                 ).to_csv(root / "summary.csv", index=False)
    return root


def test_cross_rate_rows_of_growth_csv_join_the_slowest_run(tmp_path):
    root = _one_3d_run(tmp_path, "alpha0_slow", 0.64)
    pd.DataFrame({"case": ["alpha0_slow"] * 2, "seed": [1, 1],
                  "observable": ["phi_c_rate_independent", "phi_noncaged_rate_independent"],
                  "value": [0.601, float("nan")], "alpha": [0.0, 0.0], "runs": [3, 3],
                  "rates": ["1e-06;1e-07;1e-08"] * 2}).to_csv(root / "w" / "growth_alpha0.csv",
                                                            index=False)
    runs, results = run_table([root])
    got = results.set_index("observable")
    assert got.loc["phi_c_rate_independent", "value"] == 0.601
    assert got.loc["phi_c_rate_independent", "case"] == "alpha0_slow"
    assert np.isnan(got.loc["phi_noncaged_rate_independent", "value"])
    assert len(runs) == 1


def test_a_bad_reference_table_is_one_line(tmp_path, capsys):
    folder = tmp_path / "refs"
    folder.mkdir()
    (folder / "x.csv").write_text("id,paper\nx-01,x\n")
    assert main(["--references", str(folder), "--results", str(tmp_path),
                 "--out", str(tmp_path / "o.csv")]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("error: ") and "missing columns" in err and "\n" not in err


def test_with_block_inserts_after_the_title_once():
    block = f"{BLOCK_BEGIN}\nA\n{BLOCK_END}"
    text = with_block("# T\n\nbody\n", block)
    assert text == f"# T\n\n{block}\n\nbody\n"
    assert with_block(text, block.replace("A", "B")) == text.replace("\nA\n", "\nB\n")


def test_the_repository_references_load():
    refs = read_references(ROOT / "references")
    assert len(refs) >= 40
    assert set(refs["study"]) <= set(STUDY_DOCS)
    assert refs["where"].fillna("").str.strip().ne("").all()


def test_the_notebooks_open_with_the_committed_table():
    """docs/studies/*.md carry the verdict block generated from docs/studies/vs_paper.csv:
    regenerate it with workflows.scripts.vs_paper --docs when the runs change."""
    table = pd.read_csv(ROOT / "docs" / "studies" / "vs_paper.csv")
    for study, name in STUDY_DOCS.items():
        text = (ROOT / "docs" / "studies" / name).read_text()
        assert markdown_table(table, study) in text, name


def test_reference_rows_at_a_runs_point():
    """an6 (e_n 0.4, Gamma 2, alpha 4): its own bands and the density at 2000 taps, no
    other set's rows."""
    from workflows.vs_paper import reference_rows

    rows = reference_rows(CASE_TAP, ROOT / "references")
    assert len(rows) and set(rows["study"]) == {"tapping"}
    assert (pd.to_numeric(rows["e_n"]).fillna(0.4) == 0.4).all()
    assert (pd.to_numeric(rows["Gamma"]).fillna(2.0) == 2.0).all()
    bands = rows[(rows["observable"] == "angle_late") & (rows["uncertainty_kind"] == "band")]
    assert sorted(bands["layer"].dropna().astype(int)) == [2, 3]
    assert ((rows["observable"] == "phi_late_enclosing") & (rows["tap"] == 2000)).any()


def test_caging_numbers_join_as_runs_of_their_own(tmp_path):
    """A study's caging.csv becomes runs of engine 'analysis' in the study's family, one
    per dimension and aspect ratio (inf: the infinite rod, a point of its own), judged
    against the paper's caging numbers; the largest rod value is caging_number_max."""
    root = _one_3d_run(tmp_path, "alpha1.5", 0.68)
    inf = float("inf")
    pd.DataFrame({"dimension": [2, 2, 3, 3, 3, 3, 3],
                  "alpha": [0.0, inf, 0.0, 0.1, 15.0, 20.0, inf],
                  "mean": [5.01, 4.98, 7.02, 10.5, 9.30, 9.25, 9.03],
                  "stderr": [0.05] * 7, "trials": [1000] * 7, "seed": [1] * 7}
                 ).to_csv(root / "w" / "caging.csv", index=False)
    runs, results = run_table([root])
    cage = runs[runs.engine == "analysis"]
    assert len(cage) == 7 and set(cage.family) == {"random_packings"}
    assert np.isinf(cage.alpha).sum() == 2
    top = results[results.observable == "caging_number_max"].set_index("case")["value"]
    assert top.to_dict() == {"caging_3d_alpha0.1": 10.5, "caging_2d_alphainf": 4.98}
    refs = read_references(ROOT / "references")
    refs = refs[refs["id"].isin([f"wouterse-2{k}" for k in range(1, 7)])]
    from analysis.vs_paper import match
    got = match(refs, runs, results)
    # each case is judged on its own: the other dimension's case reads "conditions differ"
    other = got.verdict.str.startswith("conditions differ: dimension")
    assert other.sum() == 5
    got = got[(got.engine == "analysis") & ~other].set_index("id")
    assert got.index.is_unique
    assert got.loc["wouterse-21", "ours"] == 5.01 and got.loc["wouterse-23", "ours"] == 4.98
    assert got.loc["wouterse-22", "ours"] == 7.02 and got.loc["wouterse-24", "ours"] == 9.03
    for k in (21, 22, 23, 24, 26):
        assert got.loc[f"wouterse-{k}", "verdict"] == "agrees", k
    # the largest rod value, 10.5 +- 0.05, against "around 12" +- 0.5
    assert got.loc["wouterse-25", "verdict"] == "differs"
    assert got.loc["wouterse-22", "ours_uncertainty"] == 0.05  # the trials' standard error
