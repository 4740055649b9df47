"""Run one engine on a case; the outcome (ok or failed) goes to OUT/run.json.

A run stopped by SIGINT, SIGTERM or SIGHUP writes no run.json and exits with 128 plus the
signal number; the next run resumes it from its checkpoint."""
from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

from workflows import runner
from rodcase.case import ConfigError
from workflows.stopping import Interrupted


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--engine", required=True, choices=["pysim", "lammps", "lammps-body", "liggghts"])
    ap.add_argument("--case", required=True, type=Path)
    ap.add_argument("--data", required=True, type=Path)
    ap.add_argument("--out", required=True, type=Path)
    ap.add_argument("--ranks", type=int, default=1, help="MPI ranks (LAMMPS, LIGGGHTS)")
    ap.add_argument("--threads", type=int, default=1, help="Numba threads (pysim)")
    ap.add_argument("--timeout", type=float, default=3600.0)
    a = ap.parse_args(argv)
    try:
        rec = runner.run(a.engine, a.case, a.data, a.out, ranks=a.ranks, threads=a.threads,
                         timeout=a.timeout)
    except ConfigError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    except Interrupted as exc:
        print(f"stopped: {exc}; no result is recorded, the next run resumes {a.out} from its "
              f"last checkpoint", file=sys.stderr)
        return 128 + exc.signum
    if rec["status"] != "ok":
        print(f"FAILED: {rec['error']}", file=sys.stderr)
    else:
        rate = rec.get("particle_steps_per_second")  # growth and relaxation runs have none
        speed = f" ({rate / 1e6:.2f} M particle-steps/s)" if rate and math.isfinite(rate) else ""
        print(f"{a.engine}: {rec.get('steps')} steps in {rec.get('wall_seconds', 0):.1f} s"
              f"{speed}", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
