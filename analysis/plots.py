"""Figures with every engine overlaid (matplotlib, written atomically as PNG)."""
from __future__ import annotations

import os
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

ENGINE_COLORS = {"pysim": "tab:blue", "lammps": "tab:orange", "liggghts": "tab:green",
                 "lammps-body": "tab:red"}
SEED_STYLES = ["-", "--", ":", "-."]
#: line style per engine where colour tells the runs apart (any other engine: dotted)
ENGINE_LINES = {"pysim": "-", "lammps": "--"}


def _save(fig, path):
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(path.stem + ".part" + path.suffix)
    fig.savefig(tmp, dpi=130, bbox_inches="tight")
    plt.close(fig)
    os.replace(tmp, path)


def _style(engine, seed_index):
    return dict(color=ENGINE_COLORS.get(engine, "k"), ls=SEED_STYLES[seed_index % len(SEED_STYLES)])


def _run_style(r):
    """Line style of a run dict; ``points=True`` (the slabs of a settled bed, not a
    sequence in time): markers without a line."""
    st = _style(r["engine"], r["seed_index"])
    return {**st, "ls": "none"} if r.get("points") else st


def pressure_vs_phi(runs, out, p_scale=1.0, window=None, phi_min=None):
    """Contact pressure (units of ``p_scale``) versus packing fraction, one line per run,
    with each run's jamming fit drawn.

    ``runs``: list of dicts with ``engine``, ``seed_index``, ``thermo`` (DataFrame with
    ``phi``, ``pressure``), and optionally ``phi_j``, ``slope``, ``points`` (draw markers,
    no line: the slabs of a settled bed).
    """
    fig, (ax, axl) = plt.subplots(1, 2, figsize=(11, 4.2))
    for r in runs:
        th = r["thermo"]
        st = _run_style(r)
        if r.get("points"):
            st["marker"] = "s"
        label = f"{r['engine']} seed {r['seed']}" + (" (settled bed, slabs)" if r.get("points")
                                                     else "")
        ax.plot(th.phi, th.pressure / p_scale, lw=1.2, label=label, **st)
        axl.semilogy(th.phi, np.clip(th.pressure / p_scale, 1e-9, None), lw=1.0, **st)
        if np.isfinite(r.get("phi_j", np.nan)) and np.isfinite(r.get("slope", np.nan)):
            x = np.linspace(r["phi_j"], th.phi.max(), 20)
            ax.plot(x, r["slope"] * (x - r["phi_j"]) / p_scale, color=st["color"], lw=0.6,
                    alpha=0.7)
            ax.axvline(r["phi_j"], color=st["color"], lw=0.5, alpha=0.5)
    lo = phi_min if phi_min is not None else max(0.0, min(r["thermo"].phi.min() for r in runs))
    for a in (ax, axl):
        a.set_xlim(lo, max(r["thermo"].phi.max() for r in runs))
        a.set_xlabel(r"packing fraction $\phi$")
    if window is not None:
        for v in window:
            axl.axhline(v, color="grey", lw=0.6, ls=":")
    ax.set_ylim(bottom=0)
    ax.set_ylabel(r"contact pressure $p D / k_n$")
    axl.set_ylabel(r"$p D / k_n$ (log)")
    ax.set_title("pressure and the linear fits extrapolated to $p = 0$", fontsize=9)
    axl.set_title("log scale; dotted: fit window", fontsize=9)
    ax.legend(fontsize=7, ncol=2)
    _save(fig, out)


def contacts_vs_phi(runs, out, z_iso=None, phi_min=None):
    """Contact number versus packing fraction: rattler-free (solid markers) and with
    rattlers (open markers), one series per run; ``z_iso`` drawn as a reference. For rods
    a second panel shows the orientational order versus packing fraction: 3-D nematic
    ``S``, 2-D ``sqrt(N) S_2`` (solid) and ``sqrt(N) S_4`` (open). Runs with ``p_c``
    (``(phi, P(C), rattler-free P(C))`` of the frame nearest to jamming) get a last
    panel with the contact-number distributions."""
    order = [c for c in ("s_nematic", "sqrt_n_s2", "sqrt_n_s4")
             if any(c in r["curves"] and r["curves"][c].notna().any() for r in runs)]
    p_c = [r for r in runs if r.get("p_c") is not None]
    panels = 1 + bool(order) + bool(p_c)
    fig, axes = plt.subplots(1, panels, figsize=(5.5 * panels, 4.4), squeeze=False)
    ax = axes[0, 0]
    for r in runs:
        cv = r["curves"]
        st = _run_style(r)
        m = cv.z_rattler_free > 0
        ax.plot(cv.phi[m], cv.z_rattler_free[m], marker="o", ms=3, lw=1,
                label=f"{r['engine']} seed {r['seed']}", **st)
        ax.plot(cv.phi, cv.z, marker="o", ms=3, mfc="none", lw=0.5, alpha=0.6, **st)
        if np.isfinite(r.get("phi_j", np.nan)):
            ax.axvline(r["phi_j"], color=st["color"], lw=0.5, alpha=0.5)
    if z_iso is not None:
        ax.axhline(z_iso, color="k", lw=0.8, ls=":", label=f"isostatic $z$ = {z_iso}")
    if phi_min is not None:
        ax.set_xlim(left=phi_min)
    ax.set_xlabel(r"packing fraction $\phi$")
    ax.set_ylabel(r"contact number $z$ (filled: rattlers removed)")
    ax.legend(fontsize=7, ncol=2)
    if order:
        ax2 = axes[0, 1]
        for r in runs:
            cv = r["curves"]
            st = _run_style(r)
            for c, mfc in zip(order, ("auto", "none", "none")):
                if c in cv:
                    ax2.plot(cv.phi, cv[c], marker="o", ms=3, lw=0.8, mfc=mfc, **st)
        ax2.set_xlabel(r"packing fraction $\phi$")
        ax2.set_ylabel(" / ".join(order) + " (open: second)")
        ax2.set_title("orientational order (disorder: S ~ 1/sqrt(N))", fontsize=9)
    if p_c:
        ax3 = axes[0, panels - 1]
        for r in p_c:
            phi, dist, dist_rf = r["p_c"]
            st = _style(r["engine"], r["seed_index"])
            ax3.plot(np.arange(len(dist_rf)), dist_rf, marker="o", ms=3, lw=1,
                     label=f"{r['engine']} seed {r['seed']} ($\\phi$ = {phi:.3f})", **st)
            ax3.plot(np.arange(len(dist)), dist, marker="o", ms=3, mfc="none", lw=0.5,
                     alpha=0.6, **st)
        ax3.set_xlabel("contacts per particle $C$")
        ax3.set_ylabel("$P(C)$ (filled: rattlers removed)")
        ax3.set_title("frame nearest to $\\phi_J$", fontsize=9)
        ax3.legend(fontsize=6)
    _save(fig, out)


def observable_by_engine(stats, observable, out, ylabel=None, band=None):
    """Mean +- standard deviation over seeds of one observable, per case and engine.

    ``stats``: :func:`analysis.compare.per_engine` table. ``band``: optional
    ``(lo, hi)`` reference range shaded in grey.
    """
    s = stats[stats.observable == observable]
    cases = sorted(s.case.unique())
    engines = [e for e in ENGINE_COLORS if e in set(s.engine)]
    fig, ax = plt.subplots(figsize=(max(4, 1.6 * len(cases) + 2), 3.8))
    for k, e in enumerate(engines):
        se = s[s.engine == e].set_index("case").reindex(cases)
        x = np.arange(len(cases)) + (k - (len(engines) - 1) / 2) * 0.15
        ax.errorbar(x, se["mean"], yerr=se["std"].fillna(0), fmt="o", capsize=3,
                    color=ENGINE_COLORS[e], label=e)
    if band is not None:
        ax.axhspan(*band, color="grey", alpha=0.15, lw=0)
    ax.set_xticks(np.arange(len(cases)), cases)
    ax.set_ylabel(ylabel or observable)
    ax.legend(fontsize=8)
    _save(fig, out)


def message_figure(out, message: str):
    """A figure that only says why there is nothing to draw (e.g. every run failed)."""
    fig, ax = plt.subplots(figsize=(6, 2))
    ax.axis("off")
    ax.text(0.5, 0.5, message, ha="center", va="center", wrap=True)
    _save(fig, out)


def trends(summary, parameter, observables, out, title=None, references=None, series=None,
           papers=()):
    """Observables versus a case parameter (e.g. ``alpha``), one panel each, engines
    overlaid: mean and standard deviation over seeds (a series ``'<engine> <protocol>'``,
    runs of another protocol, in the engine's colour with open squares). ``references``
    maps an observable to ``[(label, x (array), y (array))]`` curves drawn in black
    (theory). ``series``: a second parameter column (e.g. ``bond_number``) that splits
    each engine's points into one line per value, coloured by value, with one marker and
    line style per engine. ``papers``: published values, dicts ``observable, label, x, y,
    yerr``, drawn as red diamonds with their uncertainty where ``x`` lies within the
    data's range, one legend entry per label."""
    have = summary[np.isfinite(summary.value.astype(float))]
    obs = [o for o in observables if o in set(have.observable)]
    if not obs or parameter not in summary.columns:
        message_figure(out, f"no {', '.join(observables)} versus {parameter} to draw")
        return
    if series is not None and series not in summary.columns:
        raise ValueError(f"series {series!r} is no column of the summary "
                         f"(columns: {', '.join(map(str, summary.columns))})")
    values = sorted(summary[series].dropna().unique()) if series else [None]
    cmap = plt.get_cmap("viridis")
    engines = sorted(summary.engine.unique())
    fig, axes = plt.subplots(1, len(obs), figsize=(4.2 * len(obs), 3.6), squeeze=False)
    for ax, o in zip(axes[0], obs):
        s = summary[summary.observable == o]
        for engine, g in s.groupby("engine"):
            base = engine.split()[0]
            other = base != engine
            for value in values:
                gv = g if value is None else g[g[series] == value]
                if gv.empty:
                    continue
                st = gv.groupby(parameter)["value"].agg(["mean", "std"]).reset_index()
                if value is None:
                    # a series named '<engine> <protocol>' (another protocol): the engine's
                    # colour, open squares, dashed
                    style = dict(fmt="s--" if other else "o-", mfc="none" if other else None,
                                 color=ENGINE_COLORS.get(base, "k"), label=engine)
                else:
                    k = engines.index(engine)
                    style = dict(fmt="os^Dv"[k % 5] + ["-", "--", ":", "-."][k % 4],
                                 color=cmap(values.index(value) / max(len(values) - 1, 1) * 0.9),
                                 label=f"{engine}, {series} {value:g}")
                ax.errorbar(st[parameter], st["mean"], yerr=st["std"].fillna(0), capsize=3,
                            ms=4, **style)
        lo, hi = s[parameter].min(), s[parameter].max()
        for k, (label, x, y) in enumerate((references or {}).get(o, [])):
            keep = (np.asarray(x) >= lo) & (np.asarray(x) <= hi)  # theory only where data are
            if keep.any():  # black, one line style per reference curve
                ax.plot(np.asarray(x)[keep], np.asarray(y)[keep], color="k",
                        ls=["--", ":", "-."][k % 3], marker="x" if len(keep) < 30 else None,
                        ms=4, lw=0.8, label=label)
        shown = [p for p in papers if p["observable"] == o and lo <= p["x"] <= hi]
        for k, label in enumerate(dict.fromkeys(p["label"] for p in shown)):
            pts = [p for p in shown if p["label"] == label]
            ax.errorbar([p["x"] for p in pts], [p["y"] for p in pts],
                        yerr=[p["yerr"] for p in pts], fmt="Dd^v"[k % 4], color="tab:red",
                        mfc="none", ms=6, capsize=2, lw=0, elinewidth=1, label=label)
        ax.set_xlabel(parameter)
        positive = s[parameter][s[parameter] > 0]
        if lo > 0 and hi / lo > 50:  # e.g. compression rates over decades
            ax.set_xscale("log")
        elif lo == 0 and len(positive) and hi / positive.min() > 50:
            # e.g. Bond numbers 0, 100, ..., 1e4: linear up to the smallest positive value
            ax.set_xscale("symlog", linthresh=float(positive.min()))
        ax.set_ylabel(o)
        if series is None or ax is axes[0][0]:  # many series: one legend
            ax.legend(fontsize=7 if series is None else 6)
    if title:
        fig.suptitle(title, fontsize=10)
    _save(fig, out)


def _seed_groups(runs):
    """Runs of :func:`tapping_curves` grouped by their ``group`` (variant and engine; a
    run without one is its own group), in order of first appearance: ``(first run,
    curves)``, where a group of several seeds has as curves the seed mean of every column
    over the frames all its runs have, with ``<col>_min`` and ``<col>_max`` of the
    averaged columns beside it, and ``seeds``, their number."""
    import pandas as pd

    groups: dict = {}
    for k, r in enumerate(runs):
        groups.setdefault(r.get("group", k), []).append(r)
    out = []
    for members in groups.values():
        if len(members) == 1:
            out.append((members[0], members[0]["curves"], 1))
            continue
        steps = set(members[0]["curves"].step)
        for m in members[1:]:
            steps &= set(m["curves"].step)
        frames = [m["curves"].set_index("step").loc[sorted(steps)] for m in members]
        stacked = pd.concat(frames, keys=range(len(frames)))
        mean = stacked.groupby(level=1).mean()
        for col in [c for c in mean.columns if c.endswith("_avg")]:
            mean[f"{col}_min"] = stacked[col].groupby(level=1).min()
            mean[f"{col}_max"] = stacked[col].groupby(level=1).max()
        out.append((members[0], mean.reset_index(), len(members)))
    return out


def tapping_curves(runs, out, phi_max=None, n_layers: int = 4, layer_label: str = "",
                   paper=None):
    """Tapping: volumetric density (raw, thin; moving average over one oscillation,
    thick) and mean angle between spines and the base versus ``1 + tap number`` on a
    logarithmic axis, globally and per layer; all runs overlaid. Runs of one ``group``
    (the seeds of a variant on one engine) are drawn as their seed mean, thick, with the
    band between the seeds' lowest and highest moving averages.

    ``runs``: dicts with ``label``, ``engine``, ``index`` (run number for the colour),
    ``curves`` (:func:`analysis.summary.tap_curves`) and optionally ``group`` and
    ``group_label``. ``phi_max``: ``{label: value}`` of aligned-packing limits drawn as
    reference lines on the density panels. ``paper``: the paper's values to overlay, dicts
    with ``index`` (the colour of their runs), ``quantity`` (``phi`` or ``angle``),
    ``layer`` (0 for the whole bed), ``tap`` (``nan`` for a late state, drawn as a band
    from tap 1000 on), ``value`` and ``uncertainty``.
    """
    phi_max = phi_max or {}
    fig, axes = plt.subplots(2, n_layers + 1, figsize=(3.3 * (n_layers + 1), 6.4),
                             sharex=True, squeeze=False)
    cmap = plt.get_cmap("tab10")
    for r, cv, seeds in _seed_groups(runs):
        x = 1.0 + cv.tap.clip(lower=0.0)
        color = cmap(r["index"] % 10)
        ls = ENGINE_LINES.get(r["engine"], ":")
        label = (r["label"] if seeds == 1
                 else f"{r.get('group_label', r['label'])}, mean of {seeds} seeds")
        for k in range(n_layers + 1):
            suffix = "" if k == 0 else f"_layer{k}"
            for row, q in enumerate(("phi", "angle")):
                col = f"{q}{suffix}"
                if col not in cv:
                    continue
                if seeds == 1:
                    axes[row, k].plot(x, cv[col], color=color, lw=0.4, alpha=0.5, ls=ls)
                elif f"{col}_avg_min" in cv:
                    axes[row, k].fill_between(x, cv[f"{col}_avg_min"], cv[f"{col}_avg_max"],
                                              color=color, alpha=0.2, lw=0)
                if f"{col}_avg" in cv:
                    axes[row, k].plot(x, cv[f"{col}_avg"], color=color, lw=1.4, ls=ls,
                                      label=label if (row, k) == (0, 0) else None)
    for i, ref in enumerate(paper or []):
        ax = axes[0 if ref["quantity"] == "phi" else 1, int(ref["layer"])]
        color = cmap(ref["index"] % 10)
        label = "paper" if i == 0 else None
        if np.isfinite(ref["tap"]):
            ax.errorbar([1.0 + ref["tap"]], [ref["value"]], yerr=[ref["uncertainty"]], fmt="s",
                        color=color, mec="k", ms=6, capsize=3, zorder=5, label=label)
        else:
            ax.axhspan(ref["value"] - ref["uncertainty"], ref["value"] + ref["uncertainty"],
                       xmin=0.75, color=color, alpha=0.12, hatch="//", lw=0, label=label)
    axes[0, 0].set_title("filled part of the cylinder", fontsize=9)
    for k in range(n_layers):
        axes[0, k + 1].set_title(f"layer {k + 1} {layer_label}".strip(), fontsize=9)
    for ax in axes[0]:
        for value in phi_max.values():
            ax.axhline(value, color="grey", lw=0.8, ls=":")
        ax.set_ylabel(r"volumetric density $\phi$")
    for label, value in phi_max.items():
        axes[0, 0].text(1.0, value, f" {label}", fontsize=6, va="bottom", color="grey")
    for ax in axes[1]:
        ax.set_ylabel("mean angle to the base (deg)")
        ax.set_xlabel("1 + tap number")
        ax.set_ylim(0, 90)
    from matplotlib.ticker import FuncFormatter, LogLocator, NullFormatter
    last = max((float(r["curves"].tap.max()) for r in runs if len(r["curves"])), default=1.0)
    subs = (1.0, 2.0, 5.0) if last < 500 else (1.0, 3.0)  # labels that do not overlap
    for ax in axes.ravel():
        ax.set_xscale("log")
        ax.xaxis.set_major_locator(LogLocator(base=10, subs=subs))
        ax.xaxis.set_major_formatter(FuncFormatter(lambda val, _: f"{val:g}"))
        ax.xaxis.set_minor_formatter(NullFormatter())
    axes[0, 0].legend(fontsize=6, loc="lower right")
    fig.suptitle("tapping: thin lines raw frames, thick the moving average over one oscillation "
                 "(several seeds: their mean, the band between the lowest and highest); "
                 "solid pysim, dashed LAMMPS, dotted LIGGGHTS"
                 + ("; squares and hatched bands: the paper's values (late state: bands)"
                    if paper else ""), fontsize=9)
    fig.tight_layout()
    _save(fig, out)


def tapping_sets(table, out, labels=None):
    """Tapping: the settled and the late (last eighth of the taps) density and mean angle
    to the base of every parameter set, per engine: each seed a small dot, the seed mean a
    large marker with two standard errors of it as error bar (needs two seeds).

    ``table``: rows ``variant, engine, observable, seed, value`` with observables
    ``phi_settled``, ``phi_late``, ``angle_settled``, ``angle_late``; ``labels``:
    ``{variant: tick label}``. Where the table has finite ``contacts_flight`` (how far the
    late taps lift the bed, :func:`analysis.summary.cycle_rows`), a third panel shows it."""
    variants = list(dict.fromkeys(table.variant))
    engines = [e for e in ENGINE_COLORS if e in set(table.engine)] + sorted(
        set(table.engine) - set(ENGINE_COLORS))
    flight = np.isfinite(table[table.observable == "contacts_flight"].value.to_numpy(float)).any()
    ncol = 3 if flight else 2
    # about 1.2 in per tick label (three lines of 7-point text) in every panel
    fig, axes = plt.subplots(1, ncol, figsize=(min(24.0, ncol * (1.2 * len(variants) + 1.0)),
                                               4.2))
    states = (("settled", "s", False), ("late", "o", True))
    panels = [(axes[0], [(f"phi_{k}", k, m, f) for k, m, f in states],
               r"volumetric density $\phi$"),
              (axes[1], [(f"angle_{k}", k, m, f) for k, m, f in states],
               "mean angle to the base (deg)")]
    if flight:
        panels.append((axes[2], [("contacts_flight", "late", "D", True)],
                       "late taps: contacts in flight / on the base"))
    width = 0.7 / max(1, len(engines))
    for ax, series, ylabel in panels:
        for e_i, engine in enumerate(engines):
            color = ENGINE_COLORS.get(engine, "k")
            for observable, kind, marker, filled in series:
                fill = color if filled else "none"
                sub = table[(table.engine == engine) & (table.observable == observable)]
                label = f"{engine}, {kind}"
                for v_i, variant in enumerate(variants):
                    vals = sub[sub.variant == variant].value.dropna().to_numpy()
                    if not len(vals):
                        continue
                    xpos = v_i + (e_i - (len(engines) - 1) / 2) * width
                    ax.plot(np.full(len(vals), xpos), vals, ".", color=color, ms=3, alpha=0.6)
                    err = 2 * vals.std(ddof=1) / np.sqrt(len(vals)) if len(vals) > 1 else None
                    ax.errorbar(xpos, vals.mean(), yerr=err, fmt=marker, color=color,
                                mfc=fill, ms=7, capsize=3, label=label)
                    label = None  # one legend entry per engine and state
        ax.set_xticks(range(len(variants)))
        ax.set_xticklabels([(labels or {}).get(v, v) for v in variants], fontsize=7)
        ax.set_ylabel(ylabel)
        ax.grid(axis="y", lw=0.3, alpha=0.5)
    axes[1].axhline(np.degrees(np.pi / 2 - 1.0), color="grey", lw=0.8, ls=":")
    axes[1].text(0.01, np.degrees(np.pi / 2 - 1.0), "isotropic", fontsize=6, color="grey",
                 va="bottom", transform=axes[1].get_yaxis_transform())
    axes[0].legend(fontsize=6)
    fig.suptitle("tapping: settled (squares) and late state (circles: mean over the last "
                 "eighth of the taps), seed means with two standard errors, dots the seeds",
                 fontsize=9)
    fig.tight_layout()
    _save(fig, out)


def _segments_panel(ax, frame, horizontal: int, select=None):
    """Spines of the selected grains projected on the (``horizontal``, z) plane, drawn
    as round-capped lines of the grain diameter, coloured by the angle to the base."""
    from matplotlib.collections import LineCollection

    sel = np.ones(frame.n, bool) if select is None else select
    x, u, half = frame.x[sel], frame.axis[sel], 0.5 * frame.length[sel]
    a = np.column_stack([x[:, horizontal] - half * u[:, horizontal], x[:, 2] - half * u[:, 2]])
    b = np.column_stack([x[:, horizontal] + half * u[:, horizontal], x[:, 2] + half * u[:, 2]])
    beta = np.degrees(np.arcsin(np.clip(np.abs(u[:, 2]), 0, 1)))
    order = np.argsort(x[:, 1 - horizontal])  # far grains first
    lc = LineCollection(np.stack([a, b], axis=1)[order], cmap="viridis", capstyle="round")
    lc.set_array(beta[order])
    lc.set_clim(0, 90)
    ax.add_collection(lc)
    return lc, 2.0 * float(np.mean(frame.radius[sel])) if sel.any() else 0.0


def _nice_step(span: float, ticks: int = 4) -> float:
    """A 1-2-5 step giving about ``ticks`` ticks over ``span``."""
    raw = max(span / ticks, 1e-12)
    mag = 10.0 ** np.floor(np.log10(raw))
    return float(mag * min((m for m in (1.0, 2.0, 5.0, 10.0) if m * mag >= raw)))


def _stadiums(a, b, radius, points: int = 12) -> np.ndarray:
    """Outlines (N, 2 points + 2, 2) of 2-D stadiums: the points within ``radius`` of the
    segments ``a``-``b`` (N, 2), a disk where ``a = b``; the outline of a spherocylinder
    seen along any direction."""
    d = b - a
    n = np.linalg.norm(d, axis=1)
    ang = np.where(n > 0, np.arctan2(d[:, 1], d[:, 0]), 0.0)
    half = np.linspace(-np.pi / 2, np.pi / 2, points)
    cap_b = ang[:, None] + half[None, :]  # around b, facing along the segment
    cap_a = cap_b + np.pi  # around a, facing back
    r = np.asarray(radius)[:, None]
    ring_b = b[:, None, :] + r[..., None] * np.stack([np.cos(cap_b), np.sin(cap_b)], -1)
    ring_a = a[:, None, :] + r[..., None] * np.stack([np.cos(cap_a), np.sin(cap_a)], -1)
    return np.concatenate([ring_b, ring_a], axis=1)


def packing_snapshots(frames, out):
    """One panel per ``(title, Frame)``: a 2-D packing whole, a 3-D one as the slab of
    thickness ``max(L + D)`` through the middle of the box seen along y (the x-z plane),
    every grain drawn at its size as the outline it casts (a stadium; a disk for a
    sphere). Rods coloured by the angle of the spine to the horizontal (3-D: to the x-y
    plane; 2-D: to the x axis), spheres and disks by radius."""
    from matplotlib.collections import PolyCollection

    fig, axes = plt.subplots(1, len(frames), figsize=(4.2 * len(frames) + 0.6, 4.4),
                             squeeze=False)
    pc = None
    for ax, (title, f) in zip(axes[0], frames):
        two_d = f.dim == 2
        h, v = (0, 1) if two_d else (0, 2)
        sel = np.ones(f.n, bool)
        if not two_d:
            mid = f.box_lo[1] + 0.5 * f.box[1]
            sel = np.abs(f.x[:, 1] - mid) < 0.5 * float(np.max(f.length + 2 * f.radius))
        x, u, half, r = f.x[sel], f.axis[sel], 0.5 * f.length[sel], f.radius[sel]
        a = np.column_stack([x[:, h] - half * u[:, h], x[:, v] - half * u[:, v]])
        b = np.column_stack([x[:, h] + half * u[:, h], x[:, v] + half * u[:, v]])
        rods = bool(np.any(f.length > 0))
        if rods:
            tilt = np.abs(u[:, 1]) if two_d else np.abs(u[:, 2])
            colour, clim, label = np.degrees(np.arcsin(np.clip(tilt, 0, 1))), (0, 90), \
                "spine angle to the horizontal (deg)" if not two_d else \
                "spine angle to the x axis (deg)"
        else:
            colour, clim, label = r, (float(f.radius.min()), float(f.radius.max()) or 1.0), \
                "radius"
        order = np.argsort(x[:, 1]) if not two_d else np.arange(len(x))  # far grains first
        pc = PolyCollection(_stadiums(a, b, r)[order], cmap="viridis", edgecolors="k",
                            linewidths=0.2)
        pc.set_array(colour[order])
        pc.set_clim(*clim if clim[1] > clim[0] else (clim[0], clim[0] + 1))
        ax.add_collection(pc)
        lo, hi = f.box_lo, f.box_lo + f.box
        ax.add_patch(plt.Rectangle((lo[h], lo[v]), f.box[h], f.box[v], fill=False, lw=0.8))
        pad = 0.05 * max(f.box[h], f.box[v])
        ax.set_xlim(lo[h] - pad, hi[h] + pad)
        ax.set_ylim(lo[v] - pad, hi[v] + pad)
        ax.set_aspect("equal")
        ax.set_xlabel("x")
        ax.set_ylabel("y" if two_d else "z")
        ax.set_title(f"{title}\n" + ("all grains" if two_d else
                                      f"slab through the middle ({int(sel.sum())} of {f.n})"),
                     fontsize=8)
        ax.tick_params(labelsize=7)
    if pc is not None:
        fig.colorbar(pc, ax=axes.ravel().tolist(), shrink=0.8).set_label(label)
    _save(fig, out)


def tapping_snapshots(frames, out, container_diameter: float, cut: float | None = None):
    """Side views (all grains projected on x-z) and cuts through the cylinder axis (grains
    whose centre lies within ``cut`` of the x-z plane, default half a grain length) of the
    given frames: ``frames`` is a list of ``(title, Frame)``, one column each; grains
    coloured by the angle between spine and base."""
    from matplotlib.ticker import FuncFormatter, MultipleLocator

    ncol = len(frames)
    fig, axes = plt.subplots(2, ncol, figsize=(2.6 * ncol + 0.8, 7.2), squeeze=False)
    top = max(float(np.max(f.x[:, 2] + 0.5 * f.length + f.radius)) for _, f in frames)
    rc = 0.5 * container_diameter
    lc = None
    for c, (title, f) in enumerate(frames):
        width = cut if cut is not None else 0.5 * float(np.max(f.length + 2 * f.radius))
        for r, (sel, name) in enumerate([(None, "side view"),
                                         (np.abs(f.x[:, 1]) < width, "cut through the axis")]):
            ax = axes[r, c]
            lc, dia = _segments_panel(ax, f, 0, sel)
            ax.set_xlim(-rc * 1.05, rc * 1.05)
            ax.set_ylim(min(-0.05 * top, float(f.x[:, 2].min()) - dia), top * 1.05)
            ax.set_aspect("equal")
            # line width in points = grain diameter in data units
            fig.canvas.draw()
            bbox = ax.get_window_extent()
            pts_per_unit = bbox.width / (2.1 * rc) * 72.0 / fig.dpi
            lc.set_linewidth(max(dia * pts_per_unit, 0.3))
            ax.axvline(-rc, color="k", lw=0.8)
            ax.axvline(rc, color="k", lw=0.8)
            ax.set_title(f"{title}\n{name}", fontsize=8)
            ax.tick_params(labelsize=6)
            # ticks in grain diameters: readable whatever the unit system
            ax.xaxis.set_major_locator(MultipleLocator(_nice_step(2 * rc / dia) * dia))
            ax.yaxis.set_major_locator(MultipleLocator(_nice_step(top / dia) * dia))
            ax.xaxis.set_major_formatter(FuncFormatter(lambda v, _, d=dia: f"{v / d:.0f}"))
            ax.yaxis.set_major_formatter(FuncFormatter(lambda v, _, d=dia: f"{v / d:.0f}"))
            if r == 1:
                ax.set_xlabel("x / D", fontsize=7)
            if c == 0:
                ax.set_ylabel("z / D", fontsize=7)
    if lc is not None:
        cb = fig.colorbar(lc, ax=axes.ravel().tolist(), shrink=0.6)
        cb.set_label("angle to the base (deg)")
    _save(fig, out)


def deposit_profiles(runs, out):
    """Deposits: packing fraction, vertical stress ``sigma_vv`` and horizontal stress
    ``sigma_hh`` (compressive positive, with the Janssen saturation fit of ``sigma_vv`` as
    a thin line) versus the depth ``x = h / W``, the distribution of the angle between
    spines and the horizontal, the radial orientation correlation ``Q(r)`` and the
    distribution of the angle between the major (most compressive) principal stress of
    each coarse-graining element and the horizontal, and the Janssen apparent mass
    (``sigma_vv W^(d-1) / g`` against the grain mass above each slab, the diagonal
    being a column whose walls hold nothing); one colour per variant, solid pysim,
    dashed LAMMPS, dotted LIGGGHTS.

    Last, the polar distribution of the major axis of each grain's own stress (Hidalgo et
    al.'s Fig. 5; an axis, so drawn at ``phi`` and ``phi + 180``; 0 is horizontal, 90
    vertical).

    ``runs``: dicts with ``label``, ``engine``, ``index`` (colour), ``profile``
    (:func:`analysis.summary.analyse_deposit`), ``angles`` (degrees, final frame) and,
    optionally, ``q_r`` (``(r / length, Q)``), ``major`` (``(edges in degrees,
    density, elements)``) and ``major_particles`` (degrees, one per loaded grain).
    """
    fig, axes = plt.subplots(2, 4, figsize=(18, 8))
    axes = axes.ravel()
    axes[7].remove()
    axes[7] = fig.add_subplot(2, 4, 8, projection="polar")
    cmap = plt.get_cmap("tab10")
    top_mass = 0.0
    for r in runs:
        pr = r["profile"]
        color = cmap(r["index"] % 10)
        ls = ENGINE_LINES.get(r["engine"], ":")
        axes[0].plot(pr.phi, pr.x, color=color, ls=ls, marker=".", label=r["label"])
        if "sigma_vv_err" in pr:  # standard errors from the spread over columns
            axes[1].errorbar(pr.sigma_vv, pr.x, xerr=pr.sigma_vv_err, color=color, ls=ls,
                             marker=".", capsize=2, elinewidth=0.6)
        else:
            axes[1].plot(pr.sigma_vv, pr.x, color=color, ls=ls, marker=".")
        if "sigma_vv_fit" in pr and np.isfinite(pr.sigma_vv_fit).any():
            axes[1].plot(pr.sigma_vv_fit, pr.x, color=color, ls=ls, lw=0.6, alpha=0.7)
        axes[2].plot(pr.sigma_hh, pr.x, color=color, ls=ls, marker=".")
        axes[3].hist(r["angles"], bins=18, range=(0, 90), density=True, histtype="step",
                     color=color, ls=ls)
        if "q_r" in r:
            axes[4].plot(*r["q_r"], color=color, ls=ls, marker=".", ms=3)
        if "major" in r and r["major"][2] > 0:
            edges, dens, _ = r["major"]
            axes[5].stairs(dens * np.pi / 180, edges, color=color, ls=ls)
        if len(r.get("major_particles", [])):
            edges = np.linspace(-np.pi, np.pi, 37)
            a = np.radians(np.asarray(r["major_particles"], float))
            dens, _ = np.histogram(np.concatenate([a, np.where(a > 0, a - np.pi, a + np.pi)]),
                                   bins=edges, density=True)
            axes[7].stairs(dens, edges, color=color, ls=ls)
        if "apparent_mass" in pr:
            axes[6].plot(pr.mass_above, pr.apparent_mass, color=color, ls=ls, marker=".")
            top_mass = max(top_mass, float(np.nanmax(pr.mass_above, initial=0.0)))
    for ax, label in zip(axes[:3], [r"packing fraction $\phi$", r"vertical stress $\sigma_{vv}$",
                                    r"horizontal stress $\sigma_{hh}$"]):
        ax.set_xlabel(label)
        ax.set_ylabel("depth  x = h / W")
        ax.invert_yaxis()
    axes[1].set_title("thin: Janssen fit (weighted by the bars: standard errors over "
                      "columns)", fontsize=8)
    axes[3].set_xlabel("angle between spine and horizontal (deg)")
    axes[3].set_title("final frame", fontsize=8)
    axes[3].set_ylabel("probability density (1/deg)")
    beta = np.linspace(0, 90, 91)
    dims = {r.get("dim", 3) for r in runs}
    if 3 in dims:  # uniform directions on the sphere
        axes[3].plot(beta, np.cos(np.radians(beta)) * np.pi / 180, color="grey", lw=0.8,
                     ls=":", label="isotropic (3-D)")
    if 2 in dims:  # uniform angles in the plane
        axes[3].plot(beta, np.full_like(beta, 1.0 / 90.0), color="grey", lw=0.8, ls="--",
                     label="isotropic (2-D)")
    axes[3].legend(fontsize=6)
    axes[4].axhline(0.0, color="grey", lw=0.6)
    axes[4].set_xlabel("centre distance r / (L + D)")
    axes[4].set_ylabel(r"$Q(r)$: $\langle P_2(u_i \cdot u_j)\rangle$ (2-D: "
                       r"$\langle\cos 2\Delta\theta\rangle$)")
    axes[5].set_xlabel("major principal stress axis to the horizontal (deg)")
    axes[5].set_ylabel("probability density (1/deg)")
    axes[5].set_title("elements of 5 particle lengths (non-empty)", fontsize=8)
    axes[6].plot([0, top_mass], [0, top_mass], color="grey", lw=0.8, ls=":",
                 label="walls hold nothing")
    axes[6].set_xlabel("grain mass above the slab centre")
    axes[6].set_ylabel(r"apparent mass $\sigma_{vv} W^{d-1} / g$")
    axes[6].set_title("Janssen: saturates when the walls hold weight", fontsize=8)
    axes[6].legend(fontsize=6)
    axes[7].set_title("major axis of each grain's stress\n(polar density; 90 = vertical)",
                      fontsize=8)
    handles, labels = axes[0].get_legend_handles_labels()
    fig.legend(handles, labels, fontsize=7, loc="lower right")
    fig.suptitle("deposits: profiles versus depth (solid pysim, dashed LAMMPS, dotted LIGGGHTS)",
                 fontsize=9)
    fig.tight_layout()
    _save(fig, out)


def janssen_against_paper(panels, out):
    """Janssen profiles against a paper's fits, one column per case: top, the trace of
    the mean stress (compressive positive) in the case's units against the depth ``x = h
    / W``, with standard errors and each run's saturation fit ``sigma_m (1 - exp(-x /
    h_s))`` (thin); bottom, the same profiles over their own fitted ``sigma_m`` beside
    the paper's ``1 - exp(-x / h_s)`` (black), which compares saturation depths when the
    units of the stresses cannot be matched. The paper's ``sigma_m`` and ``h_s`` are
    printed.

    ``panels``: dicts with ``title``, ``runs`` (dicts ``label``, ``engine``, ``x``,
    ``trace``, ``err`` (standard errors, or NaN), ``fit`` (``(x, values)`` or ``None``),
    ``sigma_m``, ``h_s`` (NaN without a saturation fit)) and ``paper`` (``None`` or a
    dict ``sigma_m``, ``h_s``, ``label``).
    """
    if not panels:
        message_figure(out, "no successful deposition run to draw: see failures.csv")
        return
    n = len(panels)
    fig, axes = plt.subplots(2, n, figsize=(4.6 * n, 8.0), squeeze=False)
    cmap = plt.get_cmap("tab10")
    for col, panel in enumerate(panels):
        top, shape = axes[0, col], axes[1, col]
        x_max = 0.0
        for i, r in enumerate(panel["runs"]):
            color = cmap(i % 10)
            ls = ENGINE_LINES.get(r["engine"], ":")
            x = np.asarray(r["x"], float)
            x_max = max(x_max, float(np.nanmax(x, initial=0.0)))
            err = np.asarray(r.get("err", np.full(len(x), np.nan)), float)
            top.errorbar(r["trace"], x, xerr=np.where(np.isfinite(err), err, 0.0), color=color,
                         ls=ls, marker=".", capsize=2, elinewidth=0.6, label=r["label"])
            if r["fit"] is not None:
                fx, fy = r["fit"]
                keep = np.asarray(fx, float) <= x_max
                top.plot(np.asarray(fy)[keep], np.asarray(fx)[keep], color=color, ls=ls, lw=0.6)
            if np.isfinite(r["sigma_m"]):
                shape.plot(np.asarray(r["trace"], float) / r["sigma_m"], x, color=color,
                           ls=ls, marker=".",
                           label=f"{r['label']}: h_s/W = {r['h_s']:.2f}")
        paper = panel["paper"]
        if paper is not None:
            xs = np.linspace(0.0, x_max if x_max > 0 else 3.0 * paper["h_s"], 200)
            shape.plot(1.0 - np.exp(-xs / paper["h_s"]), xs, color="k", lw=1.4,
                       label=f"{paper['label']}: h_s/W = {paper['h_s']:g}")
            unmet = paper.get("unmet") or []
            title = (f"{panel['title']}\npaper: sigma_m = {paper['sigma_m']:g} N/m, "
                     f"h_s/W = {paper['h_s']:g}")
            if unmet:
                title += "\nconditions differ: " + "\n".join(unmet)
            top.set_title(title, fontsize=7, color="k" if not unmet else "tab:red")
        else:
            top.set_title(f"{panel['title']}\nthe paper gives no fit here", fontsize=8)
        top.ticklabel_format(axis="x", style="sci", scilimits=(-3, 4))
        top.set_xlabel(r"trace of the mean stress in $5d \times 5d$ elements (case units)")
        shape.set_xlabel(r"$\mathrm{tr}\,\sigma / \sigma_m$ (each run its own fit)")
        shape.axvline(1.0, color="grey", lw=0.6, ls=":")
        if not any(np.isfinite(r["sigma_m"]) for r in panel["runs"]):
            shape.text(0.5, 0.5, "no run saturates within its depth\n(no sigma_m to scale by)",
                       transform=shape.transAxes, ha="center", fontsize=8, color="tab:red")
        for ax in (top, shape):
            ax.set_ylabel("depth  x = h / W")
            ax.invert_yaxis()
            ax.legend(fontsize=6)
    fig.suptitle("Janssen saturation of the pressure against the paper's fits "
                 "(solid pysim, dashed LAMMPS, dotted LIGGGHTS)", fontsize=9)
    fig.tight_layout()
    _save(fig, out)


def contact_angle_distributions(groups, out, bins: int = 30):
    """``P(varphi)`` of the contact angle around the particle
    (:func:`analysis.contacts.contact_angles`), one panel per variant, engines overlaid.

    ``groups``: ``[(title, junction, {engine: angles (rad)})]`` with ``junction`` the
    cap-side angle ``arctan(2R/L)`` (drawn dotted; ``None`` for disks). The dashed line
    is ``2/pi``, isotropic contacts on disks.
    """
    n = max(len(groups), 1)
    fig, axes = plt.subplots(1, n, figsize=(3.6 * n, 3.2), squeeze=False, sharey=True)
    edges = np.linspace(0.0, np.pi / 2, bins + 1)
    for ax, (title, junction, by_engine) in zip(axes[0], groups):
        for engine, angles in by_engine.items():
            if len(angles):
                ax.hist(angles, bins=edges, density=True, histtype="step", lw=1.4,
                        color=ENGINE_COLORS.get(engine, "k"), label=f"{engine} ({len(angles)})")
        ax.axhline(2 / np.pi, color="grey", lw=0.8, ls="--")
        if junction is not None:
            ax.axvline(junction, color="grey", lw=0.8, ls=":")
        ax.set_xlim(0, np.pi / 2)
        ax.set_xticks([0, np.pi / 8, np.pi / 4, 3 * np.pi / 8, np.pi / 2],
                      ["0", "π/8", "π/4", "3π/8", "π/2"])
        ax.set_xlabel("contact angle from the spine, varphi")
        ax.set_title(title, fontsize=9)
        ax.legend(fontsize=7)
    axes[0, 0].set_ylabel("P(varphi)")
    _save(fig, out)


def pressure_by_variant(runs, out, p_scale=1.0, parameter=None):
    """Contact pressure versus packing fraction of every run of a study on one log-scale
    panel, coloured by variant (line style by engine): how ``p(phi)`` changes with the
    varying parameter (e.g. the compression rate). ``runs``: dicts with ``variant``,
    ``value`` (of ``parameter``, for the legend and the colour order), ``engine``,
    ``seed``, ``thermo`` and optionally ``phi_j`` (a marker on the curve's axis) and
    ``points`` (markers without a line: the slabs of a settled bed)."""
    order = sorted({(r["value"], r["variant"]) for r in runs}, key=lambda t: (str(type(t[0])), t))
    cmap = plt.get_cmap("viridis", max(len(order), 2))
    colour = {v: cmap(k) for k, (_val, v) in enumerate(order)}
    styles = {"pysim": "-", "lammps": "--", "lammps-body": "-.", "liggghts": ":"}
    fig, ax = plt.subplots(figsize=(6.8, 4.4))
    seen = set()
    for r in runs:
        th = r["thermo"]
        key = (r["variant"], r["engine"])
        label = None
        if key not in seen:
            seen.add(key)
            name = f"{parameter} = {r['value']:g}" if parameter else r["variant"]
            label = f"{name} ({r['engine']})"
        line = dict(ls="none", marker="s", ms=3) if r.get("points") else \
            dict(ls=styles.get(r["engine"], "-"))  # points: the slabs of a settled bed
        ax.semilogy(th.phi, np.clip(th.pressure / p_scale, 1e-9, None), lw=1.0,
                    color=colour[r["variant"]], label=label, **line)
        if np.isfinite(r.get("phi_j", np.nan)):
            ax.axvline(r["phi_j"], color=colour[r["variant"]], lw=0.6, alpha=0.6,
                       ls=styles.get(r["engine"], "-"))
    ax.set_xlabel(r"packing fraction $\phi$")
    ax.set_ylabel(r"contact pressure $p D / k_n$")
    ax.set_title("p(phi) of every run; vertical lines: fitted phi_J", fontsize=9)
    lo = [float(r["thermo"].pressure[r["thermo"].pressure > 0].min() / p_scale) for r in runs
          if (r["thermo"].pressure > 0).any()]
    if lo:
        ax.set_ylim(bottom=max(min(lo) / 2, 1e-9))
    ax.legend(fontsize=7)
    _save(fig, out)


def order_scaling(curves, table, out):
    """``sqrt(N) S_2`` (filled) and ``sqrt(N) S_4`` (open) versus packing fraction along
    2-D compressions, one panel per aspect ratio and one colour per particle number N,
    every seed drawn; the dotted line is 1, the rms value for independent uniform
    angles. A lower row draws ``<S_2>`` and ``<S_4>`` (over the seeds, with their standard
    errors) against N with the ``1/sqrt(N)`` law through the smallest N.
    ``curves``/``table``: as :func:`analysis.order.finite_size_order`."""
    alphas = sorted(curves.alpha.unique())
    ns = sorted(curves.n.unique())
    cmap = plt.get_cmap("viridis", max(len(ns) + 1, 2))
    colour = {n: cmap(k) for k, n in enumerate(ns)}
    fig, axes = plt.subplots(2, len(alphas), figsize=(4.2 * len(alphas), 7.6), squeeze=False)
    for j, alpha in enumerate(alphas):
        ax = axes[0, j]
        labelled = set()
        for (n, _seed), g in curves[curves.alpha == alpha].groupby(["n", "seed"], sort=True):
            g = g.sort_values("phi")
            label = None if n in labelled else f"N = {n}"
            labelled.add(n)
            ax.plot(g.phi, g.sqrt_n_s2, marker="o", ms=3, lw=0.8, color=colour[n], label=label)
            ax.plot(g.phi, g.sqrt_n_s4, marker="o", ms=3, lw=0.5, mfc="none", ls="--",
                    color=colour[n])
        ax.axhline(1.0, color="k", lw=0.6, ls=":")
        ax.set_title(f"alpha = {alpha:g}", fontsize=9)
        ax.set_xlabel(r"packing fraction $\phi$")
        ax.set_ylim(bottom=0)
        if j == 0:
            ax.set_ylabel(r"$\sqrt{N} S_2$ (filled), $\sqrt{N} S_4$ (open)")
        ax.legend(fontsize=7)
        ax = axes[1, j]
        t = table[table.alpha == alpha].sort_values("n")
        if len(t):
            ax.errorbar(t.n, t.mean_s2, yerr=t.sem_s2, marker="o", color="k", capsize=3,
                        label=r"$\langle S_2 \rangle$")
            ax.errorbar(t.n, t.mean_s4, yerr=t.sem_s4, marker="o", mfc="none", color="k",
                        ls="--", capsize=3, label=r"$\langle S_4 \rangle$")
            ax.set_xscale("log")
            ax.set_yscale("log")
            n0 = float(t.n.iloc[0])
            ref = float(max(t.mean_s2.iloc[0], t.mean_s4.iloc[0]))
            ax.loglog(t.n, ref * np.sqrt(n0 / t.n), color="grey", lw=0.8, ls=":",
                      label=r"$\propto 1/\sqrt{N}$")
            ax.xaxis.set_minor_locator(matplotlib.ticker.NullLocator())
            ax.set_xticks(list(t.n), [str(int(v)) for v in t.n])
        ax.set_xlabel("particles N")
        if j == 0:
            ax.set_ylabel("order parameter, mean over the seeds")
        ax.legend(fontsize=7)
    fig.suptitle("orientational order of the compressed packings: disorder gives "
                 r"$S_n \sim 1/\sqrt{N}$", fontsize=10)
    _save(fig, out)


def against_papers(table, out, max_panels: int = 24):
    """The value rows of ``vs_paper.csv`` with a run behind them, one panel per paper and
    observable: the paper's values (black, error bars: their uncertainty) and each
    engine's seed means (error bars: standard errors) against the parameter that varies
    among the panel's rows (else the row ids); markers filled where the verdict is
    ``agrees``, open otherwise."""
    import pandas as pd

    point = ["alpha", "d", "sigma", "e_n", "Gamma", "bo_g", "layer", "tap"]
    rows = table[(table["kind"] == "value")]
    ran = rows[rows["engine"].fillna("").astype(str) != ""]
    keys = sorted({(p, o) for p, o in zip(ran["paper"], ran["observable"])})[:max_panels]
    if not keys:
        message_figure(out, "No run matches a published value yet\n(vs_paper.csv: every "
                            "row 'not run').")
        return
    ncol = min(3, len(keys))
    nrow = int(np.ceil(len(keys) / ncol))
    fig, axes = plt.subplots(nrow, ncol, figsize=(4.2 * ncol, 3.2 * nrow), squeeze=False)
    for ax, (paper, obs) in zip(axes.flat, keys):
        sub = rows[(rows["paper"] == paper) & (rows["observable"] == obs)]
        varying = [c for c in point if pd.to_numeric(sub[c], errors="coerce").nunique() > 1]
        if varying:
            xcol = varying[0]
            x = pd.to_numeric(sub[xcol], errors="coerce").to_numpy(float)
            ax.set_xlabel(xcol)
        else:
            ids = list(dict.fromkeys(sub["id"]))
            x = np.array([ids.index(i) for i in sub["id"]], float)
            ax.set_xticks(range(len(ids)), ids, rotation=30, fontsize=7)
        ref = sub.drop_duplicates("id")
        xr = x[[list(sub.index).index(i) for i in ref.index]]
        ax.errorbar(xr, ref["paper_value"], yerr=ref["paper_uncertainty"].fillna(0), fmt="s",
                    color="k", ms=5, capsize=3, label="paper")
        for engine, g in sub.groupby("engine"):
            if not str(engine):
                continue
            xe = x[[list(sub.index).index(i) for i in g.index]]
            agree = (g["verdict"] == "agrees").to_numpy()
            color = ENGINE_COLORS.get(engine, "tab:gray")
            ax.errorbar(xe, g["ours"], yerr=g["ours_uncertainty"].fillna(0), fmt="none",
                        ecolor=color, capsize=2)
            ax.scatter(xe[agree], g["ours"][agree], color=color, zorder=3, label=engine)
            ax.scatter(xe[~agree], g["ours"][~agree], facecolors="none", edgecolors=color,
                       zorder=3, label=f"{engine} (not agreeing)" if (~agree).any() else None)
        ax.set_title(f"{paper}: {obs}", fontsize=9)
        ax.legend(fontsize=6)
    for ax in list(axes.flat)[len(keys):]:
        ax.set_visible(False)
    fig.tight_layout()
    _save(fig, out)


def engine_differences(cmp, out, max_rows: int = 60):
    """Every engine pair of ``comparison.csv`` as its difference in units of its
    tolerance (error bars: two Welch standard errors), against the tolerance band
    ``[-1, 1]``; coloured by verdict."""
    colors = {"agree": "tab:green", "DIFFER": "tab:red", "inconclusive": "tab:orange",
              "n/a": "tab:gray"}
    rows = cmp[np.isfinite(cmp["difference"].astype(float))].head(max_rows)
    if not len(rows):
        message_figure(out, "No engine pair to compare\n(one engine per case, or no values).")
        return
    fig, ax = plt.subplots(figsize=(7.5, 0.9 + 0.24 * len(rows)))
    y = np.arange(len(rows))[::-1]
    x = rows["difference"].to_numpy(float) / rows["tolerance"].to_numpy(float)
    err = 2.0 * rows["se"].to_numpy(float) / rows["tolerance"].to_numpy(float)
    ax.axvspan(-1, 1, color="tab:green", alpha=0.1, lw=0, label="within the tolerance")
    ax.axvline(0, color="k", lw=0.6)
    for yi, xi, ei, v in zip(y, x, err, rows["verdict"]):
        ax.errorbar([xi], [yi], xerr=[ei] if np.isfinite(ei) else None, fmt="o",
                    color=colors.get(v, "k"), ms=4, capsize=2)
    ax.set_yticks(y, [f"{r.study}/{r.case} {r.observable}: {r.engine_b} - {r.engine_a}"
                      for r in rows.itertuples()], fontsize=6)
    ax.set_xlabel("difference / tolerance (green: agree, red: DIFFER, orange: inconclusive)")
    ax.legend(fontsize=6, loc="lower right")
    fig.tight_layout()
    _save(fig, out)


def growth_curves(runs, out, pc=None, title=None):
    """Curves of growth runs after Wouterse, Luding & Philipse: the mean contact number
    ``<C>`` (rattlers included) against ``phi`` (their Fig. 2) and the fraction of
    non-caged particles against ``phi`` (Fig. 6), one line per run (e.g. per growth
    rate), and, with ``pc``, the contact-number distributions of a few frames as bars
    (Fig. 3).

    ``runs``: dicts with ``label`` and ``curves`` (the growing frames,
    :func:`analysis.growth.growing_frames`: ``phi``, ``z``, ``noncaged_fraction``), and
    optionally ``phi_before_jump`` and ``c_mean_before_jump`` (a marker where the rods'
    jump of ``<C>`` starts) and ``phi_j`` (a vertical line). ``pc``: a table with
    ``step``, ``phi``, ``c``, ``fraction`` (:func:`analysis.summary.pc_table` of one run),
    one group of bars per frame.
    """
    panels = 2 + (pc is not None and len(pc) > 0)
    fig, axes = plt.subplots(1, panels, figsize=(5.0 * panels, 4.0), squeeze=False)
    ax_c, ax_n = axes[0, 0], axes[0, 1]
    cmap = plt.get_cmap("viridis", max(len(runs), 2))
    for k, r in enumerate(runs):
        cv = r["curves"].sort_values("phi")
        colour = cmap(k)
        ax_c.plot(cv.phi, cv.z, marker="o", ms=2.5, lw=1.0, color=colour, label=r["label"])
        if "noncaged_fraction" in cv:
            ax_n.plot(cv.phi, cv.noncaged_fraction, marker="o", ms=2.5, lw=1.0, color=colour,
                      label=r["label"])
        c_b = r.get("c_mean_before_jump", np.nan)
        if np.isfinite(c_b):
            ax_c.plot([r["phi_before_jump"]], [c_b], marker="D", ms=7, mfc="none",
                      color=colour)
        if np.isfinite(r.get("phi_j", np.nan)):
            for ax in (ax_c, ax_n):
                ax.axvline(r["phi_j"], color=colour, lw=0.6, ls=":")
    ax_c.set_xlabel(r"packing fraction $\phi$")
    ax_c.set_ylabel(r"mean contact number $\langle C\rangle$ (rattlers included)")
    ax_c.set_title("diamond: where the jump of <C> starts; dotted: phi_J", fontsize=9)
    ax_c.legend(fontsize=7)
    ax_n.set_xlabel(r"packing fraction $\phi$")
    ax_n.set_ylabel("fraction of non-caged particles")
    ax_n.set_ylim(-0.02, 1.02)
    if panels == 3:
        ax_p = axes[0, 2]
        steps = list(dict.fromkeys(pc.step))
        width = 0.8 / len(steps)
        pcmap = plt.get_cmap("plasma", len(steps) + 1)
        for q, st in enumerate(steps):
            part = pc[pc.step == st]
            ax_p.bar(part.c + (q - (len(steps) - 1) / 2) * width, part.fraction, width=width,
                     color=pcmap(q), label=f"$\\phi$ = {part.phi.iloc[0]:.3f}")
        ax_p.xaxis.set_major_locator(matplotlib.ticker.MaxNLocator(integer=True))
        ax_p.set_xlabel("contacts per particle $C$")
        ax_p.set_ylabel("$P(C)$")
        ax_p.legend(fontsize=7)
    if title:
        fig.suptitle(title, fontsize=10)
    _save(fig, out)


def closest_jamming(points, out, references=None, title=None):
    """Hard-sphere packings after Baranau & Tallarek (their Fig. 2): the density ``phi``
    each compression reached (left) and its closest jamming density ``phi_J`` (right)
    against the inverse compression rate ``1/gamma``, a colour per size spread ``sigma``
    and a marker per algorithm (``protocol`` ``ls`` or ``fb``), one point per packing.

    ``points``: :func:`analysis.closest_jamming.limits`'s input. ``references``: rows
    ``sigma``, ``observable`` (``phi_lt``, ``phi_rcp`` or ``phi_gcp``), ``value``: the
    paper's limits, drawn as dash-dotted (LT), dashed (RCP) and dotted (GCP) lines in the
    colour of their sigma.
    """
    fig, axes = plt.subplots(1, 2, figsize=(11.0, 4.2), sharey=True)
    sigmas = sorted(points["sigma"].unique())
    cmap = plt.get_cmap("viridis", max(len(sigmas), 2))
    markers = {"ls": "o", "fb": "s"}
    for k, sig in enumerate(sigmas):
        colour = cmap(k)
        for alg, g in points[points["sigma"] == sig].groupby("protocol"):
            for ax, col in zip(axes, ("phi", "phi_j")):
                ax.scatter(1.0 / g["rate"], g[col], s=18, marker=markers.get(alg, "^"),
                           facecolors="none", edgecolors=[colour],
                           label=f"$\\sigma$ = {sig:g}, {alg.upper()} (N = "
                                 f"{', '.join(str(int(n)) for n in sorted(g['n'].unique()))})")
        if references is not None:
            for obs, ls in (("phi_lt", "-."), ("phi_rcp", "--"), ("phi_gcp", ":")):
                ref = references[(references["observable"] == obs)
                                 & np.isclose(references["sigma"].astype(float), sig)]
                for v in ref["value"]:
                    for ax in axes:
                        ax.axhline(float(v), color=colour, lw=0.8, ls=ls)
    for ax, what in zip(axes, ("density after the compression $\\phi$",
                               "closest jamming density $\\phi_J$")):
        ax.set_xscale("log")
        ax.set_xlabel("inverse compression rate $1/\\gamma$")
        ax.set_title(what, fontsize=10)
    axes[0].set_ylabel("packing fraction")
    axes[1].legend(fontsize=7, loc="lower right")
    note = ("paper (N = 10^4): dash-dot phi_LT, dashed phi_RCP, dotted phi_GCP"
            if references is not None else "")
    fig.suptitle("; ".join(t for t in (title, note) if t), fontsize=10)
    _save(fig, out)


def caging_numbers(table, out, references=None):
    """Caging number of a spherocylinder against its aspect ratio (Wouterse et al.,
    Fig. 10a): mean and standard error per ``dimension``; the infinite rod
    (``alpha = inf``) as a horizontal line in its dimension's colour. ``table``:
    columns ``dimension``, ``alpha``, ``mean``, ``stderr``. ``references``: rows
    ``dimension``, ``alpha`` (inf for the infinite rod), ``value`` (the paper's numbers),
    drawn as crosses (finite alpha) or dotted lines (infinite rods)."""
    fig, ax = plt.subplots(figsize=(6.4, 4.2))
    for k, (dim, g) in enumerate(table.groupby("dimension", sort=True)):
        colour = f"C{k}"
        g = g.sort_values("alpha")
        fin = g[np.isfinite(g["alpha"])]
        ax.errorbar(fin["alpha"], fin["mean"], yerr=fin["stderr"], marker="o", ms=4,
                    color=colour, capsize=2, label=f"{int(dim)}-D, random point contacts")
        for _, row in g[~np.isfinite(g["alpha"])].iterrows():
            ax.axhline(row["mean"], color=colour, lw=1.0,
                       label=f"{int(dim)}-D infinite rod: {row['mean']:.2f} "
                             f"$\\pm$ {row['stderr']:.2f}")
        if references is not None:
            ref = references[np.isclose(references["dimension"].astype(float), dim)]
            fin_ref = ref[np.isfinite(ref["alpha"].astype(float))]
            ax.plot(fin_ref["alpha"], fin_ref["value"], "x", color=colour, ms=8,
                    label=f"paper, {int(dim)}-D" if len(fin_ref) else None)
            for v in ref[~np.isfinite(ref["alpha"].astype(float))]["value"]:
                ax.axhline(float(v), color=colour, lw=0.8, ls=":")
    ax.set_xscale("symlog", linthresh=0.1)
    ax.set_xlim(left=-0.01)  # the spheres and disks at 0 stay inside
    ax.set_xlabel(r"aspect ratio $\alpha = L/D$")
    ax.set_ylabel(r"caging number $\langle\gamma\rangle$")
    ax.legend(fontsize=7, loc="upper right")
    ax.set_title("contacts needed to cage a spherocylinder (paper: crosses, dotted)",
                 fontsize=9)
    _save(fig, out)
