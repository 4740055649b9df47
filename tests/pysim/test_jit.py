"""pysim.jit: the prefetch hint compiles into kernels (and is a no-op in plain Python)."""
import numpy as np
import pytest

from pysim.jit import njit, prefetch_write


@njit
def _touch(a, idx):
    """Prefetch the lines of ``a[idx]`` (flattened rows of 3), then add 1 to those rows."""
    for k in range(idx.shape[0]):
        prefetch_write(a, 3 * idx[k])
        prefetch_write(idx, k)
    for k in range(idx.shape[0]):
        for c in range(3):
            a[idx[k], c] += 1.0
    return a.sum()


def test_prefetch_write_is_only_a_hint(rng):
    """Prefetching the rows a kernel then updates leaves its results those of the same
    loops without the hint."""
    a = rng.normal(size=(1000, 3))
    idx = rng.integers(0, 1000, 300).astype(np.int32)
    want = a.copy()
    np.add.at(want, idx, 1.0)
    total = _touch(a, idx)
    assert np.array_equal(a, want)
    assert total == pytest.approx(want.sum(), rel=1e-12)


def test_prefetch_write_needs_a_contiguous_array():
    """A strided view has no flat element offset: typing refuses it rather than
    prefetching the wrong lines."""
    import numba

    if numba.config.DISABLE_JIT:
        pytest.skip("plain Python: the hint is a no-op for any array")
    strided = np.zeros((10, 6))[:, :3]  # rows of 3 with a stride of 6
    with pytest.raises(numba.core.errors.TypingError):
        _touch(strided, np.arange(2, dtype=np.int32))


def _import_after(started: str) -> str:
    """The warnings (stderr) of a fresh interpreter that runs ``started`` and then
    imports pysim."""
    import os
    import subprocess
    import sys
    from pathlib import Path

    env = {k: v for k, v in os.environ.items() if k != "NUMBA_THREADING_LAYER"}
    p = subprocess.run([sys.executable, "-c", started + "\nimport pysim.jit"],
                       capture_output=True, text=True, env=env,
                       cwd=Path(__file__).resolve().parents[2], timeout=300)
    assert p.returncode == 0, p.stderr
    return p.stderr


def test_threads_started_on_another_layer_before_import_warn():
    """Numba's threads started before pysim's import run on the layer Numba chose then,
    not on OpenMP (1.6-2 times slower steps on 2 threads): the import says so and how to
    avoid it; started after the import, nothing is said."""
    early = ("import numba\nnumba.config.THREADING_LAYER = 'workqueue'\n"
             "numba.set_num_threads(1)")
    err = _import_after(early)
    assert "RuntimeWarning" in err and "'workqueue' layer" in err
    assert "Import pysim before calling numba.set_num_threads" in err
    assert "layer" not in _import_after("import numba")
