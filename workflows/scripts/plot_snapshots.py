"""Snapshots of the final packing of one case: the last frame of each engine's first
seed, side by side (analysis.plots.packing_snapshots)."""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

from analysis import plots
from analysis.io import read_particle_frames
from workflows.runner import ok_runs


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--out", required=True, type=Path)
    ap.add_argument("run_dirs", nargs="+", type=Path, help="<case>/seed<k>/<engine> folders")
    a = ap.parse_args(argv)
    frames, engines = [], set()
    for d in sorted(ok_runs(a.run_dirs), key=lambda d: (d.parent.name, d.name)):
        if d.name in engines:
            continue  # one seed per engine: the first
        engines.add(d.name)
        frame = read_particle_frames(d / "particles.dump", last_only=True)[0]
        frames.append((f"{d.name}, {d.parent.name}, step {frame.step}", frame))
    if not frames:
        plots.message_figure(a.out, "no finished run to draw")
        return 0
    plots.packing_snapshots(frames, a.out)
    return 0


if __name__ == "__main__":
    sys.exit(main())
