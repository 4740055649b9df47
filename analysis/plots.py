"""Figures with every engine overlaid (matplotlib, written atomically as PNG)."""
from __future__ import annotations

import os
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

ENGINE_COLORS = {"pysim": "tab:blue", "lammps": "tab:orange", "liggghts": "tab:green"}
SEED_STYLES = ["-", "--", ":", "-."]


def _save(fig, path):
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(path.stem + ".part" + path.suffix)
    fig.savefig(tmp, dpi=130, bbox_inches="tight")
    plt.close(fig)
    os.replace(tmp, path)


def _style(engine, seed_index):
    return dict(color=ENGINE_COLORS.get(engine, "k"), ls=SEED_STYLES[seed_index % len(SEED_STYLES)])


def pressure_vs_phi(runs, out, p_scale=1.0, window=None, phi_min=None):
    """Contact pressure (units of ``p_scale``) versus packing fraction, one line per run,
    with each run's jamming fit drawn.

    ``runs``: list of dicts with ``engine``, ``seed_index``, ``thermo`` (DataFrame with
    ``phi``, ``pressure``), and optionally ``phi_j``, ``slope``.
    """
    fig, (ax, axl) = plt.subplots(1, 2, figsize=(11, 4.2))
    for r in runs:
        th = r["thermo"]
        st = _style(r["engine"], r["seed_index"])
        label = f"{r['engine']} seed {r['seed']}"
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
    ``S``, 2-D ``sqrt(N) S_2`` (solid) and ``sqrt(N) S_4`` (open)."""
    order = [c for c in ("s_nematic", "sqrt_n_s2", "sqrt_n_s4")
             if any(c in r["curves"] and r["curves"][c].notna().any() for r in runs)]
    fig, axes = plt.subplots(1, 2 if order else 1, figsize=(11 if order else 6.4, 4.4),
                             squeeze=False)
    ax = axes[0, 0]
    for r in runs:
        cv = r["curves"]
        st = _style(r["engine"], r["seed_index"])
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
            st = _style(r["engine"], r["seed_index"])
            for c, mfc in zip(order, ("auto", "none", "none")):
                if c in cv:
                    ax2.plot(cv.phi, cv[c], marker="o", ms=3, lw=0.8, mfc=mfc, **st)
        ax2.set_xlabel(r"packing fraction $\phi$")
        ax2.set_ylabel(" / ".join(order) + " (open: second)")
        ax2.set_title("orientational order (disorder: S ~ 1/sqrt(N))", fontsize=9)
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


def trends(summary, parameter, observables, out, title=None, references=None):
    """Observables versus a case parameter (e.g. ``alpha``), one panel each, engines
    overlaid: mean and standard deviation over seeds. ``references`` maps an observable
    to ``[(label, x (array), y (array))]`` curves drawn in black (theory)."""
    obs = [o for o in observables if o in set(summary.observable)]
    if not obs or parameter not in summary.columns:
        message_figure(out, f"no {', '.join(observables)} versus {parameter} to draw")
        return
    fig, axes = plt.subplots(1, len(obs), figsize=(4.2 * len(obs), 3.6), squeeze=False)
    for ax, o in zip(axes[0], obs):
        s = summary[summary.observable == o]
        for engine, g in s.groupby("engine"):
            st = g.groupby(parameter)["value"].agg(["mean", "std"]).reset_index()
            ax.errorbar(st[parameter], st["mean"], yerr=st["std"].fillna(0), fmt="o-",
                        capsize=3, color=ENGINE_COLORS.get(engine, "k"), label=engine, ms=4)
        lo, hi = s[parameter].min(), s[parameter].max()
        for label, x, y in (references or {}).get(o, []):
            keep = (np.asarray(x) >= lo) & (np.asarray(x) <= hi)  # theory only where data are
            if keep.any():
                ax.plot(np.asarray(x)[keep], np.asarray(y)[keep], "k--", lw=0.8, label=label)
        ax.set_xlabel(parameter)
        ax.set_ylabel(o)
        ax.legend(fontsize=7)
    if title:
        fig.suptitle(title, fontsize=10)
    _save(fig, out)
