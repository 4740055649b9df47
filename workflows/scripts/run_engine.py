"""Run LAMMPS or LIGGGHTS on a case and leave the common-format files and run.json."""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

from workflows import engines, provenance
from workflows.case import ConfigError, load_case


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--engine", required=True, choices=["lammps", "liggghts"])
    ap.add_argument("--case", required=True, type=Path)
    ap.add_argument("--data", required=True, type=Path)
    ap.add_argument("--out", required=True, type=Path)
    ap.add_argument("--ranks", type=int, default=1)
    ap.add_argument("--timeout", type=float, default=3600.0)
    a = ap.parse_args(argv)
    try:
        case = load_case(a.case)
        summary = engines.run(a.engine, case, a.data, a.out, ranks=a.ranks, timeout=a.timeout)
    except (ConfigError, engines.EngineError) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2 if isinstance(exc, ConfigError) else 1
    version = summary.pop("engine_version")
    provenance.write(a.out / "run.json", provenance.record(a.engine, version, case, **summary))
    print(f"{a.engine}: {summary['steps']} steps in {summary['wall_seconds']:.1f} s "
          f"({summary['particle_steps_per_second'] / 1e6:.2f} M particle-steps/s)", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
