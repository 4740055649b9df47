"""pysim runs through its command line (``python -m pysim run``), for the tests that check
a run's files, its signals and its resume; and the checks of a tapping run that every
engine's tests share."""
import signal
import subprocess
import sys
import time

import numpy as np
import yaml

from analysis.io import RunData
from pysim.initial import write_initial
from rodcase.case import validate_case


def pysim_run(case_path, data, out, *extra):
    """The command line of a pysim run of ``case_path`` from ``data`` into ``out``."""
    return [sys.executable, "-m", "pysim", "run", str(case_path), "--data", str(data), "--out",
            str(out), "--no-progress", *extra]


def run_case(tmp_path, case, *extra):
    """Validate ``case``, write it and its initial state into ``tmp_path`` and run pysim
    on it to the end; the run's folder (``tmp_path/out``)."""
    case = validate_case(case)
    cp = tmp_path / "case.yaml"
    cp.write_text(yaml.safe_dump(case))
    write_initial(case, tmp_path / "init.data")
    r = subprocess.run(pysim_run(cp, tmp_path / "init.data", tmp_path / "out", *extra),
                       capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    return tmp_path / "out"


def analyse(out, case_path, study="s", variant="v", seed=1):
    """The pipeline's analysis of the run in ``out`` (``observables.csv``, ``curves.csv``
    beside its files), through its command line."""
    r = subprocess.run([sys.executable, "-m", "workflows.scripts.analyse_run", "--case",
                        str(case_path), "--run", str(out), "--study", study, "--variant",
                        variant, "--seed", str(seed), "--engine", "pysim", "--observables",
                        str(out / "observables.csv"), "--curves", str(out / "curves.csv")],
                       capture_output=True, text=True)
    assert r.returncode == 0, r.stderr


def start_mid_run(case_path, data, out) -> subprocess.Popen:
    """A pysim run (checkpointing every chunk) in the background, returned once it has
    checkpointed and written 40 thermo lines: mid-run, for a signal to stop it."""
    # SIGINT back to its default in the child: a test suite started in the background of
    # a non-interactive shell ignores SIGINT, the child inherits that, and Python then
    # installs no KeyboardInterrupt handler (the Ctrl-C test failed so under 'make test &')
    proc = subprocess.Popen(pysim_run(case_path, data, out, "--checkpoint-every", "0"),
                            stderr=subprocess.PIPE, text=True,
                            preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    thermo_part = out / "thermo.dat.part"
    deadline = time.time() + 120
    while time.time() < deadline:
        if (out / "checkpoint.npz").exists() and thermo_part.exists() \
                and thermo_part.read_text().count("\n") > 40:
            break
        time.sleep(0.05)
    return proc


def prepared(tmp_path_factory, name, case):
    """``(validated case, folder)``: a fresh folder ``name`` holding the case's initial
    state, ``init.data``, for the engines to start from."""
    d = tmp_path_factory.mktemp(name)
    case = validate_case(case)
    write_initial(case, d / "init.data")
    return case, d


def assert_in_the_tapped_container(frames, case, tp, D):
    """Every frame of a tapping run (``(frame, contacts)`` pairs): all the rods, each
    spine end with its radius inside the cylinder and above the moving base of plan
    ``tp``, and every overlap, up to 0.05 ``D``."""
    rc = 0.5 * case["container"]["diameter"]
    for f, contacts in frames:
        assert f.n == case["particles"]["n"]
        ends = np.concatenate([f.x + 0.5 * f.length[:, None] * f.axis,
                               f.x - 0.5 * f.length[:, None] * f.axis])
        r = np.tile(f.radius, 2)
        assert np.all(np.hypot(ends[:, 0], ends[:, 1]) + r < rc + 0.05 * D)
        assert np.all(ends[:, 2] - r > tp.base_height(f.step) - 0.05 * D)
        assert np.all(contacts.overlap < 0.05 * D)


def assert_resumed_like_uninterrupted(thermo, full, restart_step):
    """A run resumed from its restart at ``restart_step`` (its ``thermo``) against the
    uninterrupted run in ``full``: the same kinetic energy, bit for bit, up to the restart,
    and within 5 % in the next two rows (a tapping base's phase goes on, not restarted)."""
    ref = RunData(full).thermo.set_index("step")
    mine = thermo.set_index("step")
    before = mine.index[mine.index <= restart_step]
    np.testing.assert_array_equal(mine.loc[before, "ke"], ref.loc[before, "ke"])
    after = mine.index[mine.index > restart_step][:2]
    np.testing.assert_allclose(mine.loc[after, "ke"], ref.loc[after, "ke"], rtol=0.05)


def stopped_and_resumed(run, monkeypatch, stage_class, stop_at: int, full_dir, cut_dir) -> dict:
    """A hard-sphere driver's ``run(out_dir, **options)`` stopped by Ctrl-C at the
    ``stop_at``-th block of ``stage_class`` (checkpointing after every block), then resumed
    into ``cut_dir``: its summary, once every file of the run is checked to hold the bytes
    of the uninterrupted run in ``full_dir``."""
    import pytest

    step = stage_class.step
    calls = {"n": 0}

    def stop_after_a_while(self, arg):
        calls["n"] += 1
        if calls["n"] == stop_at:
            raise KeyboardInterrupt
        return step(self, arg)

    monkeypatch.setattr(stage_class, "step", stop_after_a_while)
    with pytest.raises(KeyboardInterrupt):
        run(cut_dir, progress=False, checkpoint_every=0.0)
    monkeypatch.setattr(stage_class, "step", step)
    again = run(cut_dir, progress=False, resume=True)
    for name in ("particles.dump", "contacts.dump", "thermo.dat", "blocks.dat"):
        assert (cut_dir / name).read_bytes() == (full_dir / name).read_bytes(), name
    return again

