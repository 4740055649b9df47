"""The growth runs of one aspect ratio side by side, one per growth rate (Wouterse, Luding
& Philipse, Figs. 2, 3 and 6): a figure of ``<C>(phi)``, the non-caged fraction and the
``P(C)`` of the slowest run, and a table of the packing fractions above which the rates
agree (:func:`analysis.growth.phi_rate_independent`).

  python -m workflows.scripts.growth_rates --figure F.png --table T.csv RUN_DIR...

Each ``RUN_DIR`` is ``<results>/<study>/<case>/seed<k>/<engine>`` of a finished growth
run (``curves.csv``, ``observables.csv`` and the dumps); the case is read from the
``case.yaml`` beside it. The table has one row per observable, filed under the slowest
run (``case``, ``seed``: what ``vs_paper`` matches to the paper): ``observable``, ``value``
(NaN with fewer than two rates, or where the curves never agree), ``runs``, ``rates``
(the paper's unit: relative growth per time step). Failed runs are left out."""
from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pandas as pd

from analysis.growth import growing_frames, phi_rate_independent
from analysis.io import RunData
from analysis.plots import growth_curves
from analysis.summary import pc_table
from rodcase.case import read_yaml
from rodcase.files import atomic_write_text
from workflows.scripts import study_figure_args

#: table rows: our observable, the curve column it reads
RATE_OBSERVABLES = (("phi_c_rate_independent", "z"),
                    ("phi_noncaged_rate_independent", "noncaged_fraction"))
#: P(C) bars of the slowest run at these fractions of its way from start to phi_J
PC_FRACTIONS = (0.0, 0.5, 0.9, 1.0)


def rate_per_step(case: dict) -> float:
    """The growth rate in the paper's unit, relative growth of the length per time step
    (``protocol.rate * protocol.dt``)."""
    return float(case["protocol"]["rate"]) * float(case["protocol"]["dt"])


def load(run_dir: Path) -> dict:
    """One run: its rate, growing frames and the jump and jamming observables."""
    case = read_yaml(run_dir.parent / "case.yaml")
    obs = pd.read_csv(run_dir / "observables.csv").set_index("observable")["value"]
    curves = pd.read_csv(run_dir / "curves.csv")
    if "contraction" in case["protocol"]:  # the random start before it is no growth frame
        curves = curves[curves.phi >= case["protocol"]["contraction"]["phi"] - 1e-9]
    rate = rate_per_step(case)
    return {"dir": run_dir, "rate": rate, "label": f"rate {rate:.0e} per step",
            "curves": growing_frames(curves), "phi_j": obs.get("phi_j", np.nan),
            "phi_before_jump": obs.get("phi_before_jump", np.nan),
            "c_mean_before_jump": obs.get("c_mean_before_jump", np.nan),
            "alpha": float(case["particles"].get("aspect_ratio", 0.0))}


def main(argv=None) -> int:
    a = study_figure_args(__doc__, argv)
    if not a.done:  # the failures are listed in failures.csv
        print(f"error: none of the {len(a.runs)} runs finished", file=sys.stderr)
        return 2
    runs = sorted((load(d) for d in a.done), key=lambda r: -r["rate"])
    alphas = {r["alpha"] for r in runs}
    if len(alphas) > 1:
        print(f"error: runs of several aspect ratios {sorted(alphas)}; give one", file=sys.stderr)
        return 2
    slowest = runs[-1]
    pc = None
    if np.isfinite(slowest["phi_j"]) and len(slowest["curves"]):
        lo = float(slowest["curves"].phi.min())
        pc = pc_table(RunData(slowest["dir"]),
                      [lo + f * (slowest["phi_j"] - lo) for f in PC_FRACTIONS])
    growth_curves(runs, a.figure, pc=pc,
                  title=f"alpha = {slowest['alpha']:g} (P(C): {slowest['label']})")
    rows = []
    for name, column in RATE_OBSERVABLES:
        value = np.nan
        if len(runs) > 1:
            value = phi_rate_independent([r["curves"] for r in runs], column)
        rows.append({"case": slowest["dir"].parent.parent.name,
                     "seed": int(slowest["dir"].parent.name.removeprefix("seed")),
                     "observable": name, "value": value, "alpha": slowest["alpha"],
                     "runs": len(runs), "rates": ";".join(f"{r['rate']:.0e}" for r in runs)})
    atomic_write_text(a.table, pd.DataFrame(rows).to_csv(index=False))
    return 0


if __name__ == "__main__":
    sys.exit(main())
