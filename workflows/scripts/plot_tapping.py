"""Figures of a tapping study: density and mean angle versus tap number for every run
(``--curves-out``; the seeds of a variant on one engine as their mean and band), the
settled and late density and angle of every parameter set with seed means and standard
errors (``--sets-out``, its table ``--sets-table``), and snapshots of one variant's runs
(``--snapshots-out``)."""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np
import pandas as pd

from analysis import plots, theory
from analysis.io import read_particle_frames
from rodcase.files import atomic_write_text
from rodcase.case import GT_PER_GN, KT_PER_KN, ConfigError, load_case
from workflows.runner import ok_runs
from workflows.vs_paper import REFERENCES, reference_rows


def curves_figure(run_dirs, out: Path) -> int:
    runs, limits = [], {}
    variants = sorted({d.parent.parent.name for d in run_dirs})
    for d in ok_runs(run_dirs):
        case = load_case(d.parent / "case.yaml")
        alpha = case["particles"]["aspect_ratio"]
        limits[rf"$\phi_{{max}}(\alpha={alpha:g})$"] = float(theory.phi_max_aligned(alpha))
        variant, seed, engine = d.parent.parent.name, d.parent.name, d.name
        runs.append({"label": f"{variant} {engine} {seed}", "engine": engine,
                     "index": variants.index(variant), "curves": pd.read_csv(d / "curves.csv"),
                     "group": (variant, engine), "group_label": f"{variant} {engine}"})
    if not runs:
        plots.message_figure(out, "no successful tapping run to draw: see failures.csv")
        return 0
    thickness = load_case(next(iter(ok_runs(run_dirs))).parent / "case.yaml")["container"]
    plots.tapping_curves(runs, out, phi_max=limits,
                         layer_label=f"({thickness['diameter'] / 2 * 1e3:g} mm thick)"
                         if thickness["diameter"] < 0.1 else "",
                         paper=paper_overlay(run_dirs, variants))
    return 0


def paper_overlay(run_dirs, variants) -> list[dict]:
    """The tapping paper's densities and angles at each variant's parameters
    (``references/``), for :func:`analysis.plots.tapping_curves`."""
    out = []
    seen = set()
    for d in ok_runs(run_dirs):
        variant = d.parent.parent.name
        if variant in seen:
            continue
        seen.add(variant)
        rows = reference_rows(load_case(d.parent / "case.yaml"), REFERENCES)
        for r in rows.itertuples():
            quantity = {"phi_late": "phi", "angle_late": "angle"}.get(r.observable)
            if quantity is None:
                continue
            layer = 0 if pd.isna(r.layer) else int(r.layer)
            out.append({"index": variants.index(variant), "quantity": quantity,
                        "layer": layer, "tap": float(r.tap), "value": float(r.value),
                        "uncertainty": float(r.uncertainty)})
    return out


#: what the sets figure and table show: settled and late (last eighth of the taps) state
SET_OBSERVABLES = ["phi_settled", "phi_late", "angle_settled", "angle_late", "p2_z_late",
                   "angle_late_layer1", "angle_late_layer2", "angle_late_layer3",
                   "angle_late_layer4", "ke_cycle", "contacts_flight",
                   "phi_settled_enclosing", "phi_late_enclosing"]


def set_label(case: dict) -> str:
    """Tick label of a parameter set: its restitution, intensity, aspect ratio and N, and a
    third line for what else sets it apart: a tangential law other than the one the
    schema derives from the normal law (``k_t = 2/7 k_n``, ``gamma_t = gamma_n / 2``),
    given as ratios to those, ``f_n >= 0`` for ``contact.limit_damping``, ``spring
    kept`` for ``contact.tangential_spring: keep``, ``free settling`` for
    ``protocol.preparation.mode: free`` and the scheme for an Euler
    ``protocol.integrator``."""
    c = case["contact"]
    label = (f"e_n {c.get('restitution', float('nan')):g}, "
             f"Gamma {case['protocol']['intensity']:g}\n"
             f"alpha {case['particles']['aspect_ratio']:g}, N {case['particles']['n']}")
    extra = []
    k_n, gamma_n = c.get("k_n", 0.0), c.get("gamma_n", 0.0)
    if c.get("friction", 0.0) > 0 and k_n > 0 and gamma_n > 0:
        xk = c.get("k_t", 0.0) / (KT_PER_KN * k_n)
        xg = c.get("gamma_t", 0.0) / (GT_PER_GN * gamma_n)
        if abs(xk - 1.0) > 1e-6 or abs(xg - 1.0) > 1e-6:
            extra.append(f"k_t x{xk:.2g}, \u03b3_t x{xg:.2g}")
    if c.get("limit_damping", False):
        extra.append("f_n >= 0")
    if c.get("tangential_spring", "reset") == "keep":
        extra.append("spring kept")
    if case["protocol"].get("preparation", {}).get("mode") == "free":
        extra.append("free settling")
    scheme = case["protocol"].get("integrator", "verlet")
    if scheme != "verlet":
        extra.append(scheme.replace("_", " "))
    return label + ("\n" + ", ".join(extra) if extra else "")


def sets_table(run_dirs) -> tuple[pd.DataFrame, pd.DataFrame, dict]:
    """Per-seed values (``variant, engine, seed, observable, value``) of
    :data:`SET_OBSERVABLES` from the successful runs' ``observables.csv``, their per-set
    statistics (``variant, engine, observable, seeds, mean, std, sem``: standard
    deviation over seeds and standard error of the mean, NaN for one seed), and the
    variants' tick labels."""
    frames, labels = [], {}
    for d in ok_runs(run_dirs):
        variant = d.parent.parent.name
        labels.setdefault(variant, f"{variant}\n" + set_label(load_case(d.parent / "case.yaml")))
        obs = pd.read_csv(d / "observables.csv")
        obs = obs[obs.observable.isin(SET_OBSERVABLES)]
        frames.append(pd.DataFrame({"variant": variant, "engine": d.name, "seed": d.parent.name,
                                    "observable": obs.observable, "value": obs.value}))
    cols = ["variant", "engine", "seed", "observable", "value"]
    values = pd.concat(frames, ignore_index=True) if frames else pd.DataFrame(columns=cols)
    g = values.groupby(["variant", "engine", "observable"], sort=False)["value"]
    stats = g.agg(seeds="count", mean="mean", std="std").reset_index()
    stats["sem"] = stats["std"] / np.sqrt(stats["seeds"])
    return values, stats, labels


def sets_figure(run_dirs, out: Path | None, table_out: Path | None) -> int:
    values, stats, labels = sets_table(run_dirs)
    if table_out:
        table_out.parent.mkdir(parents=True, exist_ok=True)
        atomic_write_text(table_out, stats.to_csv(index=False, float_format="%.6g"))
    if out:
        if values.empty:
            plots.message_figure(out, "no successful tapping run to draw: see failures.csv")
        else:
            plots.tapping_sets(values, out, labels)
    return 0


def snapshots_figure(run_dirs, out: Path, taps: list[float]) -> int:
    frames, dc = [], None
    for d in ok_runs(run_dirs):
        case = load_case(d.parent / "case.yaml")
        dc = case["container"]["diameter"]
        cv = pd.read_csv(d / "curves.csv")
        parts = {f.step: f for f in read_particle_frames(d / "particles.dump")}
        at = cv[cv.phase == 0] if (cv.phase == 0).any() else cv
        shown = set()
        for tap in taps:
            row = at.iloc[int(np.argmin(np.abs(at.tap.to_numpy() - min(tap, at.tap.max()))))]
            if int(row.step) in shown:  # a tap past a short run's end: its last frame once
                continue
            shown.add(int(row.step))
            frames.append((f"{d.name}, {d.parent.name}, tap {row.tap:.0f}",
                           parts[int(row.step)]))
    if not frames:
        plots.message_figure(out, "no successful tapping run to draw: see failures.csv")
        return 0
    plots.tapping_snapshots(frames, out, dc)
    return 0


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--curves-out", type=Path, help="density and angle versus taps (PNG)")
    ap.add_argument("--snapshots-out", type=Path, help="snapshots of the runs (PNG)")
    ap.add_argument("--sets-out", type=Path,
                    help="settled and late state per parameter set and engine (PNG)")
    ap.add_argument("--sets-table", type=Path, help="the statistics of --sets-out (CSV)")
    ap.add_argument("--taps", type=float, nargs="+", default=[0.0, -1.0],
                    help="taps to render (-1: the last one)")
    ap.add_argument("run_dirs", nargs="+", type=Path)
    a = ap.parse_args(argv)
    try:
        if a.curves_out:
            curves_figure(a.run_dirs, a.curves_out)
        if a.sets_out or a.sets_table:
            sets_figure(a.run_dirs, a.sets_out, a.sets_table)
        if a.snapshots_out:
            taps = [t if t >= 0 else np.inf for t in a.taps]
            snapshots_figure(a.run_dirs, a.snapshots_out, taps)
    except ConfigError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(main())
