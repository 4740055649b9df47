"""A tiny end-to-end run of the Snakemake pipeline on every installed engine."""
import shutil
import subprocess
import sys
from pathlib import Path

import pandas as pd
import pytest
import yaml

ROOT = Path(__file__).resolve().parents[2]
SNAKEMAKE = str(Path(sys.executable).parent / "snakemake")


def tiny_config(results):
    return {
        "results": str(results),
        "engines": {"pysim": {"threads": 1}, "lammps": {"ranks": 1}, "liggghts": {"ranks": 1}},
        "studies": {"sphere_jamming": {
            "engines": ["pysim", "lammps", "liggghts"],
            "seeds": [1],
            "case": {
                "particles": {"n": 200, "diameter": {"distribution": "mono", "mean": 1.0}},
                "contact": {"law": "hooke", "k_n": 1e5, "gamma_n": 300.0, "gamma_bg": 1.0},
                "protocol": {"name": "compress", "phi_init": 0.3, "phi_fast": 0.55,
                             "rate_fast": 0.1, "rate": 0.02, "phi_final": 0.7, "dt": 1e-4},
                "output": {"thermo_every": 500, "dump_every": 2000},
            },
            "variants": {"slow": {}, "fast": {"protocol": {"rate": 0.04}}},
            "analysis": {"jamming_window": [1e-3, 1e-2]},
        }},
    }


@pytest.mark.slow
@pytest.mark.engines
def test_pipeline_end_to_end(tmp_path):
    results = tmp_path / "results"
    cfg = tmp_path / "tiny.yaml"
    cfg.write_text(yaml.safe_dump(tiny_config(results)))
    base = [SNAKEMAKE, "--snakefile", str(ROOT / "Snakefile"), "--directory", str(tmp_path),
            "--configfile", str(cfg)]
    r = subprocess.run(base + ["--cores", "2", "--quiet", "all"], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr[-3000:]
    summary = pd.read_csv(results / "summary.csv")
    engines = {"pysim", "lammps"} | ({"liggghts"} if shutil.which("liggghts") else set())
    assert set(summary.engine) == engines
    assert list(summary.columns[:7]) == ["study", "case", "engine", "seed", "observable",
                                         "value", "uncertainty"]
    # the compression rate varies between the variants: it gets a column named kappa
    assert set(summary.kappa) == {0.02, 0.04}
    phi_j = summary[summary.observable == "phi_j"]
    assert len(phi_j) == 2 * len(engines)
    assert phi_j.value.between(0.58, 0.68).all()
    cmp = pd.read_csv(results / "comparison.csv")
    assert set(cmp.verdict) <= {"agree", "DIFFER", "inconclusive", "n/a"} and len(cmp) > 0
    for variant in ("slow", "fast"):
        for kind in ("pressure", "contacts", "phi_j"):
            assert (results / "sphere_jamming" / "figures" / f"{variant}.{kind}.png").stat().st_size > 1000
    rep = subprocess.run(base + ["--cores", "1", "--report", str(results / "report.html")],
                         capture_output=True, text=True)
    assert rep.returncode == 0, rep.stderr[-3000:]
    assert (results / "report.html").stat().st_size > 10_000
    # the first page: what was run and the verdicts, against each other and the papers
    vs_paper = pd.read_csv(results / "vs_paper.csv")
    assert len(vs_paper) >= 40 and vs_paper.verdict.notna().all()
    page = (results / "landing.html").read_text()
    assert "Do the engines agree?" in page and "Against the papers" in page
    assert "Do the engines agree?" in (results / "report.html").read_text()
    # a second run has nothing left to do
    again = subprocess.run(base + ["--cores", "1", "--dry-run", "all"], capture_output=True,
                           text=True)
    assert "Nothing to be done" in again.stdout + again.stderr
    # a larger run budget is no reason to rerun finished runs (it is a resource, not a param)
    longer = tiny_config(results)
    longer["engines"]["pysim"]["timeout"] = 7200
    cfg.write_text(yaml.safe_dump(longer))
    again = subprocess.run(base + ["--cores", "1", "--dry-run", "all"], capture_output=True,
                           text=True)
    assert "Nothing to be done" in again.stdout + again.stderr, again.stdout[-2000:]


def test_bad_config_stops_before_anything_runs(tmp_path):
    cfg = tiny_config(tmp_path / "results")
    cfg["studies"]["sphere_jamming"]["case"]["protocol"]["phi_final"] = 1.3
    p = tmp_path / "bad.yaml"
    p.write_text(yaml.safe_dump(cfg))
    r = subprocess.run([SNAKEMAKE, "--snakefile", str(ROOT / "Snakefile"), "--directory",
                        str(tmp_path), "--configfile", str(p), "--cores", "1", "--dry-run"],
                       capture_output=True, text=True)
    assert r.returncode != 0
    assert "protocol.phi_final = 1.3 is not allowed" in r.stderr
    assert not (tmp_path / "results").exists()


@pytest.mark.parametrize("profile, trends", [("deposition_cohesion", True),
                                             ("deposition_janssen", False),
                                             ("tapping_long", False),
                                             ("random_packings_baranau", False),
                                             ("random_packings_wouterse", True)])
def test_which_profiles_get_trends_and_sets_figures(tmp_path, profile, trends):
    """Deposits that vary only the Bond number (and what follows from it) get a trends
    figure; deposits that also vary the walls or the feed do not (a line through their
    Bond numbers would mix those up); tapping studies get the per-set figure and table;
    hard-sphere studies the closest-jamming figure and table instead of trends; a study
    with an analysis.caging block its caging numbers, with the infinite rods."""
    r = subprocess.run([SNAKEMAKE, "--snakefile", str(ROOT / "Snakefile"), "--directory",
                        str(tmp_path), "--configfile",
                        str(ROOT / "workflows" / "config" / f"{profile}.yaml"), "--cores", "1",
                        "--dry-run", "--quiet", "rules"], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr[-2000:]
    rules = r.stdout + r.stderr
    assert ("plot_trends" in rules) == trends, rules[-2000:]
    assert ("plot_tapping_sets" in rules) == profile.startswith("tapping")
    assert ("closest_jamming" in rules) == profile.endswith("baranau")
    assert ("caging_numbers" in rules) == profile.endswith("wouterse")
    if profile.endswith("wouterse"):
        r = subprocess.run([SNAKEMAKE, "--snakefile", str(ROOT / "Snakefile"), "--directory",
                            str(tmp_path), "--configfile",
                            str(ROOT / "workflows" / "config" / f"{profile}.yaml"), "--cores",
                            "1", "--dry-run", "--printshellcmds", "--config",
                            f"results={tmp_path / 'r'}", "--",
                            str(tmp_path / "r" / "random_packings_wouterse" / "caging.csv")],
                           capture_output=True, text=True)
        assert r.returncode == 0, r.stderr[-2000:]
        assert "--alphas-3d 0 0.05" in r.stdout and "20 inf --alphas-2d 0 inf" in r.stdout


def test_config_key_given_twice_stops_before_anything_runs(tmp_path):
    """Snakemake's own loader keeps the last of a key given twice; the pipeline refuses it."""
    text = yaml.safe_dump(tiny_config(tmp_path / "results"))
    assert "\n        n: 200\n" in text
    p = tmp_path / "twice.yaml"
    p.write_text(text.replace("\n        n: 200\n", "\n        n: 200\n        n: 300\n"))
    r = subprocess.run([SNAKEMAKE, "--snakefile", str(ROOT / "Snakefile"), "--directory",
                        str(tmp_path), "--configfile", str(p), "--cores", "1", "--dry-run"],
                       capture_output=True, text=True)
    assert r.returncode != 0
    assert "key 'n' is given twice in one mapping" in r.stderr, r.stderr[-2000:]
    assert not (tmp_path / "results").exists()


def test_rattler_rule_reaches_the_analysis_and_the_figures(tmp_path):
    """A study's analysis.c_min and each variant's friction go to analyse_run and
    plot_study (dry run: the commands)."""
    cfg = tiny_config(tmp_path / "results")
    study = cfg["studies"]["sphere_jamming"]
    study["engines"] = ["pysim"]
    study["analysis"]["c_min"] = 3
    study["variants"] = {"rough": {"contact": {"friction": 0.5, "k_t": 2e4}}}
    p = tmp_path / "rough.yaml"
    p.write_text(yaml.safe_dump(cfg))
    r = subprocess.run([SNAKEMAKE, "--snakefile", str(ROOT / "Snakefile"), "--directory",
                        str(tmp_path), "--configfile", str(p), "--cores", "1", "--dry-run",
                        "--printshellcmds", "all"], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr[-2000:]
    out = r.stdout + r.stderr
    analyse = [ln for ln in out.splitlines() if "workflows.scripts.analyse_run" in ln]
    figures = [ln for ln in out.splitlines() if "workflows.scripts.plot_study" in ln]
    assert analyse and all("--c-min 3" in ln for ln in analyse), out[-3000:]
    assert figures and all("--friction 0.5 --c-min 3" in ln for ln in figures), out[-3000:]


@pytest.mark.slow
def test_hard_sphere_study_end_to_end(tmp_path):
    """A hard-sphere study (Baranau & Tallarek's LS protocol, pysim only, no contact law)
    through every rule: the runs pass the runner's checks, their observables, the
    closest-jamming table and figure, the snapshot, vs_paper and the report."""
    results = tmp_path / "results"
    cfg = tmp_path / "hs.yaml"
    cfg.write_text(yaml.safe_dump({
        "results": str(results), "engines": {"pysim": {"threads": 1}},
        "studies": {"hs": {
            "engines": ["pysim"], "seeds": [1, 2],
            "case": {"particles": {"n": 200, "diameter": {"distribution": "mono", "mean": 1.0}},
                     "protocol": {"name": "ls", "rate": 10.0,
                                  "closest_jamming": {"final_rate": 0.05}},
                     "output": {"dump_every": 1000}},
            "variants": {"r10": {}}}}}))
    base = [SNAKEMAKE, "--snakefile", str(ROOT / "Snakefile"), "--directory", str(tmp_path),
            "--configfile", str(cfg)]
    r = subprocess.run(base + ["--cores", "2", "--quiet", "all"], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr[-3000:]
    assert pd.read_csv(results / "failures.csv").empty
    summary = pd.read_csv(results / "summary.csv")
    phi_j = summary[summary.observable == "phi_j"]
    assert len(phi_j) == 2 and phi_j.value.between(0.6, 0.66).all()
    table = pd.read_csv(results / "hs" / "closest_jamming.csv").set_index("observable")
    assert table.loc["phi_lt", "value"] == phi_j.value.min()
    assert (results / "hs" / "figures" / "closest_jamming.png").stat().st_size > 10_000
    assert (results / "hs" / "figures" / "r10.packing.png").stat().st_size > 1000
    vs_paper = pd.read_csv(results / "vs_paper.csv").set_index("id")
    assert vs_paper.loc["baranau2014-01", "verdict"] == "conditions differ: n (ours 200, paper 10000)"
