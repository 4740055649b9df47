"""Which engine runs what: the matrix engine x shape x friction x protocol, computed with
:func:`workflows.engines.supports` (the adapter table, :mod:`workflows.engines.table`) on
the cases the project ships (every profile's cases, each also with friction switched on
or off and, where it stays a valid case, with spheres made rods or rods made spheres), so
that the matrix cannot drift from the code. Its engines, protocols and shapes are the
table's. ``make doctor`` prints it; ``docs/operations.md`` carries it."""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

from rodcase.case import ConfigError, case_hash, deep_merge, validate_case
from workflows.engines.table import ADAPTERS, ENGINES, PROTOCOLS, SHAPES, shape, supports

ROOT = Path(__file__).resolve().parents[1]


def shipped_cases() -> list[dict]:
    """Every validated case of the profiles in ``workflows/config/`` and ``examples/``."""
    from workflows.studies import load_config

    out = {}
    for path in sorted([*(ROOT / "workflows" / "config").glob("*.yaml"),
                        *(ROOT / "examples").glob("*_study.yaml")]):
        try:
            cases = load_config(path)["_cases"].values()
        except ConfigError:
            continue  # a profile this installation cannot load (e.g. LAMMPS missing)
        for case in cases:  # the seeds of a case are one case here
            out.setdefault(case_hash({k: v for k, v in case.items() if k != "seed"}), case)
    return list(out.values())


def _variants(case: dict) -> list[dict]:
    """The case, with friction switched, and with the shape switched, where valid."""
    c = case.get("contact", {})  # hard spheres have no contact law
    mu = 0.0 if c.get("friction", 0.0) > 0 else 0.5
    edits = [{"contact": {"friction": mu}},
             {"particles": {"aspect_ratio": 0.0 if case["particles"].get("aspect_ratio", 0.0)
                            else 2.0}}]
    out = [case]
    for edit in edits:
        try:
            out.append(validate_case(deep_merge(case, edit)))
        except (ConfigError, KeyError, TypeError, ValueError):
            continue  # not a case the schema allows (e.g. friction with end bonds)
    return out


def matrix(cases=None) -> dict[tuple[str, str, str, bool], str]:
    """``{(engine, protocol, shape, frictional): cell}``: ``yes`` when the engine runs
    every case of that cell, ``no`` when none, ``some`` otherwise (the cell's cases differ
    in something else its rules look at, such as the contact law); cells without a case
    are absent."""
    seen: dict[tuple, set[bool]] = {}
    for base in shipped_cases() if cases is None else cases:
        for case in _variants(base):
            key = (case["protocol"]["name"], shape(case),
                   case.get("contact", {}).get("friction", 0) > 0)
            for engine in ENGINES:
                seen.setdefault((engine, *key), set()).add(supports(engine, case) is None)
    return {k: ("yes" if v == {True} else "no" if v == {False} else "some")
            for k, v in seen.items()}


def markdown(cells: dict) -> str:
    """The matrix as a Markdown table: a row per engine and protocol that the adapter
    table has, a column per shape (:data:`SHAPES`) and friction (``-`` where no shipped
    case exists)."""
    cols = [(s, f) for s in SHAPES for f in (False, True)]
    head = "| engine | protocol | " + " | ".join(
        f"{s}{', friction' if f else ''}" for s, f in cols) + " |"
    lines = [head, "|" + "---|" * (len(cols) + 2)]
    for engine in ENGINES:
        for protocol in PROTOCOLS:
            if not any((engine, s, protocol) in ADAPTERS for s in SHAPES):
                continue  # an engine's protocol it has no deck for: one line fewer
            row = [cells.get((engine, protocol, s, f), "-") for s, f in cols]
            lines.append(f"| {engine} | {protocol} | " + " | ".join(row) + " |")
    return "\n".join(lines)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.parse_args(argv)
    print(markdown(matrix()))
    return 0


if __name__ == "__main__":
    sys.exit(main())
