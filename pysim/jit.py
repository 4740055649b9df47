"""The one place where Numba options are set.

Every kernel in pysim is compiled with ``JIT_FLAGS``. ``fastmath`` stays off: the
reference engine must give bit-identical results for the same seed. ``cache`` makes
the second start of the CLI fast (compiled code is stored next to the sources).

Set ``NUMBA_DISABLE_JIT=1`` to run every kernel as plain Python (slow, but with
readable tracebacks and real coverage).
"""
from __future__ import annotations

import numba

JIT_FLAGS = dict(cache=True, fastmath=False, nogil=True, error_model="numpy")

njit = numba.njit(**JIT_FLAGS)
"""Decorator: ``@njit`` compiles a kernel with the project's JIT flags."""
