"""Write a merged case file and its shared initial configuration: ``case.yaml`` and
``init.data`` (LAMMPS data file every engine starts from)."""
from __future__ import annotations

import argparse
import json
import sys

import yaml

from pysim.initial import write_initial
from rodcase.files import atomic_write_text
from rodcase.case import ConfigError, validate_case


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--case-json", required=True, help="the case as JSON")
    ap.add_argument("--case-out", required=True)
    ap.add_argument("--data-out", required=True)
    a = ap.parse_args(argv)
    try:
        case = validate_case(json.loads(a.case_json), "case")
    except ConfigError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    atomic_write_text(a.case_out, yaml.safe_dump(case, sort_keys=False))
    write_initial(case, a.data_out)
    return 0


if __name__ == "__main__":
    sys.exit(main())
