"""Two-rod collisions with LAMMPS' true spherocylinder bodies beside pysim's exact rods:
``body_check.csv`` and a figure of the kinetic energy after/before each collision."""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from analysis.plots import ENGINE_COLORS, _save  # noqa: E402
from rodcase.files import atomic_write_text  # noqa: E402
from workflows.body_check import check  # noqa: E402


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--alpha", type=float, default=2.0)
    ap.add_argument("--work", type=Path, required=True)
    ap.add_argument("--table", type=Path, required=True)
    ap.add_argument("--figure", type=Path, required=True)
    a = ap.parse_args(argv)
    df = check(a.alpha, a.work)
    atomic_write_text(a.table, df.to_csv(index=False))
    colors = {"lammps-body": ENGINE_COLORS["lammps-body"], "pysim": ENGINE_COLORS["pysim"],
              "lammps-body-bare-skin": "tab:gray"}
    dims = sorted(df.dimension.unique(), reverse=True)
    fig, axes = plt.subplots(1, len(dims), figsize=(5.0 * len(dims), 3.8), squeeze=False)
    for ax, dim in zip(axes[0], dims):
        sub = df[df.dimension == dim]
        geoms = list(dict.fromkeys(sub.geometry))
        groups = list(sub.groupby("engine", sort=False))
        width = 0.8 / len(groups)
        for k, (engine, g) in enumerate(groups):
            g = g.set_index("geometry").reindex(geoms)
            x = np.arange(len(geoms)) + (k - (len(groups) - 1) / 2) * width
            ratio = g.ke_ratio.to_numpy(dtype=float)
            ax.bar(x, np.where(np.isfinite(ratio), ratio, 0.0), width=width, label=engine,
                   color=colors.get(engine, "grey"))
            for xi, (_r, row) in zip(x, g.iterrows()):
                note = "NaN" if not row.finite else ("passed\nthrough" if row.passed_through
                                                     else "")
                if note:
                    ax.text(xi, 0.05, note, ha="center", va="bottom", fontsize=7, rotation=90)
        ax.axhline(1.0, color="k", lw=0.8, ls=":")
        ax.set_xticks(np.arange(len(geoms)), geoms, fontsize=8, rotation=20)
        ax.set_ylabel("kinetic energy after / before")
        style = "rounded/polyhedron" if dim == 3 else "rounded/polygon"
        ax.set_title(f"{dim}-D, body {style}: elastic collisions, alpha = {a.alpha:g}\n"
                     "(must be 1, and bounce)", fontsize=9)
        ax.legend(fontsize=7)
    _save(fig, a.figure)
    for dim in dims:
        sub = df[df.dimension == dim]
        for engine in [e for e in dict.fromkeys(sub.engine) if e.startswith("lammps")]:
            bad = sub[(sub.engine == engine) & (sub.verdict != "ok")]
            print(f"{dim}-D {engine}: wrong in {len(bad)} of {len(sub[sub.engine == engine])} "
                  f"geometries{': ' if len(bad) else ''}{', '.join(bad.geometry)}",
                  file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
