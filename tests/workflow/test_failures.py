"""Failures are results: a broken deck, an unstable case or an interrupted pipeline never
stops the other runs, never leaves half-written files as results, and shows up in the
report."""
import json
import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import pandas as pd
import pytest
import yaml

ROOT = Path(__file__).resolve().parents[2]
SNAKEMAKE = str(Path(sys.executable).parent / "snakemake")
ENGINES = ["lammps"] + (["liggghts"] if shutil.which("liggghts") else [])


def config(results, engines=ENGINES, variants=None, seeds=(1,)):
    return {
        "results": str(results),
        "studies": {"sphere_jamming": {
            "engines": list(engines), "seeds": list(seeds),
            "case": {
                "particles": {"n": 150, "diameter": {"mean": 1.0}},
                "contact": {"law": "hooke", "k_n": 1e5, "gamma_n": 300.0, "gamma_bg": 1.0},
                "protocol": {"name": "compress", "phi_init": 0.3, "phi_fast": 0.55,
                             "rate_fast": 0.2, "rate": 0.05, "phi_final": 0.68, "dt": 1e-4},
                "output": {"thermo_every": 500, "dump_every": 2000},
            },
            "variants": variants or {"base": {}},
        }},
    }


def snakemake(cfg_path, *extra, env=None, cores="2"):
    """Run the project's Snakefile with its own working directory (beside the config),
    so that tests never share Snakemake's lock and metadata with each other or with a
    pipeline the user is running."""
    return [SNAKEMAKE, "--snakefile", str(ROOT / "Snakefile"), "--directory",
            str(Path(cfg_path).parent), "--configfile", str(cfg_path), "--cores", cores,
            "--quiet", *extra]


@pytest.mark.slow
@pytest.mark.engines
def test_broken_deck_is_reported_and_the_rest_runs(tmp_path):
    inputs = tmp_path / "inputs"
    shutil.copytree(ROOT / "inputs", inputs)
    deck = inputs / "lammps" / "in.spheres.compress"
    text = deck.read_text()
    assert "atom_style      sphere\n" in text
    deck.write_text(text.replace("atom_style      sphere\n",
                                 "atom_style      sphere\nthis_is_not_a_command 1\n"))
    cfg = tmp_path / "cfg.yaml"
    cfg.write_text(yaml.safe_dump(config(tmp_path / "results", engines=["lammps", "liggghts"]
                                         if "liggghts" in ENGINES else ["lammps"],
                                         seeds=(1, 2))))
    env = dict(os.environ, RODPACK_INPUTS=str(inputs))
    r = subprocess.run(snakemake(cfg), capture_output=True, text=True, env=env)
    assert r.returncode == 0, r.stderr[-3000:]
    res = tmp_path / "results"
    fail = pd.read_csv(res / "failures.csv")
    assert set(fail.engine) == {"lammps"} and len(fail) == 2
    assert fail.error.str.contains("ERROR: Unknown command: this_is_not_a_command 1").all()
    assert fail.log.map(lambda p: Path(p).exists()).all()
    for seed in (1, 2):
        run = res / "sphere_jamming" / "base" / f"seed{seed}" / "lammps"
        assert not (run / "thermo.dat").exists() and not (run / "particles.dump").exists()
    summary = pd.read_csv(res / "summary.csv")
    assert "lammps" not in set(summary.engine)
    if "liggghts" in ENGINES:
        assert set(summary.engine) == {"liggghts"}


@pytest.mark.slow
@pytest.mark.engines
def test_unstable_case_is_a_reported_blow_up(tmp_path):
    """Soft contacts squeezed fast: pysim stops with its blow-up message (step and
    particles), LAMMPS loses atoms or warns of dangerous builds; both are reported, the
    stable variant's runs are not affected."""
    cfg = tmp_path / "cfg.yaml"
    variants = {"ok": {}, "unstable": {"contact": {"k_n": 100.0},
                                       "protocol": {"dt": 1e-3, "rate": 0.5, "rate_fast": 1.0}}}
    cfg.write_text(yaml.safe_dump(config(tmp_path / "results", engines=["pysim", "lammps"],
                                         variants=variants)))
    r = subprocess.run(snakemake(cfg), capture_output=True, text=True)
    assert r.returncode == 0, r.stderr[-3000:]
    fail = pd.read_csv(tmp_path / "results" / "failures.csv").set_index("engine")
    assert set(fail.case) == {"unstable"} and set(fail.index) == {"pysim", "lammps"}
    assert fail.loc["pysim", "error"].startswith("pysim failed (exit 3): velocity Verlet: overlap")
    assert "between particles (0-based)" in fail.loc["pysim", "error"]
    assert "at step" in fail.loc["pysim", "error"]
    assert "checkpoint" in fail.loc["pysim", "error"]
    lam = fail.loc["lammps", "error"]
    assert lam.startswith("lammps failed") or "dangerous" in lam or "blew up" in lam
    summary = pd.read_csv(tmp_path / "results" / "summary.csv")
    assert set(summary.case) == {"ok"} and set(summary.engine) == {"pysim", "lammps"}


@pytest.mark.slow
@pytest.mark.engines
def test_killed_pipeline_finishes_on_rerun_with_the_same_summary(tmp_path):
    ref = tmp_path / "ref"
    cfg_ref = tmp_path / "ref.yaml"
    cfg_ref.write_text(yaml.safe_dump(config(ref, engines=["lammps"], seeds=(1, 2, 3))))
    r = subprocess.run(snakemake(cfg_ref, cores="1"), capture_output=True, text=True)
    assert r.returncode == 0, r.stderr[-3000:]

    res = tmp_path / "killed"
    cfg = tmp_path / "killed.yaml"
    cfg.write_text(yaml.safe_dump(config(res, engines=["lammps"], seeds=(1, 2, 3))))
    proc = subprocess.Popen(snakemake(cfg, cores="1"), stdout=subprocess.DEVNULL,
                            stderr=subprocess.DEVNULL, start_new_session=True)
    deadline = time.time() + 300

    def running():  # an engine run under way: its work directory exists, its run.json not
        return [d for d in res.glob("sphere_jamming/base/seed*/lammps")
                if (d / "work" / "screen.txt").exists() and not (d / "run.json").exists()]

    while time.time() < deadline:
        if list(res.glob("sphere_jamming/base/seed*/lammps/run.json")) and running():
            break
        time.sleep(0.05)
    os.killpg(proc.pid, signal.SIGKILL)  # snakemake and the LAMMPS run it started
    proc.wait()
    assert not (res / "summary.csv").exists()
    # Snakemake keeps its lock after a kill -9: the documented way on is --unlock
    # ('make run' does it by itself when no other Snakemake runs in the directory)
    subprocess.run(snakemake(cfg, "--unlock"), capture_output=True, text=True, check=True)
    again = subprocess.run(snakemake(cfg, "--rerun-incomplete", cores="1"), capture_output=True,
                           text=True)
    assert again.returncode == 0, again.stderr[-3000:]
    cols = ["study", "case", "engine", "seed", "observable", "value", "uncertainty"]
    a = pd.read_csv(ref / "summary.csv")[cols]
    b = pd.read_csv(res / "summary.csv")[cols]
    pd.testing.assert_frame_equal(a, b)


def test_checkpoint_of_another_case_is_not_resumed(tmp_path):
    """A checkpoint left by a run of a different case (the configuration changed since)
    is removed, not resumed: the run starts over and succeeds."""
    import json

    import yaml

    from pysim.initial import write_initial
    from tests.cases import PYSIM_COMPRESS
    from workflows import engines, runner
    from rodcase.case import validate_case

    case = validate_case(PYSIM_COMPRESS)
    (tmp_path / "case.yaml").write_text(yaml.safe_dump(case))
    write_initial(case, tmp_path / "init.data")
    out = tmp_path / "run"
    out.mkdir()
    (out / "checkpoint.npz").write_bytes(b"not a checkpoint")  # would fail if resumed
    (out / "resume.json").write_text(json.dumps({"engine": "pysim", "case_hash": "other",
                                                 "data": "other"}))
    rec = runner.run("pysim", tmp_path / "case.yaml", tmp_path / "init.data", out, timeout=600)
    assert rec["status"] == "ok", rec.get("error")
    assert not (out / "checkpoint.npz").exists()
    stamp = json.loads((out / "resume.json").read_text())
    assert stamp == engines.resume_stamp("pysim", case, tmp_path / "init.data")


def test_figures_draw_only_the_runs_that_succeeded(tmp_path):
    from workflows.runner import ok_runs
    dirs = []
    for name, status in (("a", "ok"), ("b", "failed"), ("c", "ok")):
        d = tmp_path / name
        d.mkdir()
        (d / "run.json").write_text(f'{{"status": "{status}"}}')
        dirs.append(str(d))
    (tmp_path / "running").mkdir()  # no run.json until it ends
    dirs.append(str(tmp_path / "running"))
    assert ok_runs(dirs) == [tmp_path / "a", tmp_path / "c"]


def _pysim_config(results):
    return {"results": str(results), "studies": {"sphere_jamming": {
        "engines": ["pysim"], "seeds": [1],
        "case": {"particles": {"n": 100, "diameter": {"mean": 1.0}},
                 "contact": {"law": "hooke", "k_n": 1e5, "gamma_n": 300.0, "gamma_bg": 1.0},
                 "protocol": {"name": "compress", "phi_init": 0.3, "phi_fast": 0.55,
                              "rate_fast": 0.2, "rate": 0.005, "phi_final": 0.66, "dt": 1e-4},
                 "output": {"thermo_every": 500, "dump_every": 20000}},
        "variants": {"base": {}}}}}


@pytest.mark.slow
def test_stopped_pipeline_records_nothing_and_resumes(tmp_path):
    """'make stop' (workflows.scripts.stop) stops a running pipeline, --keep-going and all:
    Snakemake starts no further run, the run under way writes no run.json (a stop is not
    a failure) and keeps its checkpoint, and the next run resumes it and finishes."""
    from workflows.scripts.stop import stop

    cfg = tmp_path / "cfg.yaml"
    conf = _pysim_config(tmp_path / "res")
    conf["studies"]["sphere_jamming"]["seeds"] = [1, 2]
    cfg.write_text(yaml.safe_dump(conf))
    proc = subprocess.Popen(snakemake(cfg, "--keep-going", cores="1"),
                            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                            start_new_session=True)
    runs = [tmp_path / "res" / "sphere_jamming" / "base" / f"seed{k}" / "pysim" for k in (1, 2)]

    def started():
        return [d for d in runs if (d / "checkpoint.npz").exists()
                and (d / "thermo.dat.part").exists()]

    deadline = time.time() + 300
    while time.time() < deadline and not started():
        time.sleep(0.05)
    assert started(), "no pysim run checkpointed"
    (out,) = started()
    assert stop(tmp_path, timeout=60) >= 3  # snakemake, the job's shell, runner, pysim
    proc.wait(timeout=60)
    assert started() == [out], "Snakemake started another run after the stop"
    assert not (out / "thermo.dat").exists(), "the run finished before it was stopped"
    assert not any((d / "run.json").exists() for d in runs)
    assert "stopped: the runner got SIGINT" in (out / "log.txt").read_text()
    again = subprocess.run(snakemake(cfg, "--rerun-incomplete", cores="1"), capture_output=True,
                           text=True)
    assert again.returncode == 0, again.stderr[-3000:]
    rec = json.loads((out / "run.json").read_text())
    assert rec["status"] == "ok" and "--resume" in rec["command"]


@pytest.mark.parametrize("sig", [signal.SIGTERM, signal.SIGINT])
def test_engine_killed_by_sigterm_is_stopped_not_failed(tmp_path, sig):
    """A pysim process ended by SIGTERM (a kill, a batch system; it dies of it) or SIGINT
    (Ctrl-C or a kill -INT of that process alone; pysim catches it and exits with 130)
    makes the runner exit with 128 + the signal's number and no run.json, so the run is
    resumed rather than reported as failed."""
    import psutil

    from rodcase.case import validate_case
    from pysim.initial import write_initial

    case = validate_case({**_pysim_config(tmp_path)["studies"]["sphere_jamming"]["case"],
                          "seed": 1})
    (tmp_path / "case.yaml").write_text(yaml.safe_dump(case))
    write_initial(case, tmp_path / "init.data")
    out = tmp_path / "run"
    proc = subprocess.Popen([sys.executable, "-m", "workflows.scripts.run_engine", "--engine",
                             "pysim", "--case", str(tmp_path / "case.yaml"), "--data",
                             str(tmp_path / "init.data"), "--out", str(out)],
                            stderr=subprocess.PIPE, text=True, cwd=ROOT)
    deadline = time.time() + 300
    while time.time() < deadline and not (out / "checkpoint.npz").exists():
        time.sleep(0.05)
    children = psutil.Process(proc.pid).children()
    assert len(children) == 1 and "pysim" in " ".join(children[0].cmdline())
    children[0].send_signal(sig)
    _, err = proc.communicate(timeout=60)
    assert proc.returncode == 128 + sig, err
    assert f"stopped: pysim got {sig.name}" in err
    assert not (out / "run.json").exists() and not (out / "failed").exists()


def test_run_finished_before_the_stop_is_recorded_not_rerun(tmp_path):
    """When the stop reaches the runner after pysim has finished (while it checks the
    run), pysim's own record is kept aside and the next run records it without running
    pysim again."""
    from workflows import engines, runner
    from rodcase.case import validate_case
    from pysim.initial import write_initial
    from tests.cases import PYSIM_COMPRESS
    from tests.runs import pysim_run

    case = validate_case(PYSIM_COMPRESS)
    (tmp_path / "case.yaml").write_text(yaml.safe_dump(case))
    write_initial(case, tmp_path / "init.data")
    out = tmp_path / "run"
    subprocess.run(pysim_run(tmp_path / "case.yaml", tmp_path / "init.data", out), check=True,
                   capture_output=True)
    # what the runner leaves when stopped in that window
    (out / "resume.json").write_text(json.dumps(
        engines.resume_stamp("pysim", case, tmp_path / "init.data")))
    os.replace(out / "run.json", out / runner.FINISHED)
    rec = runner.run("pysim", tmp_path / "case.yaml", tmp_path / "init.data", out, timeout=600)
    assert rec["status"] == "ok", rec.get("error")
    assert not (out / "pysim.log").exists()  # pysim did not run again
    assert not (out / runner.FINISHED).exists()
    assert rec["steps"] > 0


@pytest.mark.slow
def test_compression_with_a_later_phi_final_goes_on_and_a_finished_one_reruns(tmp_path):
    """A compression stopped mid-run and given a later ``phi_final`` (a stop key,
    workflows.engines.restarts.STOP_KEYS) resumes from its checkpoint and ends with the
    files of an uninterrupted run to that ``phi_final``; a finished run whose stop keys
    changed runs again from the start. Any other change of the case is not resumable."""
    from workflows import engines, runner
    from rodcase.case import validate_case
    from pysim.initial import write_initial
    from tests.cases import PYSIM_COMPRESS
    from tests.runs import pysim_run, start_mid_run

    def case_of(**protocol):
        return validate_case({**PYSIM_COMPRESS,
                              "protocol": {**PYSIM_COMPRESS["protocol"], **protocol}})

    short, full = case_of(phi_final=0.62), case_of()
    data = tmp_path / "init.data"
    write_initial(full, data)
    stamp_short = engines.resume_stamp("pysim", short, data)
    assert stamp_short != engines.resume_stamp("pysim", full, data)
    assert engines.resumable(stamp_short, engines.resume_stamp("pysim", full, data))
    assert not engines.resumable(stamp_short,
                                 engines.resume_stamp("pysim", case_of(rate=0.03), data))
    paths = {}
    for name, case in (("short", short), ("full", full)):
        paths[name] = tmp_path / f"{name}.yaml"
        paths[name].write_text(yaml.safe_dump(case))
    ref = tmp_path / "ref"
    subprocess.run(pysim_run(paths["full"], data, ref), check=True, capture_output=True)

    out = tmp_path / "run"
    proc = start_mid_run(paths["short"], data, out)
    proc.send_signal(signal.SIGINT)
    proc.communicate(timeout=60)
    assert not (out / "run.json").exists(), "the run finished before it could be stopped"
    (out / "resume.json").write_text(json.dumps(stamp_short))  # as the runner writes it
    rec = runner.run("pysim", paths["full"], data, out, timeout=600)
    assert rec["status"] == "ok", rec.get("error")
    assert rec["resumed"]
    for name in ("thermo.dat", "particles.dump"):
        assert (out / name).read_bytes() == (ref / name).read_bytes(), name

    rec = runner.run("pysim", paths["short"], data, out, timeout=600)
    assert rec["status"] == "ok", rec.get("error")
    assert not rec["resumed"]
    thermo = pd.read_csv(out / "thermo.dat", sep=r"\s+", comment="#", header=None)
    assert thermo.iloc[-1, 2] == pytest.approx(0.62, abs=1e-3)
