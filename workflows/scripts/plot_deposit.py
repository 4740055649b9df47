"""Figure of a deposition study: profiles of packing fraction and stresses versus depth
with the Janssen fits, the orientation distributions, the radial orientation correlation
``Q(r)`` and the directions of the major principal stress in elements of five particle
lengths and of each grain's own stress (the paper's polar plot), for every successful
run (final frames)."""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np
import pandas as pd

from analysis import plots
from analysis.io import RunData
from analysis.order import OrientationCorrelation, angle_to_horizontal
from analysis.stress import StressField, particle_major_angles
from analysis.summary import ORDER_RANGE, STRESS_ELEMENT
from workflows.runner import ok_runs


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--out", required=True, type=Path, help="figure (PNG)")
    ap.add_argument("run_dirs", nargs="+", type=Path)
    a = ap.parse_args(argv)
    variants = sorted({d.parent.parent.name for d in a.run_dirs})
    runs = []
    for d in ok_runs(a.run_dirs):
        last, contacts = RunData(d).frames()[-1]
        variant, seed, engine = d.parent.parent.name, d.parent.name, d.name
        length = float(np.mean(last.length + 2.0 * last.radius))  # particle length L + D
        q = OrientationCorrelation(ORDER_RANGE * length, bins=24).compute(last)
        field = StressField(STRESS_ELEMENT * length, angle_bins=9).compute(last, contacts)
        runs.append({"label": f"{variant} {engine} {seed}", "engine": engine,
                     "index": variants.index(variant), "dim": last.dim,
                     "profile": pd.read_csv(d / "curves.csv"),
                     "angles": np.degrees(angle_to_horizontal(last)),
                     "q_r": (q.centers / length, q.q),
                     "major": (np.degrees(field.angle_edges), field.angle_hist,
                               int(np.isfinite(field.major_angle).sum())),
                     "major_particles": np.degrees(particle_major_angles(last, contacts))})
    if not runs:
        plots.message_figure(a.out, "no successful deposition run to draw: see failures.csv")
        return 0
    plots.deposit_profiles(runs, a.out)
    return 0


if __name__ == "__main__":
    sys.exit(main())
