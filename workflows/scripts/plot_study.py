"""Figures of one study variant with all engines overlaid: pressure and contact number
versus packing fraction, the distribution of contact numbers P(C) in the frame nearest
to jamming, and phi_J per engine. A bed settled under gravity (LIGGGHTS' rods) is drawn
by the slabs of its profile (p, z and order versus phi along the depth) and P(C) of
its bulk window."""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np
import pandas as pd

from analysis import plots
from analysis.compare import per_engine
from analysis.contacts import ContactNumber
from analysis.io import RunData, read_thermo
from analysis.packing import packing_fraction
from workflows.runner import ok_runs


def contacts_at_jamming(run_dir: Path, phi_j: float, bulk=None, c_min: int | None = None,
                        friction: float = 0.0):
    """``(phi, P(C) with rattlers, P(C) rattler-free)`` of the frame whose packing
    fraction is nearest to ``phi_j`` (``None`` without frames or ``phi_j``). A settled
    bed (``bulk`` = its window ``(lo, hi)``, :func:`analysis.summary.analyse_settled`):
    the last frame, over the particles whose centre lies in the window, rattlers removed
    inside the window as the analysis does, at ``phi_j``. The rattler rule is the
    analysis's (``c_min``, ``friction``: :class:`analysis.contacts.ContactNumber`)."""
    if not np.isfinite(phi_j):
        return None
    frames = RunData(run_dir).frames()
    if not frames:
        return None
    if bulk is not None:
        from analysis.contacts import default_c_min
        from analysis.summary import settled_contact_numbers, settled_pairs

        frame, contacts = frames[-1]
        pairs, fixed = settled_pairs(frame, contacts)
        inside, ratt, counts, counts_free = settled_contact_numbers(
            frame, pairs, fixed, bulk[0], bulk[1],
            default_c_min(frame, friction) if c_min is None else c_min)
        c_all = counts[inside]
        free = counts_free[inside & ~ratt]
        return (float(phi_j), np.bincount(c_all) / max(len(c_all), 1),
                np.bincount(free) / max(len(free), 1))
    phis = np.array([packing_fraction(f) for f, _ in frames])
    k = int(np.argmin(np.abs(phis - phi_j)))
    cn = ContactNumber(c_min, friction=friction).compute(*frames[k])
    return float(phis[k]), cn.distribution, cn.distribution_rattler_free


def pressure_curve(run_dir: Path, curves: pd.DataFrame) -> pd.DataFrame:
    """``phi`` and ``pressure`` to draw as the run's p(phi): the thermo table of a
    compression; for a bed settled under gravity (curves with a ``bulk`` column,
    :func:`analysis.summary.analyse_settled`) its slabs inside the bulk window, p(phi)
    along the gravity gradient (the thermo table of a settling run holds the collapse
    of the inserted column, not a p(phi))."""
    if "bulk" in curves:
        return curves[curves.bulk == 1].sort_values("phi")[["phi", "pressure"]]
    return read_thermo(run_dir / "thermo.dat")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--pressure", required=True, type=Path)
    ap.add_argument("--contacts", required=True, type=Path)
    ap.add_argument("--phi-j", required=True, type=Path)
    ap.add_argument("--p-scale", type=float, default=1.0)
    ap.add_argument("--window", type=float, nargs=2)
    ap.add_argument("--z-iso", type=float, default=6.0)
    ap.add_argument("--friction", type=float, default=0.0,
                    help="the variant's contact.friction (picks the rattler rule)")
    ap.add_argument("--c-min", type=int, default=None,
                    help="the study's analysis.c_min (rattler rule), if set")
    ap.add_argument("run_dirs", nargs="+", type=Path,
                    help="run directories holding thermo.dat, curves.csv, observables.csv")
    a = ap.parse_args(argv)
    runs, obs = [], []
    seeds = {}
    for d in ok_runs(a.run_dirs):
        o = pd.read_csv(d / "observables.csv")
        obs.append(o)
        val = dict(zip(o.observable, o.value))
        engine, seed = o.engine.iloc[0], int(o.seed.iloc[0])
        seeds.setdefault(engine, [])
        seeds[engine].append(seed)
        curves = pd.read_csv(d / "curves.csv")
        bulk = (val["bulk_lo"], val["bulk_hi"]) if "bulk_lo" in val else None  # settled bed
        runs.append({"engine": engine, "seed": seed, "thermo": pressure_curve(d, curves),
                     "curves": curves[curves.bulk == 1] if bulk else curves,
                     "points": bulk is not None,
                     "phi_j": val.get("phi_j", float("nan")),
                     "slope": val.get("jamming_slope", float("nan")),
                     "p_c": contacts_at_jamming(d, val.get("phi_j", float("nan")), bulk,
                                                a.c_min, a.friction)})
    for r in runs:
        r["seed_index"] = sorted(seeds[r["engine"]]).index(r["seed"])
    if not runs:
        msg = "no successful run to draw: see failures.csv"
        print(msg, file=sys.stderr)
        for path in (a.pressure, a.contacts, a.phi_j):
            plots.message_figure(path, msg)
        return 0
    phis = [r["phi_j"] for r in runs if pd.notna(r["phi_j"])]
    phi_min = min(phis) - 0.06 if phis else None
    plots.pressure_vs_phi(runs, a.pressure, p_scale=a.p_scale, window=a.window, phi_min=phi_min)
    plots.contacts_vs_phi(runs, a.contacts, z_iso=a.z_iso, phi_min=phi_min)
    stats = per_engine(pd.concat(obs, ignore_index=True))
    plots.observable_by_engine(stats, "phi_j", a.phi_j, ylabel=r"$\phi_J$ (mean $\pm$ sd over seeds)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
