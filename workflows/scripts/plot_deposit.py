"""Figure of a deposition study: profiles of packing fraction and stresses versus depth
with the Janssen fits, and the orientation distributions, for every successful run."""
from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np
import pandas as pd

from analysis import plots
from analysis.io import read_particle_frames
from analysis.order import angle_to_horizontal


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--out", required=True, type=Path, help="figure (PNG)")
    ap.add_argument("run_dirs", nargs="+", type=Path)
    a = ap.parse_args(argv)
    variants = sorted({d.parent.parent.name for d in a.run_dirs})
    runs = []
    for d in a.run_dirs:
        if json.loads((d / "run.json").read_text()).get("status") != "ok":
            continue
        last = read_particle_frames(d / "particles.dump")[-1]
        variant, seed, engine = d.parent.parent.name, d.parent.name, d.name
        runs.append({"label": f"{variant} {engine} {seed}", "engine": engine,
                     "index": variants.index(variant),
                     "profile": pd.read_csv(d / "curves.csv"),
                     "angles": np.degrees(angle_to_horizontal(last))})
    if not runs:
        plots.message_figure(a.out, "no successful deposition run to draw: see failures.csv")
        return 0
    plots.deposit_profiles(runs, a.out)
    return 0


if __name__ == "__main__":
    sys.exit(main())
