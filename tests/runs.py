"""pysim runs through its command line (``python -m pysim run``), for the tests that check
a run's files, its signals and its resume."""
import signal
import subprocess
import sys
import time

import yaml

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
