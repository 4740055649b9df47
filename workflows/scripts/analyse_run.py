"""Analyse one run directory: ``observables.csv`` (tidy) and ``curves.csv``.

What a reader of the numbers must know (:func:`analysis.summary.problems`: NaN
observables, frames whose rattler removal empties the packing) goes to stderr as
``warning:`` lines, which the pipeline keeps in the run's ``analysis.log`` and repeats on
its own stderr when it ends (``workflows/rules/analysis.smk``)."""
from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from analysis.summary import (TIDY_COLUMNS, analyse_compression, analyse_deposit,
                              analyse_growth, analyse_hard, analyse_jammed, analyse_settled,
                              analyse_tapping, problems, tidy)
from rodcase.case import HARD_SPHERE_PROTOCOLS
from rodcase.files import atomic_write_text
from workflows.scripts import case_or_none
from workflows.engines import settles

#: provenance columns copied from run.json into every result row
PROVENANCE = ("engine_version", "case_hash", "git_revision")


def tap_plan(case: dict) -> dict:
    """Keyword arguments of :func:`analysis.summary.tap_curves` for a tapping case: the
    step plan of the protocol and layers of half the container diameter (the 4 mm layers
    of the 8 mm cylinder of science.md). A free preparation's tapping starts where its
    run settled: ``start_step`` ``None``, the step of the first frame."""
    from pysim.protocols.tapping import is_free, plan

    free = is_free(case["protocol"])
    tp = plan(case["protocol"], case["gravity"], settled=0 if free else None)
    dc = case["container"]["diameter"]
    return {"start_step": None if free else tp.start, "dt": tp.dt, "period": tp.period,
            "amplitude": tp.amplitude, "frames_per_tap": tp.frames_per_tap,
            "container_diameter": dc, "layer_thickness": dc / 2, "n_layers": 4}


def deposit_geometry(case: dict) -> dict:
    """Keyword arguments of :func:`analysis.summary.analyse_deposit` for a deposition case:
    slabs one grain length thick, the base's wall id in pysim's contact table (walls are
    numbered x = 0, x = W, [y = 0, y = W,] base: :mod:`pysim.protocols.deposit`)."""
    p = case["particles"]
    d = p["diameter"]["mean"]
    dim = p.get("dimension", 3)
    return {"width": case["container"]["width"], "gravity": case["gravity"],
            "slab": d * (1.0 + p.get("aspect_ratio", 0.0)), "density": p.get("density", 1.0),
            "base_wall_id": -(2 * (dim - 1) + 1)}


def analyse(case: dict, a, record: dict):
    """``(rows, curves)`` of the run ``a.run`` by its protocol's analysis."""
    if case["protocol"]["name"] in HARD_SPHERE_PROTOCOLS:  # no contact law
        return analyse_hard(a.run, c_min=a.c_min)
    p_scale = case["contact"]["k_n"] / case["particles"]["diameter"]["mean"]
    rule = {"c_min": a.c_min, "friction": case["contact"]["friction"]}
    if case["protocol"]["name"] == "growth":
        rows, curves, _thermo = analyse_growth(a.run, **rule)
    elif case["protocol"]["name"] == "jammed":
        rows, curves, _thermo = analyse_jammed(a.run, **rule)
    elif case["protocol"]["name"] == "tapping":
        rows, curves, _thermo = analyse_tapping(a.run, **tap_plan(case))
    elif settles(a.engine, case):  # LIGGGHTS rods: a settled bed, not a compression
        rows, curves, _thermo = analyse_settled(a.run, case["protocol"]["settle"]["bulk"],
                                                **rule)
        settled = record.get("settled")
        rows.append(("settled", float(settled) if settled is not None else float("nan"),
                     float("nan")))
    elif case["protocol"]["name"] == "deposit":
        rows, curves = analyse_deposit(a.run, **deposit_geometry(case))
        settled = record.get("settled")
        rows.append(("settled", float(settled) if settled is not None else float("nan"),
                     float("nan")))
    else:
        pr = case["protocol"]
        # fit the slow stage only: the fast stage may overshoot into transient jamming
        fit_from = pr["phi_fast"] if pr.get("phi_fast", pr["phi_init"]) > pr["phi_init"] else None
        rows, curves, _thermo = analyse_compression(a.run, a.window, p_scale, fit_from=fit_from,
                                                    **rule)
    return rows, curves


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--case", required=True, type=Path)
    ap.add_argument("--run", required=True, type=Path)
    ap.add_argument("--study", required=True)
    ap.add_argument("--variant", required=True)
    ap.add_argument("--seed", type=int, required=True)
    ap.add_argument("--engine", required=True)
    ap.add_argument("--window", type=float, nargs=2, default=[1e-3, 1e-2],
                    help="jamming-fit pressure window in units of k_n / D")
    ap.add_argument("--c-min", type=int, default=None, metavar="N",
                    help="rattler rule: fewer than N contacts (the study's analysis.c_min; "
                         "default: the rule for the grains and their friction)")
    ap.add_argument("--parameters", default="{}", help="varying case parameters (JSON)")
    ap.add_argument("--observables", required=True, type=Path)
    ap.add_argument("--curves", required=True, type=Path)
    a = ap.parse_args(argv)
    case = case_or_none(a.case)
    if case is None:
        return 2
    record = json.loads((a.run / "run.json").read_text())
    if record.get("status") != "ok":
        # a failed run has no observables; summarize lists it in failures.csv
        cols = TIDY_COLUMNS + list(json.loads(a.parameters)) + list(PROVENANCE)
        atomic_write_text(a.observables, ",".join(cols) + "\n")
        atomic_write_text(a.curves, "step,phi\n")
        return 0
    rows, curves = analyse(case, a, record)
    df = tidy(rows, a.study, a.variant, a.engine, a.seed, json.loads(a.parameters))
    for key in PROVENANCE:
        df[key] = record.get(key, "unknown")
    atomic_write_text(a.observables, df.to_csv(index=False))
    atomic_write_text(a.curves, curves.to_csv(index=False))
    if "error" in curves.attrs.get("fit", {}):
        print(f"warning: {a.run}: {curves.attrs['fit']['error']}", file=sys.stderr)
    for line in problems(rows, curves):
        print(f"warning: {a.run}: {line}", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
