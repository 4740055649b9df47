"""Observables of one compression run, as tidy rows, the same for every engine.

``analyse_compression`` reads a run directory in the common format and returns

* observables: ``phi_j`` (with its fit error), ``jamming_slope`` (``dp/dphi`` of the
  fit), ``z_j`` (rattler-free contact number
  at the first frame at or above ``phi_J``), ``z_j_with_rattlers``,
  ``rattler_fraction_j``, ``phi_at_z_j``, ``phi_final``, ``pressure_final``;
* curves: per output frame, ``phi``, contact ``pressure`` (from the contact table),
  ``z``, ``z_rattler_free``, ``n_rattlers`` and the thermo ``p(phi)``.
"""
from __future__ import annotations

import numpy as np
import pandas as pd

from analysis.contacts import ContactNumber
from analysis.io import RunData
from analysis.jamming import JammingFitError, JammingPoint
from analysis.packing import packing_fraction
from analysis.stress import pressure

TIDY_COLUMNS = ["study", "case", "engine", "seed", "observable", "value", "uncertainty"]


def analyse_compression(run_dir, window, p_scale: float, c_min: int = 4):
    """Observables ``[(name, value, uncertainty)]`` and per-frame curves of one run.

    ``window`` is the jamming-fit pressure window in units of ``p_scale`` (``k_n/D``);
    ``c_min`` the rattler threshold (3-D spheres: 4).
    """
    run = RunData(run_dir)
    thermo = run.thermo
    rows = []
    curves = []
    for frame, contacts in run.frames():
        cn = ContactNumber(c_min).compute(frame, contacts)
        curves.append({"step": frame.step, "phi": packing_fraction(frame),
                       "pressure": pressure(frame, contacts), "z": cn.z,
                       "z_rattler_free": cn.z_rattler_free, "n_rattlers": cn.n_rattlers,
                       "n": frame.n})
    curves = pd.DataFrame(curves)
    try:
        jp = JammingPoint(window, p_scale).compute(thermo.phi.to_numpy(), thermo.pressure.to_numpy())
        phi_j, phi_j_err, slope = jp.phi_j, jp.phi_j_err, jp.slope
        fit = {"rows": (jp.rows.start, jp.rows.stop)}
    except JammingFitError as exc:
        phi_j, phi_j_err, slope, fit = np.nan, np.nan, np.nan, {"error": str(exc)}
    rows += [("phi_j", phi_j, phi_j_err), ("jamming_slope", slope, np.nan)]
    above = curves[curves.phi >= phi_j] if np.isfinite(phi_j) else curves.iloc[0:0]
    if len(above):
        first = above.iloc[0]
        rows += [("z_j", first.z_rattler_free, np.nan),
                 ("z_j_with_rattlers", first.z, np.nan),
                 ("rattler_fraction_j", first.n_rattlers / first.n, np.nan),
                 ("phi_at_z_j", first.phi, np.nan)]
    else:
        rows += [(k, np.nan, np.nan) for k in
                 ("z_j", "z_j_with_rattlers", "rattler_fraction_j", "phi_at_z_j")]
    last = thermo.iloc[-1]
    rows += [("phi_final", float(last.phi), np.nan), ("pressure_final", float(last.pressure), np.nan)]
    curves.attrs["fit"] = fit
    return rows, curves, thermo


def tidy(rows, study, case, engine, seed, parameters: dict | None = None) -> pd.DataFrame:
    """Tidy table of observables with one column per varying case parameter."""
    df = pd.DataFrame(rows, columns=["observable", "value", "uncertainty"])
    df.insert(0, "seed", seed)
    df.insert(0, "engine", engine)
    df.insert(0, "case", case)
    df.insert(0, "study", study)
    for k, v in (parameters or {}).items():
        df[k] = v
    return df
