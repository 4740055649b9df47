"""The one place where Numba options are set.

Every kernel in pysim is compiled with ``JIT_FLAGS``; the few kernels that run their
particle or pair loops on several threads (``numba.prange``) use ``PARALLEL_FLAGS``, the
same flags plus ``parallel=True``. ``fastmath`` stays off: the reference engine must give
bit-identical results for the same seed. ``cache`` makes the second start of the CLI
fast (compiled code is stored in ``pysim/__pycache__/numba-<hash of the sources>``, so
that editing any kernel recompiles every kernel that may have inlined it).

Helpers called once per pair or per particle take and return scalars only: an array
argument costs two atomic reference-count updates per call, more than a contact law.

Threads never change results: every parallel loop either writes only to the particle or
pair it owns, or reduces over fixed blocks whose partial sums are added in block order
(see :mod:`pysim.contacts`; on one thread the contact pass adds the reactions itself, in
the order the threaded gather uses), so 1 and 2 threads give the same bits. The kernels
run on :func:`set_threads` threads, at most ``NUMBA_NUM_THREADS`` (Numba's pool: all cores
unless set; :func:`max_threads`); Numba's default is the whole pool, the CLI's
(``python -m pysim run --threads N``) is 1, as in the pipeline.

One hint beyond Numba's own: :func:`prefetch_write` (``llvm.prefetch``), for the rod pass's
scattered updates (see :func:`pysim.contacts.rods._rod_select`).

Set ``NUMBA_DISABLE_JIT=1`` to run every kernel as plain Python (slow, but with
readable tracebacks and real coverage).
"""
from __future__ import annotations

import hashlib
import os
import shutil
import warnings
from pathlib import Path

import numba
import numba.extending


def _source_hash() -> str:
    """Hash of every pysim source file: Numba's cache notices a change in a kernel's own
    file but not in the files of the kernels it calls, and a stale cached kernel can then
    run with a changed callee (wrong results or a crash). Keying the cache directory by
    the hash of all sources rules that out."""
    h = hashlib.sha256()
    root = Path(__file__).resolve().parent
    for p in sorted(root.rglob("*.py")):
        h.update(str(p.relative_to(root)).encode())
        h.update(p.read_bytes())
    return h.hexdigest()[:16]


def _use_versioned_cache() -> None:
    if os.environ.get("NUMBA_CACHE_DIR"):
        return  # the user chose a cache directory
    base = Path(__file__).resolve().parent / "__pycache__"
    current = base / f"numba-{_source_hash()}"
    numba.config.CACHE_DIR = str(current)
    try:  # drop caches of earlier sources, once no process can still be using them
        import time

        for old in base.glob("numba-*"):
            if old != current and time.time() - old.stat().st_mtime > 86400:
                shutil.rmtree(old, ignore_errors=True)
    except OSError:
        pass


_use_versioned_cache()

JIT_FLAGS = dict(cache=True, fastmath=False, nogil=True, error_model="numpy")
PARALLEL_FLAGS = dict(JIT_FLAGS, parallel=True)

# The OpenMP layer starts a parallel region in a few microseconds (the kernels start
# five per time step); fall back to Numba's own pool where libgomp is missing.
numba.config.THREADING_LAYER_PRIORITY = ["omp", "tbb", "workqueue"]


def _layer_started_elsewhere() -> str | None:
    """The threading layer Numba's threads already run on when something started them
    before pysim was imported (``numba.set_num_threads``, a parallel kernel) on another
    layer than OpenMP: the priority above then had no say. None otherwise, and when
    ``NUMBA_THREADING_LAYER`` names a layer on purpose."""
    from numba.np.ufunc import parallel

    if not parallel._is_initialized or os.environ.get("NUMBA_THREADING_LAYER"):
        return None
    layer = numba.threading_layer()
    return None if layer == "omp" else layer


if (_early_layer := _layer_started_elsewhere()) is not None:
    warnings.warn(
        f"Numba's threads were started on the {_early_layer!r} layer before pysim was "
        "imported, so pysim could not choose OpenMP; threaded steps then take up to about "
        "twice as long (docs/performance.md). Import pysim before calling "
        "numba.set_num_threads, or set NUMBA_THREADING_LAYER to choose a layer on purpose.",
        RuntimeWarning, stacklevel=2)

njit = numba.njit(**JIT_FLAGS)
"""Decorator: ``@njit`` compiles a kernel with the project's JIT flags."""

inline_njit = numba.njit(**JIT_FLAGS, inline="always")
"""Decorator: ``@inline_njit`` compiles a kernel that Numba inlines into its callers (LLVM
declines to inline a large one, and a loop that calls a function cannot run on SIMD
lanes)."""

pnjit = numba.njit(**PARALLEL_FLAGS)
"""Decorator: ``@pnjit`` compiles a kernel whose ``prange`` loops run on threads."""

prange = numba.prange


def _prefetch_write_python(arr, offset):
    """Plain-Python stand-in of :func:`prefetch_write` (``NUMBA_DISABLE_JIT=1``): a hint
    only, so nothing to do."""


def _prefetch_write_intrinsic(typingctx, arr, offset):
    if not (isinstance(arr, numba.types.Array) and arr.layout == "C"
            and isinstance(offset, numba.types.Integer)):
        return None  # a typing error: C-contiguous arrays and integer offsets only

    def codegen(context, builder, sig, args):
        from llvmlite import ir
        from numba.core import cgutils

        ary = context.make_array(sig.args[0])(context, builder, args[0])
        off = context.cast(builder, args[1], sig.args[1], numba.types.int64)
        ptr = builder.bitcast(builder.gep(ary.data, [off]), ir.IntType(8).as_pointer())
        i32 = ir.IntType(32)
        fn = cgutils.get_or_insert_function(
            builder.module, ir.FunctionType(ir.VoidType(), [ptr.type, i32, i32, i32]),
            "llvm.prefetch.p0")
        # write intent, keep in all cache levels, data cache
        builder.call(fn, [ptr, ir.Constant(i32, 1), ir.Constant(i32, 3), ir.Constant(i32, 1)])
        return context.get_dummy_value()

    return numba.types.void(arr, offset), codegen


if numba.config.DISABLE_JIT:
    prefetch_write = _prefetch_write_python
else:
    prefetch_write = numba.extending.intrinsic(_prefetch_write_intrinsic)
prefetch_write.__doc__ = """``prefetch_write(arr, offset)``: ask the CPU to bring the cache line
of element ``offset`` of the flattened C-contiguous ``arr`` into the caches, to be written
(LLVM's ``llvm.prefetch``; a hint: no effect on results). For data that a kernel loads
irregularly and some loop after the next one updates. An intrinsic: its code is emitted
in place, so the array argument costs no call and no reference counting."""


def max_threads() -> int:
    """Size of Numba's thread pool (``NUMBA_NUM_THREADS``, all cores unless set): the most
    threads :func:`set_threads` accepts."""
    return int(numba.config.NUMBA_NUM_THREADS)


def set_threads(n: int) -> None:
    """Use ``n`` threads in the parallel kernels, ``1 <= n <=`` :func:`max_threads`; starts
    the pool (on OpenMP: this module's import set the layer priority first)."""
    n = int(n)
    if not 1 <= n <= max_threads():
        raise ValueError(f"threads = {n} is not allowed; use 1 to {max_threads()} (the size of "
                         "Numba's pool, NUMBA_NUM_THREADS)")
    numba.set_num_threads(n)


def get_threads() -> int:
    """Threads the parallel kernels use now."""
    return int(numba.get_num_threads())
