"""Sanity checks of a finished run, the same for every engine.

A run that wrote its files can still have blown up: NaN in the thermo table, kinetic
energy running away, or particles driven through each other. :func:`check_run` reads
the common format and returns a one-line description of the first such problem (step
and particles), or ``None``.
"""
from __future__ import annotations

import numpy as np

from analysis.io import read_contact_frames, read_thermo
from rodcase.case import HARD_SPHERE_PROTOCOLS

#: overlap, as a fraction of the mean diameter, that no sane packing reaches
MAX_OVERLAP = 0.25
#: overlap, in mean diameters, above which hard spheres have passed through each other
#: (round-off of the dump's 10 digits stays far below)
HARD_OVERLAP = 1e-6


def _contact_energy(case: dict, overlap: float, d: float) -> float:
    c = case["contact"]
    if c["law"] == "hertz":
        return 0.4 * c["k_n"] * overlap**2.5
    if c["law"] == "harmonic":
        return 0.5 * c["k_n"] * (overlap / d) ** 2
    return 0.5 * c["k_n"] * overlap**2


def check_run(run_dir, case: dict, max_overlap: float | None = None) -> str | None:
    """First sign of a blow-up in a run directory, or ``None``.

    * any non-finite value in ``thermo.dat`` (a container has no box packing fraction or
      pressure: in a container only time, ke and n_contacts are checked);
    * kinetic energy per particle above the elastic energy of one contact overlapping by
      ``max_overlap`` diameters (a packing never stores that much motion);
    * any contact in ``contacts.dump`` overlapping by more than ``max_overlap`` mean
      diameters.
    """
    from pathlib import Path

    run_dir = Path(run_dir)
    if case["protocol"]["name"] in HARD_SPHERE_PROTOCOLS:
        return check_hard_run(run_dir, case)
    if max_overlap is None:
        max_overlap = float(case["contact"].get("max_overlap", MAX_OVERLAP))
    th = read_thermo(run_dir / "thermo.dat")
    cols = ["time", "phi", "pressure", "ke", "n_contacts"]
    if "container" in case:  # tapping, deposit: no box packing fraction or pressure
        cols = ["time", "ke", "n_contacts"]
    values = (th[cols].apply(lambda c: c.astype(np.float64)).to_numpy() if len(th)
              else np.zeros((0, len(cols))))
    bad = ~np.isfinite(values).all(axis=1)
    if bad.any():
        row = th[bad].iloc[0]
        return f"non-finite thermo values at step {int(row.step)}"
    d = case["particles"]["diameter"]["mean"]
    n = case["particles"]["n"]
    ke_max = n * _contact_energy(case, max_overlap * d, d)
    runaway = th.ke > ke_max
    if runaway.any():
        row = th[runaway].iloc[0]
        return (f"runaway kinetic energy {row.ke:.3g} (> {ke_max:.3g}, the energy of every "
                f"particle in a contact overlapping {max_overlap} D) at step {int(row.step)}")
    over = first_overlap_above(run_dir, max_overlap * d)
    if over:
        overlap, i, j, step = over
        return (f"overlap {overlap / d:.3g} D between particles {i} and {j} at step {step} "
                f"(limit {max_overlap} D)")
    return None


def first_overlap_above(run_dir, limit: float):
    """``(overlap, i, j, step)`` of the largest overlap of the first frame of
    ``contacts.dump`` that has one above ``limit`` (length), or ``None``."""
    for c in read_contact_frames(run_dir / "contacts.dump"):
        if c.n == 0:
            continue
        k = int(np.argmax(c.overlap))
        if c.overlap[k] > limit:
            return float(c.overlap[k]), int(c.i[k]), int(c.j[k]), int(c.step)
    return None


def check_hard_run(run_dir, case: dict) -> str | None:
    """First sign of a broken hard-sphere run (pysim's ``ls``, ``fb``, ``mls``), or
    ``None``: a non-finite packing fraction in ``thermo.dat`` (its force-biased rows have
    no time, pressure or kinetic energy, docs/formats.md), or two spheres of a frame
    overlapping by more than :data:`HARD_OVERLAP` mean diameters."""
    from pathlib import Path

    run_dir = Path(run_dir)
    th = read_thermo(run_dir / "thermo.dat")
    bad = ~np.isfinite(th["phi"].astype(np.float64).to_numpy())
    if bad.any():
        return f"non-finite packing fraction at step {int(th[bad].iloc[0].step)}"
    d = case["particles"]["diameter"]["mean"]
    over = first_overlap_above(run_dir, HARD_OVERLAP * d)
    if over:
        overlap, i, j, step = over
        return (f"hard spheres {i} and {j} overlap by {overlap / d:.3g} D at step {step} "
                f"(limit {HARD_OVERLAP} D)")
    return None
