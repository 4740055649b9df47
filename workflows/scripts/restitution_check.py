"""Two-rod collisions with a tapping case's contact law, pysim's exact spherocylinders
beside LAMMPS' glued-sphere rods: ``restitution_check.csv`` and a figure of the normal
restitution in each geometry (workflows/restitution_check.py)."""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import yaml  # noqa: E402

from analysis.plots import ENGINE_COLORS, _save  # noqa: E402
from rodcase.files import atomic_write_text  # noqa: E402
from workflows.restitution_check import LABELS, SPACINGS, check, law_from_case  # noqa: E402

MARKERS = ("s", "^", "v", "D")


def plot(df, law, title: str, path: Path):
    """Restitution versus geometry, one marker per engine and spacing, the analytic
    single-contact value as a line; LAMMPS markers carry their sphere-pair count."""
    geoms = list(dict.fromkeys(df.geometry))
    fig, ax = plt.subplots(figsize=(6.4, 4.0))
    ax.axhline(df.expected_e.iloc[0], color="k", lw=0.8, ls=":",
               label=f"single contact, analytic: e = {df.expected_e.iloc[0]:.3f}")
    spacings = sorted(df.spacing.dropna().unique(), reverse=True)
    series = [("pysim", None)] + [("lammps", s) for s in spacings]
    width = 0.6 / len(series)
    for k, (engine, spacing) in enumerate(series):
        pick = df.spacing.isna() if spacing is None else df.spacing == spacing
        sub = df[(df.engine == engine) & pick].set_index("geometry").reindex(geoms)
        x = np.arange(len(geoms)) + (k - (len(series) - 1) / 2) * width
        if spacing is None:
            marker, label = "o", "pysim (exact spherocylinders)"
        else:
            marker, label = MARKERS[k - 1], f"LAMMPS glued spheres, spacing D/{1 / spacing:g}"
        ax.plot(x, sub.e, ls="none", marker=marker, ms=7, color=ENGINE_COLORS[engine],
                label=label)
        if spacing is not None:
            for xi, e, n in zip(x, sub.e, sub.contacts):
                ax.annotate(f"{n:.0f}", (xi, e), textcoords="offset points", xytext=(0, 7),
                            ha="center", fontsize=7)
    ax.set_xticks(np.arange(len(geoms)), [LABELS[g] for g in geoms], fontsize=8)
    ax.set_ylim(-0.05, max(1.0, float(df.e.max()) + 0.1))
    ax.set_ylabel("normal restitution  e = (v_b - v_a)_after / v_rel")
    ax.set_title(f"{title}: two rods, alpha = {law.alpha:g}, D = {law.diameter:g} m, "
                 f"dt = {law.dt:g} s\n(numbers: sphere pairs in contact at the deepest point)",
                 fontsize=9)
    ax.legend(fontsize=7, loc="upper right")
    _save(fig, path)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--case", type=Path, required=True,
                    help="a validated tapping case (case.yaml of a run)")
    ap.add_argument("--spacings", type=float, nargs="+", default=list(SPACINGS),
                    help="glued-sphere spacings, fractions of D (default: 0.5 0.25)")
    ap.add_argument("--label", default=None, help="names the case in the figure title")
    ap.add_argument("--work", type=Path, required=True)
    ap.add_argument("--table", type=Path, required=True)
    ap.add_argument("--figure", type=Path, required=True)
    a = ap.parse_args(argv)
    try:
        law = law_from_case(yaml.safe_load(a.case.read_text()))
    except (ValueError, KeyError) as exc:
        print(f"error: {a.case}: {exc}", file=sys.stderr)
        return 2
    df = check(law, a.work, spacings=a.spacings)
    atomic_write_text(a.table, df.to_csv(index=False))
    plot(df, law, a.label or str(a.case), a.figure)
    ref = df[df.engine == "pysim"].set_index("geometry").e
    for _, row in df[df.verdict != "agree"].iterrows():
        print(f"DIFFER: {row.geometry}, {row.engine} at spacing {row.spacing:g} D: e = "
              f"{row.e:.3g} through {row.contacts} contacts, pysim {ref[row.geometry]:.3g}",
              file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
