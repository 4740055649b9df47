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
from pysim.io import atomic_write_text  # noqa: E402
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
    geoms = list(dict.fromkeys(df.geometry))
    fig, ax = plt.subplots(figsize=(7.5, 3.6))
    colors = {"lammps-body": ENGINE_COLORS["lammps"], "pysim": ENGINE_COLORS["pysim"]}
    for k, (engine, g) in enumerate(df.groupby("engine", sort=False)):
        g = g.set_index("geometry").reindex(geoms)
        x = np.arange(len(geoms)) + (k - 0.5) * 0.35
        ratio = g.ke_ratio.to_numpy(dtype=float)
        ax.bar(x, np.where(np.isfinite(ratio), ratio, 0.0), width=0.35, label=engine,
               color=colors.get(engine, "grey"))
        for xi, (r, row) in zip(x, g.iterrows()):
            note = "NaN" if not row.finite else ("passed\nthrough" if row.passed_through else "")
            if note:
                ax.text(xi, 0.05, note, ha="center", va="bottom", fontsize=7, rotation=90)
    ax.axhline(1.0, color="k", lw=0.8, ls=":")
    ax.set_xticks(np.arange(len(geoms)), geoms, fontsize=8)
    ax.set_ylabel("kinetic energy after / before")
    ax.set_title(f"elastic two-rod collisions, alpha = {a.alpha:g} (must be 1, and bounce)",
                 fontsize=9)
    ax.legend(fontsize=8)
    _save(fig, a.figure)
    bad = df[(df.engine == "lammps-body") & (df.verdict != "ok")]
    print(f"LAMMPS body rods wrong in {len(bad)} of {len(geoms)} geometries: "
          f"{', '.join(bad.geometry)}", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
