"""The pipeline through SLURM: the Snakemake executor plugin with workflows/profiles/slurm
on a one-node cluster of this machine (workflows/cluster/local_slurm.py), brought up for
these tests and torn down after them, whatever happens.

Skipped, saying why, where the cluster cannot run: not root, SLURM missing and no
apt-get, the daemons do not start, another local cluster is up, or the machine has its
own SLURM configuration.
"""
import json
import os
import re
import shutil
import subprocess
import sys
import time
from pathlib import Path

import pytest
import yaml

ROOT = Path(__file__).resolve().parents[2]
SNAKEMAKE = str(Path(sys.executable).parent / "snakemake")
PROFILE = ROOT / "workflows" / "profiles" / "slurm"
ENGINES = ["pysim", "lammps"] + (["liggghts"] if shutil.which("liggghts") else [])
#: seconds any one Snakemake may take before the test gives up on it
PATIENCE = 600

pytestmark = [pytest.mark.engines, pytest.mark.slurm]


def tiny_config(engines=ENGINES, rate=0.05, n=150):
    """One study, one seed: quick.yaml's case shape on a few spheres."""
    return {
        "results": "results",
        "engines": {"pysim": {"threads": 1}, "lammps": {"ranks": 1}, "liggghts": {"ranks": 1}},
        "studies": {"sphere_jamming": {
            "engines": list(engines), "seeds": [1],
            "case": {
                "particles": {"n": n, "diameter": {"distribution": "mono", "mean": 1.0},
                              "density": 1.0},
                "contact": {"law": "hooke", "k_n": 1e5, "gamma_n": 300.0, "friction": 0.0,
                            "gamma_bg": 1.0},
                "protocol": {"name": "compress", "phi_init": 0.3, "phi_fast": 0.55,
                             "rate_fast": 0.2, "rate": rate, "phi_final": 0.68, "dt": 1e-4},
                "output": {"thermo_every": 500, "dump_every": 2000},
            },
            "analysis": {"jamming_window": [1e-3, 1e-2]},
        }},
    }


@pytest.fixture(scope="module")
def cluster(tmp_path_factory, request):
    """The state directory of a running one-node cluster; stopped after the module's
    tests (its jobs cancelled, its daemons ended), also when a test or the start fails."""
    from workflows.cluster import local_slurm

    state = tmp_path_factory.mktemp("slurm")
    request.addfinalizer(lambda: local_slurm.down(state))
    try:
        local_slurm.up(state)
    except local_slurm.Unavailable as exc:
        pytest.skip(f"no local SLURM cluster: {exc}")
    return state


def _env(state):
    # the jobs import this checkout's workflows (the venv may hold another's)
    path = os.pathsep.join(p for p in (str(ROOT), os.environ.get("PYTHONPATH")) if p)
    return dict(os.environ, SLURM_CONF=str(state / "slurm.conf"), PYTHONPATH=path)


def _snakemake(*extra, slurm=True):
    """A Snakemake of the project's Snakefile in the current directory, through the SLURM
    profile (squeue for the status: the local cluster keeps no accounting) or locally."""
    cmd = [SNAKEMAKE, "--snakefile", str(ROOT / "Snakefile"), "--configfile", "cfg.yaml"]
    if slurm:
        cmd += ["--profile", str(PROFILE), "--slurm-status-command", "squeue",
                "--slurm-init-seconds-before-status-checks", "2"]
    else:
        cmd += ["--cores", "2"]
    return cmd + ["--", *extra]


def _workdir(path, cfg):
    path.mkdir()
    (path / "cfg.yaml").write_text(yaml.safe_dump(cfg))
    return path


def _pysim_job(env):
    """The SLURM job id of the pysim run (the plugin's comment names rule and wildcards)."""
    q = subprocess.run(["squeue", "-h", "-o", "%A|%k"], env=env, capture_output=True,
                       text=True, check=True)
    (job,) = [line.split("|")[0] for line in q.stdout.splitlines()
              if "rule_run_engine" in line and line.endswith("_pysim")]
    return job


def test_slurm_run_resumes_a_scancelled_job_and_equals_a_local_run(cluster, tmp_path):
    """Every engine's run and analysis go through sbatch with the profile unedited (no
    account, the default partition). The pysim run, cancelled mid-run with scancel, is
    stopped, not failed, as 'make stop' stops a local run (no run.json, its checkpoint
    kept) while the other runs go on; the next submission resumes it from that checkpoint.
    Then summary.csv is byte for byte that of a local run of the same configuration and
    seed, run beside the cluster's (whose jobs spend most of their time waiting for the
    status queries)."""
    cfg = tiny_config(rate=0.01)  # pysim runs for a while: it is cancelled mid-run
    here, there = _workdir(tmp_path / "local", cfg), _workdir(tmp_path / "slurm", cfg)
    target = "results/summary.csv"
    run = there / "results/sphere_jamming/base/seed1/pysim"
    env = _env(cluster)
    t0 = time.monotonic()
    with open(here / "snakemake.log", "w") as log:
        local = subprocess.Popen(_snakemake(target, slurm=False), cwd=here, env=env,
                                 stdout=log, stderr=subprocess.STDOUT)
    with open(there / "first.log", "w") as log:
        first = subprocess.Popen(_snakemake(target), cwd=there, env=env, stdout=log,
                                 stderr=subprocess.STDOUT)
    try:
        def running():  # checkpointed and a few thermo rows on
            part = run / "thermo.dat.part"
            return (run / "checkpoint.npz").exists() and part.exists() and \
                len(part.read_text().splitlines()) >= 4

        deadline = time.monotonic() + PATIENCE
        while time.monotonic() < deadline and not running() and first.poll() is None:
            time.sleep(0.2)
        assert running(), (there / "first.log").read_text()[-3000:]
        job = _pysim_job(env)
        subprocess.run(["scancel", job], env=env, check=True)
        first.wait(timeout=PATIENCE)
        t1 = time.monotonic()
        out1 = (there / "first.log").read_text()
        assert first.returncode != 0 and \
            f"SLURM-job '{job}' failed, SLURM status is: 'CANCELLED'" in out1, out1[-3000:]
        # the stopped run: no record, no result, its checkpoint kept
        assert not (run / "run.json").exists() and not (run / "failed").exists()
        assert not (run / "thermo.dat").exists(), "pysim had finished before the scancel"
        assert (run / "checkpoint.npz").exists()
        log = (run / "log.txt").read_text()
        assert re.search(r"stopped: (the runner|pysim) got SIGTERM", log), log
        again = subprocess.run(_snakemake(target), cwd=there, env=env, text=True,
                               capture_output=True, timeout=PATIENCE)
        t2 = time.monotonic()
        local.wait(timeout=PATIENCE)
    finally:
        for proc in (local, first):
            if proc.poll() is None:
                proc.kill()
    out2 = again.stdout + again.stderr
    assert again.returncode == 0, out2[-4000:]
    rec = json.loads((run / "run.json").read_text())
    assert rec["status"] == "ok" and "--resume" in rec["command"], rec
    for engine in ENGINES:
        rec = json.loads((run.parent / engine / "run.json").read_text())
        assert rec["status"] == "ok", rec.get("error")
    # init_case, an engine run and its analysis each, summary; pysim's run twice
    submitted = re.findall(r"has been submitted with SLURM jobid \d+", out1 + out2)
    assert len(submitted) == 2 + 2 * len(ENGINES) + 1, out1[-3000:] + out2[-3000:]
    # every rule books its wall time and memory (the profile and the engine rule)
    for warning in ("No wall time information", "No job memory information"):
        assert warning not in out1 + out2
    assert local.returncode == 0, (here / "snakemake.log").read_text()[-4000:]
    mine = (there / target).read_text()
    assert {line.split(",")[2] for line in mine.splitlines()[1:]} == set(ENGINES)
    assert mine == (here / target).read_text()
    print(f"through SLURM: {t1 - t0:.0f} s to the scancel and the first Snakemake's end, "
          f"{t2 - t1:.0f} s for the resubmission; the local run beside it")
