"""Contact-angle distributions P(varphi) of a 2-D (or 3-D) rod study, one panel per
variant, engines overlaid: from the mechanically stable frame (protocol ``jammed``) or
the first frame at or above the fitted jamming point (compression)."""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np
import pandas as pd

from analysis.contacts import contact_angles
from analysis.io import RunData
from analysis.plots import contact_angle_distributions
from rodcase.case import load_case
from workflows.runner import ok_runs


def jamming_frame(run_dir: Path, protocol: str):
    """``(frame, contacts)`` at jamming: the last frame of a ``jammed`` run, else the first
    frame whose packing fraction reaches the run's ``phi_at_z_j`` (the last if unknown)."""
    frames = RunData(run_dir).frames()
    if protocol == "jammed" or not frames:
        return frames[-1] if frames else None
    obs = pd.read_csv(run_dir / "observables.csv")
    hit = obs[obs.observable == "phi_at_z_j"].value
    target = float(hit.iloc[0]) if len(hit) else float("nan")
    if np.isfinite(target):
        from analysis.packing import packing_fraction

        for frame, contacts in frames:
            if packing_fraction(frame) >= target - 1e-9:
                return frame, contacts
    return frames[-1]


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--runs", nargs="+", type=Path, required=True,
                    help="run directories <study>/<variant>/seed<k>/<engine>")
    ap.add_argument("--out", type=Path, required=True)
    a = ap.parse_args(argv)
    groups = {}
    for run in ok_runs(a.runs):
        case = load_case(run.parent / "case.yaml")
        alpha = case["particles"].get("aspect_ratio", 0.0)
        if alpha <= 0:
            continue  # disks and spheres have no spine to measure the angle from
        picked = jamming_frame(run, case["protocol"]["name"])
        if picked is None:
            continue
        frame, contacts = picked
        variant = run.parent.parent.name
        title = f"{variant} (alpha = {alpha:g})"
        junction = float(np.arctan(1.0 / alpha)) if alpha > 0 else None
        entry = groups.setdefault((alpha, variant), (title, junction, {}))
        entry[2].setdefault(run.name, []).append(contact_angles(frame, contacts))
    ordered = [(t, j, {e: np.concatenate(v) for e, v in by.items()})
               for _k, (t, j, by) in sorted(groups.items())]
    contact_angle_distributions(ordered, a.out)
    return 0


if __name__ == "__main__":
    sys.exit(main())
