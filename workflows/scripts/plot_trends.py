"""Observables of a study versus its varying case parameter, engines overlaid, with the
theory curves of analysis.theory where one exists."""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np
import pandas as pd

from analysis import plots

OBSERVABLES = ["phi_j", "z_j", "z_j_bonds", "s_nematic_j", "sqrt_n_s2", "sqrt_n_s4",
               "fraction_side_side", "fraction_tip_side", "fraction_tip_tip"]


def references(parameter: str, dimension: int) -> dict:
    """Theory on the observables' axes: isostatic counts and, in 3-D, the random contact
    equation phi = <C> V / V_excl evaluated at the isostatic <C>."""
    if parameter != "alpha":
        return {}
    from analysis import theory

    a = np.linspace(0.0, 20.0, 201)
    if dimension == 2:
        z2 = np.where(a > 0, theory.isostatic_z(2, True), theory.isostatic_z(2, False))
        return {"z_j_bonds": [("isostatic 2 d_f", a, z2)]}
    z_iso = np.where(a > 0, theory.isostatic_z(3, True), theory.isostatic_z(3, False))
    thick = a >= 3  # the random contact equation holds for slender rods
    phi_rce = np.array([theory.rce_packing_fraction(10.0, ai) for ai in a[thick]])
    return {"z_j": [("isostatic 2 d_f", a, z_iso)],
            "phi_j": [("random contact eq., <C> = 10", a[thick], phi_rce)]}


def label_protocols(df: pd.DataFrame) -> pd.DataFrame:
    """Runs of another protocol than the study's (LIGGGHTS' rods settled under gravity,
    with an observable ``settled``) get their own series, ``<engine> settled``, so that
    no line joins a compression's point to a settled bed's."""
    settled = df[(df.observable == "settled") & (df.value == 1)][["case", "engine"]]
    if settled.empty:
        return df
    df = df.copy()
    key = pd.MultiIndex.from_frame(df[["case", "engine"]])
    mark = key.isin(pd.MultiIndex.from_frame(settled))
    df.loc[mark, "engine"] = df.loc[mark, "engine"] + " settled"
    return df


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--summary", required=True, type=Path)
    ap.add_argument("--study", required=True)
    ap.add_argument("--parameter", required=True)
    ap.add_argument("--dimension", type=int, default=3)
    ap.add_argument("--out", required=True, type=Path)
    a = ap.parse_args(argv)
    df = pd.read_csv(a.summary)
    df = df[df.study == a.study]
    df = label_protocols(df)
    plots.trends(df, a.parameter, OBSERVABLES, a.out, title=a.study,
                 references=references(a.parameter, a.dimension))
    return 0


if __name__ == "__main__":
    sys.exit(main())
