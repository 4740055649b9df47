"""Shared test helpers. Long physics validations carry the ``validation`` marker and
run only with ``--validate``; tests that need an engine binary skip without it."""
from __future__ import annotations

import os
import shutil

import numpy as np
import pytest


def pytest_addoption(parser):
    parser.addoption("--validate", action="store_true", help="also run long validations")


def pytest_configure(config):
    # Under pytest-xdist each worker is its own process: two workers with two Numba
    # threads each would put four spinning OpenMP threads on two cores. Tests that need
    # two threads set them and restore this.
    if os.environ.get("PYTEST_XDIST_WORKER"):
        from pysim.jit import set_threads

        set_threads(1)


def pytest_collection_modifyitems(config, items):
    if config.getoption("--validate"):
        return
    skip = pytest.mark.skip(reason="long validation: run with --validate")
    for item in items:
        if "validation" in item.keywords:
            item.add_marker(skip)


@pytest.fixture
def rng():
    return np.random.default_rng(12345)


needs_liggghts = pytest.mark.skipif(shutil.which("liggghts") is None,
                                    reason="LIGGGHTS is not installed (make liggghts as root)")
