"""The kernel tests again with NUMBA_DISABLE_JIT=1: the same Python source runs as plain
Python, so coverage is real and tracebacks readable (style.md: PySDM)."""
import os
import subprocess
import sys
from pathlib import Path

import pytest

HERE = Path(__file__).resolve().parent


@pytest.mark.slow
def test_kernels_without_jit():
    env = dict(os.environ, NUMBA_DISABLE_JIT="1")
    names = ("test_geometry.py", "test_contacts.py", "test_neighbors.py", "test_jit.py")
    files = [str(HERE / f) for f in names]
    r = subprocess.run([sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", *files],
                       capture_output=True, text=True, env=env, cwd=HERE.parents[1])
    assert r.returncode == 0, r.stdout[-3000:] + r.stderr[-2000:]
    assert " passed" in r.stdout and "failed" not in r.stdout
