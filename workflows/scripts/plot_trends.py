"""Observables of a study versus its varying case parameter, engines overlaid, with the
theory curves of analysis.theory where one exists."""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np
import pandas as pd

from analysis import plots

OBSERVABLES = ["phi_j", "z_j", "z_j_with_rattlers", "z_j_bonds", "s_nematic_j", "sqrt_n_s2", "sqrt_n_s4",
               "fraction_side_side", "fraction_tip_side", "fraction_tip_tip"]
#: deposits (analysis.summary.analyse_deposit): packing fraction of the filled part, mean
#: angle between spines and the horizontal (degrees), stress ratio K = sigma_hh / sigma_vv
#: in the lower half, how vertical the major principal stress axes are (1 all vertical, 0
#: spread uniformly), Janssen saturation depth h_s / W of sigma_vv
DEPOSIT_OBSERVABLES = ["phi_deposit", "angle_mean", "k_ratio", "major_order", "h_s_vv"]


#: random contacts per caging-number estimate on the trends figure (standard error ~0.25
#: contact, at a cost of seconds per aspect ratio)
CAGING_TRIALS = 200


def caging_curve(alphas) -> tuple[np.ndarray, np.ndarray]:
    """Caging number of 3-D spherocylinders at the aspect ratios ``alphas``
    (:class:`analysis.caging.CagingNumber`: random contacts until the translations, and
    for rods the rotations perpendicular to the axis, are blocked; fixed seed)."""
    from analysis.caging import CagingNumber

    a = np.unique(np.asarray(alphas, dtype=float))
    c = [CagingNumber(radius=0.5, length=float(x), dim=3, trials=CAGING_TRIALS,
                      seed=20261124).compute().mean for x in a]
    return a, np.asarray(c)


def deposit_references(dimension: int, x) -> dict:
    """Isotropic references of deposits over the parameter values ``x``: the mean angle
    to the horizontal of isotropic orientations (3-D: ``pi/2 - 1`` rad = 32.7 deg, 2-D:
    45 deg), the isotropic stress ratio ``K = 1`` and the order 0 of major stress axes
    spread uniformly."""
    x = np.asarray(x, dtype=float)
    iso_angle = np.degrees(np.pi / 2 - 1.0) if dimension == 3 else 45.0
    return {"angle_mean": [("isotropic orientations", x, np.full_like(x, iso_angle))],
            "k_ratio": [("isotropic stress", x, np.ones_like(x))],
            "major_order": [("major axes spread uniformly", x, np.zeros_like(x))]}


def references(parameter: str, dimension: int, alphas=(), values=()) -> dict:
    """Theory on the observables' axes: isostatic counts and, in 3-D, the random contact
    equation phi = <C> V / V_excl evaluated at the isostatic <C> (alpha >= 3) with its
    thin-rod limit ``phi alpha = <C>/2`` (alpha >= 10), and the caging number at the
    study's aspect ratios ``alphas`` beside the contact numbers; for deposits
    :func:`deposit_references`, against any parameter (its ``values`` give the range)."""
    if parameter != "alpha":
        return deposit_references(dimension, sorted(set(values))) if len(values) else {}
    a = np.linspace(0.0, 20.0, 201)
    deposit = deposit_references(dimension, a)
    from analysis import theory

    if dimension == 2:
        z2 = np.where(a > 0, theory.isostatic_z(2, True), theory.isostatic_z(2, False))
        return {"z_j_bonds": [("isostatic 2 d_f", a, z2)], **deposit}
    z_iso = np.where(a > 0, theory.isostatic_z(3, True), theory.isostatic_z(3, False))
    thick = a >= 3  # the random contact equation holds for slender rods
    phi_rce = np.array([theory.rce_packing_fraction(10.0, ai) for ai in a[thick]])
    z_refs = [("isostatic 2 d_f", a, z_iso)]
    if len(alphas):
        ca, cn = caging_curve(alphas)
        z_refs.append(("caging number", ca, cn))
    thin = a >= 10  # its thin-rod limit only for long rods (at alpha 4 it is 1.25)
    return {"z_j": z_refs,
            "phi_j": [("random contact eq., <C> = 10", a[thick], phi_rce),
                      ("thin-rod limit, phi alpha = 5", a[thin],
                       theory.thin_rod_limit(10.0, a[thin]))], **deposit}


#: published values that are not our observable but belong on its panel: Baranau and
#: Tsigelnitskiy's limits of the jamming density, from the lowest (phi_LT, fastest
#: compressions) through phi_RCP to phi_GCP (slowest, before crystallisation), against
#: which a compression's phi_J at its own rate is read; Wouterse et al.'s caging numbers
#: beside ours and the jammed contact numbers
ON_PANEL = {"phi_lt": "phi_j", "phi_rcp": "phi_j", "phi_gcp": "phi_j", "caging_number": "z_j"}


def paper_points(results: Path, study: str, parameter: str, observables) -> list[dict]:
    """The papers' values of ``observables`` (and of those :data:`ON_PANEL` puts on their
    panels, labelled with their own names) along ``parameter`` (a point parameter of
    ``references/``, e.g. ``alpha``) at the other parameters of the study's cases (read
    from ``<results>/<study>/<case>/seed<k>/case.yaml``), for :func:`analysis.plots.trends`.
    The papers' conditions may differ from ours (``vs_paper.csv`` says where)."""
    from analysis.vs_paper import POINT
    from rodcase.case import ConfigError, load_case
    from workflows.vs_paper import REFERENCES, reference_rows

    if parameter not in POINT:
        return []
    rows = {}
    for case_file in sorted(Path(results, study).glob("*/seed*/case.yaml")):
        try:
            case = load_case(case_file)
        except ConfigError:
            continue  # a run of an older schema: its own table says so
        # the aspect ratio alpha = L/D and the paper's d = 1 + alpha move together
        free = ("alpha", "d") if parameter in ("alpha", "d") else (parameter,)
        refs = reference_rows(case, REFERENCES, free=free)
        panel = refs.observable.map(lambda o: o if o in observables else ON_PANEL.get(o))
        refs = refs[panel.isin(observables)
                    & pd.to_numeric(refs[parameter], errors="coerce").notna()
                    & pd.to_numeric(refs["value"], errors="coerce").notna()]
        rows.update({r.id: r for r in refs.itertuples()})
    return [{"observable": ON_PANEL.get(r.observable, r.observable),
             "label": (f"{r.paper} {r.observable}" if r.observable in ON_PANEL
                       else f"{r.paper} ({r.where.split(';')[0]})"),
             "x": float(getattr(r, parameter)), "y": float(r.value),
             "yerr": float(r.uncertainty) if pd.notna(r.uncertainty) else 0.0}
            for r in rows.values()]


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
    ap.add_argument("--protocol", default=None,
                    help="the study's protocol: deposits report 'settled' for their own runs")
    ap.add_argument("--series", default=None,
                    help="a second varying parameter (column) drawn as one line per value")
    ap.add_argument("--out", required=True, type=Path)
    a = ap.parse_args(argv)
    df = pd.read_csv(a.summary)
    df = df[df.study == a.study]
    if a.protocol != "deposit":  # there 'settled' is the settling test, no other protocol
        df = label_protocols(df)
    # the caging number beside the jammed contact numbers of 3-D packings, not deposits
    alphas = (df["alpha"].dropna().unique() if a.parameter == "alpha" and "alpha" in df
              and a.protocol != "deposit" and (df.observable == "z_j").any() else ())
    shown = OBSERVABLES + DEPOSIT_OBSERVABLES
    plots.trends(df, a.parameter, shown, a.out, title=a.study,
                 references=references(a.parameter, a.dimension, alphas,
                                       df[a.parameter].dropna() if a.parameter in df else ()),
                 series=a.series,
                 papers=paper_points(a.summary.parent, a.study, a.parameter, shown))
    return 0


if __name__ == "__main__":
    sys.exit(main())
