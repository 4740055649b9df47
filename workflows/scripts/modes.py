"""Vibrational modes of the mechanically stable 2-D states of a study (protocol
``jammed``, pysim runs): the Hessian of each final packing with its stiffness and stress
parts (:mod:`analysis.modes`), written as a per-state summary and a per-mode table, and
drawn as the density of states, the participation ratio and the rotational fraction
against frequency. Each stable state is also compressed up an energy ladder
(``--energies``; ``<table>.energies.csv``, one row per rung): there the band frequencies
(``omega_below_gap``, ``omega_low``, ``omega_middle``) are those of the stable state's
bands followed by rank (:func:`analysis.modes.band_means`), since the gaps narrow and
move, while the counts (``modes_above_gap``, ``mode_fraction_*``) are each rung's own
gaps'.

Each final state is read at full precision (``stable_state.npz``; older runs only have
the 10-digit final frame, which unbalances forces of 1e-8 by some 1 % and can open the
shallowest contacts), relaxed again at its box with pysim
(:func:`pysim.protocols.jammed.relax`, to a minimum of the energy; little to do for a
settled state) and rattlers are removed by science.md's 2-D rule
before the Hessian is built. Units: ``k_n = 1``, density 1 per area, smallest
diameter 1.
"""
from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np
import pandas as pd

from analysis import modes as am
from analysis.contacts import end_bond_counts, remove_rattlers_2d
from analysis.frame import Contacts, Frame
from analysis.io import RunData
from rodcase.case import load_case

#: |omega^2| below this fraction of the largest counts as a zero mode (rounding leaves
#: the translations near 1e-16 of it; the softest stress-stabilised rod modes lie near 1e-9)
ZERO = 1e-12

#: how close to its ``U/L^2`` a rung of the energy ladder must come (relative)
RUNG_RTOL = 0.25


class NotJammed(ValueError):
    """A state that, relaxed again, has no rigid backbone left: no modes to take."""


def _frame_contacts(sim, step: int) -> tuple[Frame, Contacts]:
    s = sim.state
    ids = np.arange(1, s.n + 1)
    frame = Frame.from_arrays(s.x, s.radius, s.box, axis=s.u, length=s.length,
                              periodic=s.periodic, ids=ids, step=step, dimension=2)
    ij, rec = sim.contact_table()
    contacts = Contacts(step, ids[ij[:, 0]], ids[ij[:, 1]], rec[:, 0:3], rec[:, 3:6],
                        rec[:, 6], rec[:, 7:10])
    return frame, contacts


def _zero(w2: np.ndarray, top: float) -> np.ndarray:
    return np.abs(w2) < ZERO * top


#: how the dynamical matrix weighs the degrees of freedom: the paper's coordinates
#: ``(x, y, A theta)`` with no masses (Marschall & Teitel 2018, Eq. 23), or the masses
#: and moments of inertia
METRICS = ("paper", "mass")


def load_stable_state(run_dir: Path):
    """``(case, sim, step, exact)`` of the final state of a 2-D harmonic ``jammed`` pysim
    run, not yet relaxed again: from ``stable_state.npz`` at full precision where the run
    kept it (``exact``), else from the 10-digit final frame."""
    from pysim import checkpoint
    from pysim.protocols import jammed
    from pysim.protocols.compress import simulation_from_case

    case = load_case(run_dir.parent / "case.yaml")
    if case["particles"].get("dimension", 3) != 2 or case["protocol"]["name"] != "jammed":
        raise ValueError(f"{run_dir}: modes are computed for 2-D 'jammed' runs, got "
                         f"dimension {case['particles'].get('dimension', 3)}, protocol "
                         f"{case['protocol']['name']!r}")
    if case["contact"]["law"] != "harmonic":
        raise ValueError(f"{run_dir}: modes need the harmonic law, got "
                         f"{case['contact']['law']!r}")
    exact = run_dir / jammed.STABLE_STATE
    if exact.exists():
        sim = checkpoint.load(exact)[0]
        return case, sim, sim.state.step, True
    # runs before the full-precision state was kept: the 10-digit final frame
    frame, _ = RunData(run_dir).frames()[-1]
    init = {"x": frame.x, "box": frame.box.copy(), "box_lo": frame.box_lo,
            "axis": frame.axis, "radius": frame.radius, "length": frame.length}
    return case, simulation_from_case(case, init, check_dt=False), frame.step, False


def _relax(sim, case) -> None:
    from pysim.protocols import jammed

    d_min = float(2 * sim.state.radius.min())
    jammed.relax(sim, case["protocol"]["force_tol"] * case["contact"]["k_n"] / d_min,
                 case["protocol"]["max_relax"])


def stable_state_modes(run_dir: Path, metric: str = "paper") -> tuple[pd.DataFrame, dict]:
    """Modes of the final frame of a ``jammed`` pysim run, relaxed again at its box
    (:func:`modes_of`)."""
    case, sim, step, exact = load_stable_state(run_dir)
    _relax(sim, case)
    table, summary = modes_of(sim, case, step, metric)
    return table, {**summary, "exact": exact}


def compressed_state(run_dir: Path, target: float, rtol: float = RUNG_RTOL, tries: int = 8):
    """The stable state of ``run_dir`` compressed affinely above jamming and relaxed,
    until its ``U/L^2`` lies within ``rtol`` of ``target``: ``(case, sim, step)``. Each
    trial starts again from the stable state (one basin); the strains follow by the
    secant rule on ``sqrt(U)``, linear in ``phi - phi_J`` for the harmonic law.
    ``ValueError`` after ``tries`` trials."""
    from pysim.protocols import jammed

    def trial(strain):  # strain: relative increase of phi
        case, sim, step, _ = load_stable_state(run_dir)
        if strain > 0:
            sim.rescale_box((1.0 + strain) ** (-1.0 / sim.state.dimension))
        _relax(sim, case)
        return case, sim, step, jammed.energy_density(sim, float(2 * sim.state.radius.min()))

    start = trial(0.0)
    if abs(start[3] / target - 1.0) <= rtol:
        return start[:3]
    points = [(0.0, np.sqrt(start[3]))]
    strain, energy = 1e-6, None
    for _ in range(tries):
        case, sim, step, energy = trial(strain)
        if abs(energy / target - 1.0) <= rtol:
            return case, sim, step
        points.append((strain, np.sqrt(energy)))
        (s_a, r_a), (s_b, r_b) = points[-2], points[-1]
        slope = (r_b - r_a) / (s_b - s_a)
        nxt = s_b + (np.sqrt(target) - r_b) / slope if slope > 0 else 10.0 * s_b
        strain = nxt if nxt > 0 else 0.1 * s_b
    raise ValueError(f"{run_dir}: no compression reached U/L^2 = {target:g} within "
                     f"{rtol:.0%} in {tries} tries (last {energy:.3g})")


def modes_of(sim, case: dict, step: int, metric: str = "paper") -> tuple[pd.DataFrame, dict]:
    """Modes of a relaxed 2-D packing: a per-mode table (``omega``, ``omega2``, ``pr``,
    the rotational / parallel / perpendicular fractions, and ``omega_k`` of the stiffness
    part alone; each ascending) and a summary (particles and degrees of freedom of the
    backbone, contact pairs, zero modes of ``H`` and of ``H_k``, negative modes of ``H``,
    the backbone's ``bonds`` (a side contact twice,
    :func:`analysis.contacts.end_bond_counts`) beside the ``modes_above_gap`` (above the
    widest gap of the spectrum: the paper finds one per bond at jamming) and the mean
    frequency below it (``omega_below_gap``), the fractions of all modes in the three
    bands split at the two widest gaps (``mode_fraction_low``, ``_middle``, ``_high``:
    the paper's bands at alpha >= 1) and the mean frequencies of the lower two
    (``omega_low``, ``omega_middle``), the largest stress-part entry relative to the
    stiffness part's, ``U/L^2``, ``phi`` and the residuals). ``metric`` is one of
    :data:`METRICS`."""
    if metric not in METRICS:
        raise ValueError(f"metric {metric!r} is not one of {', '.join(METRICS)}")
    from pysim.protocols import jammed

    state = sim.state
    d_min = float(2 * state.radius.min())
    k_n = case["contact"]["k_n"]
    res = jammed.residuals(sim)
    fr, ct = _frame_contacts(sim, step)
    keep = ~remove_rattlers_2d(fr, ct)
    a, b = fr.index_of(ct.i), fr.index_of(ct.j)
    pairs = np.column_stack([a, b])[keep[a] & keep[b]]
    dof = am.dofs(fr, keep)
    if len(dof) == 0:
        raise NotJammed(f"the relaxed packing at step {step} has no rigid backbone (every "
                        "particle a rattler): it was not jammed")
    spine = case["contact"].get("spine_contact", "closest")
    end_bonds = spine != "closest" and bool(np.any(fr.length > 0))
    hk, hs, _ = am.hessian_parts(fr, pairs, dof, k_n=k_n, end_bonds=end_bonds,
                                 distinct=spine == "end_bonds_distinct")
    if metric == "paper":
        weights = am.dof_lengths(0.5 * state.length, dof)
    else:
        weights = am.dof_masses(state.mass, state.inertia[:, 0], dof)
    w2, vecs = am.normal_modes(hk + hs, weights)
    wk2, _ = am.normal_modes(hk, weights)
    table = pd.DataFrame(am.mode_table(w2, vecs, dof, fr.axis))
    table["omega_k"] = np.sign(wk2) * np.sqrt(np.abs(wk2))
    top = float(np.abs(w2).max())
    backbone = keep[a] & keep[b]
    bonds = (end_bond_counts(fr, ct.subset(backbone)).sum() if end_bonds
             else int(backbone.sum()))
    two = am.bands(w2, 2, ZERO * top)
    # the paper's lowest band at alpha >= 1 lies below the eigensolver's resolution
    three = am.bands(w2, 3, ZERO * top, floor=True)
    translations = int(np.sum(fr.periodic[:2]))
    summary = {"n_particles": int(keep.sum()), "n_dof": len(dof), "n_pairs": len(pairs),
               "zero_modes": int(_zero(w2, top).sum()),
               "zero_modes_stiffness": int(_zero(wk2, top).sum()),
               "negative_modes": int(np.sum(w2 < -ZERO * top)),
               # the paper's count: N z/2 modes above the gap, one per bond
               "bonds": int(bonds), "modes_above_gap": int(np.sum(two == 1)),
               "translations": translations,
               **dict(zip(BAND_FREQUENCIES,
                          band_frequencies(w2, band_sizes(w2, translations), translations))),
               **{f"mode_fraction_{name}": float(np.mean(three == k))
                  for k, name in enumerate(("low", "middle", "high"))},
               "stress_over_stiffness": float(np.abs(hs).max() / np.abs(hk).max()),
               "energy_density": jammed.energy_density(sim, d_min),
               "phi": state.packing_fraction(), "metric": metric, **res}
    return table, summary


#: U/L^2 of the states above jamming for the scaling of the band frequencies and for
#: ``phi - phi_J``, beside the stable state's: the paper's for alpha = 0.01 (Fig. 14). Its
#: alpha = 4 rungs (1e-11, 1e-9; Fig. 18) cost long rods a relaxation of tens of minutes
#: each (``--energies``, or ``analysis.modes_energies`` of a study)
ENERGIES = (1e-14, 1e-12)

#: the stable states' U/L^2 (the paper's U_0, that of the ``jammed`` protocol): a stable
#: state within :data:`RUNG_RTOL` of it reports ``phi_minus_phi_j_u1e15`` without a
#: compression
STABLE_ENERGY = 1e-15


#: the band frequencies of a state's row, in the order of :func:`band_sizes`
BAND_FREQUENCIES = ("omega_below_gap", "omega_low", "omega_middle")


def band_sizes(omega2: np.ndarray, translations: int) -> list[int]:
    """Sizes of a stable state's bands, the ``translations`` left out, to follow up its
    energy ladder by rank: the modes below the widest gap (those below the resolution
    with them), then the low band of the three-band split (the modes below the
    resolution) and its middle band."""
    zero = ZERO * float(np.abs(omega2).max())
    two, three = am.bands(omega2, 2, zero), am.bands(omega2, 3, zero, floor=True)
    floor = int(np.sum(omega2 <= zero)) - translations
    return [floor + int((two == 0).sum()), floor, int((three == 1).sum())]


def band_frequencies(omega2: np.ndarray, sizes, translations: int) -> list[float]:
    """Mean frequencies of the bands of :func:`band_sizes` in a state's spectrum
    (:func:`analysis.modes.band_means`; NaN for a band mostly below the resolution):
    below the gap, low, middle."""
    zero = ZERO * float(np.abs(omega2).max())
    return [*am.band_means(omega2, sizes[:1], zero, translations),
            *am.band_means(omega2, sizes[1:], zero, translations)]


def _write_csv(df: pd.DataFrame, path: Path, **kw) -> None:
    """``df`` to ``path`` through a temporary file beside it (never half written)."""
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(path.name + ".tmp")
    df.to_csv(tmp, index=False, **kw)
    tmp.replace(path)


def frequency_exponents(energies, means: np.ndarray) -> dict:
    """Exponents ``x`` of ``omega_band ~ (U/L^2)^x`` by least squares in log-log over a
    stable state and its compressions: ``energies`` (one per state) and ``means`` (state
    by band: below the widest gap, then the low and middle bands of the three-band split,
    each followed by its size in the stable state, :func:`analysis.modes.band_means`):
    ``omega_below_gap_exponent``, ``omega_low_exponent``, ``omega_middle_exponent``.
    States where a band has no measured mean (NaN) are left out of its fit; with fewer
    than two left the exponent is NaN."""
    log_u = np.log(np.asarray(energies, float))
    out = {}
    for k, name in enumerate(BAND_FREQUENCIES):
        ok = np.isfinite(means[:, k]) & (means[:, k] > 0)
        out[f"{name}_exponent"] = (float(np.polyfit(log_u[ok], np.log(means[ok, k]), 1)[0])
                                   if ok.sum() >= 2 else np.nan)
    return out


#: the ladder's rungs up to this ``U/L^2`` fix ``phi_J`` (:func:`distance_to_jamming`); the
#: paper's own ``phi - phi_J`` at 1e-9 (alpha = 4) already lies off ``U ~ (phi - phi_J)^2``
LINEAR_UP_TO = 1e-12


def distance_to_jamming(energies, phis) -> np.ndarray:
    """``phi - phi_J`` of each state of an energy ladder, with ``phi_J`` where the
    least-squares line ``sqrt(U/L^2) = c (phi - phi_J)`` through the states with
    ``U/L^2 <= LINEAR_UP_TO`` (the two of lowest energy if fewer lie there) meets zero
    (harmonic law: ``U ~ (phi - phi_J)^2``). All NaN with fewer than two states or
    no spread in their ``phi``."""
    u, phi = np.asarray(energies, float), np.asarray(phis, float)
    ok = u <= LINEAR_UP_TO
    if ok.sum() < 2:
        ok = np.isin(np.arange(len(u)), np.argsort(u)[:2])
    if ok.sum() < 2 or np.ptp(phi[ok]) == 0:
        return np.full(len(phi), np.nan)
    c, b = np.polyfit(phi[ok], np.sqrt(u[ok]), 1)
    return phi + b / c


def energy_tag(u: float) -> str:
    """``1e-15`` -> ``u1e15``: the suffix of a ladder rung's ``phi_minus_phi_j_<tag>``."""
    mantissa, exponent = f"{u:.0e}".split("e")
    return f"u{mantissa}e{-int(exponent)}"


def plot_modes(tables: dict, out: Path, ladder: dict | None = None) -> None:
    """Panels against frequency, one line per variant (seeds pooled): the density of
    states of ``H`` (solid) and of its stiffness part alone (dashed; zero modes fall
    outside), the mean participation ratio and the mean rotational fraction per
    frequency bin; with ``ladder`` (variant -> per-mode tables of the stable state and
    its compressions, one per rung, seeds pooled) a fourth panel: the density of states as ``U/L^2``
    grows (the paper's Figs. 14a, 18a)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    ladder = {v: rungs for v, rungs in (ladder or {}).items() if rungs}
    fig, ax = plt.subplots(1, 4 if ladder else 3, figsize=(18.5 if ladder else 14, 4.2))
    # zero modes (translations, rods sliding between two flat contacts) are left out
    top = max(float(t.omega.abs().max()) for t in tables.values())
    positive = np.concatenate([t.omega[t.omega > np.sqrt(ZERO) * top]
                               for t in tables.values()])
    lo, hi = positive.min(), positive.max()
    bins = np.logspace(np.log10(lo), np.log10(hi), 40)
    mid = np.sqrt(bins[1:] * bins[:-1])
    cmap = plt.get_cmap("viridis")
    for k, (label, t) in enumerate(tables.items()):
        colour = cmap(k / max(1, len(tables) - 1))
        w = t.omega.to_numpy()
        for col, style in (("omega", ".-"), ("omega_k", "--")):
            hist, _ = np.histogram(t[col].to_numpy(), bins=bins)
            hist = hist / (len(t) * np.diff(bins))  # per mode, zero modes included
            hist = np.where(hist > 0, hist, np.nan)  # gaps in the spectrum stay gaps
            ax[0].plot(mid, hist, style, color=colour, label=label if col == "omega" else None)
        which = np.digitize(w, bins) - 1
        ok = (which >= 0) & (which < len(mid))
        for panel, col in ((1, "pr"), (2, "rotational")):
            mean = pd.Series(t[col].to_numpy()[ok]).groupby(which[ok]).mean()
            mean = mean.reindex(range(len(mid)))  # empty bins: NaN, a break in the line
            ax[panel].plot(mid, mean.to_numpy(), ".-", color=colour, label=label)
    ax[0].set(xscale="log", yscale="log", xlabel=r"$\omega$", ylabel=r"$D(\omega)$",
              title="density of states (dashed: stiffness part alone)")
    ax[1].set(xscale="log", xlabel=r"$\omega$", ylabel="participation ratio",
              title="participation ratio")
    ax[2].set(xscale="log", xlabel=r"$\omega$", ylabel="rotational fraction", ylim=(0, 1),
              title="rotational character")
    ax[0].legend(fontsize=7)
    styles = ("--", ":", "-.")
    for k, label in enumerate(tables):
        if label not in ladder:
            continue
        colour = cmap(k / max(1, len(tables) - 1))
        for r, rung in enumerate(ladder[label]):
            hist, _ = np.histogram(rung.omega.to_numpy(), bins=bins)
            hist = np.where(hist > 0, hist / (len(rung) * np.diff(bins)), np.nan)
            u = float(np.median(rung.energy_density))
            ax[3].plot(mid, hist, "-" if r == 0 else styles[(r - 1) % 3], color=colour,
                       label=f"{label}, U/L$^2$ = {u:.1e}")
    if ladder:
        ax[3].set(xscale="log", yscale="log", xlabel=r"$\omega$", ylabel=r"$D(\omega)$",
                  title="density of states as U grows")
        ax[3].legend(fontsize=6)
    fig.tight_layout()
    out.parent.mkdir(parents=True, exist_ok=True)
    tmp = out.with_name(out.stem + ".tmp.png")
    fig.savefig(tmp, dpi=120)
    plt.close(fig)
    tmp.replace(out)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--runs", nargs="+", type=Path, required=True,
                    help="pysim run directories <study>/<variant>/seed<k>/pysim of 'jammed' runs")
    ap.add_argument("--out", type=Path, required=True, help="figure (.png)")
    ap.add_argument("--table", type=Path, required=True,
                    help="per-state summary (.csv); the per-mode table of every state, "
                         "its compressions included, goes beside it (.modes.csv.gz)")
    ap.add_argument("--metric", choices=METRICS, default="paper",
                    help="dynamical matrix: the paper's Hessian in (x, y, A theta) "
                         "(default) or mass-weighted")
    ap.add_argument("--energies", nargs="*", type=float, default=list(ENERGIES),
                    help="U/L^2 of states compressed above each stable state, for the "
                         "scaling of the band frequencies (default %(default)s; none to skip)")
    a = ap.parse_args(argv)
    from tqdm import tqdm

    rows, per_mode, tables, ladder, rungs = [], [], {}, [], {}
    for run in tqdm(a.runs, desc="modes", unit="state"):
        record = json.loads((run / "run.json").read_text())
        if record.get("status") != "ok" or not record.get("converged", False):
            # an unconverged state is no stable state: its modes would mislead
            sys.stderr.write(f"modes: skipping {run} (status {record.get('status')}, "
                             f"converged {record.get('converged')})\n")
            continue
        try:
            table, summary = stable_state_modes(run, a.metric)
        except NotJammed as err:  # relaxed further, the state came apart
            sys.stderr.write(f"modes: skipping {run}: {err}\n")
            continue
        variant, seed = run.parent.parent.name, run.parent.name
        steps, states = [summary], [table]
        for target in a.energies:
            case, sim, step = compressed_state(run, target)
            above, row = modes_of(sim, case, step, a.metric)
            steps.append(row)
            states.append(above)
        # up the ladder the gaps narrow and move: every rung's band frequencies follow
        # the stable state's bands by rank, one definition for the table and the fit
        sizes = band_sizes(table.omega2.to_numpy(), summary["translations"])
        for t, r in zip(states, steps):
            r.update(zip(BAND_FREQUENCIES, band_frequencies(t.omega2.to_numpy(), sizes,
                                                            summary["translations"])))
        distance = distance_to_jamming([r["energy_density"] for r in steps],
                                       [r["phi"] for r in steps])
        stable = (STABLE_ENERGY
                  if abs(summary["energy_density"] / STABLE_ENERGY - 1) <= RUNG_RTOL else None)
        for target, r, d in zip([stable, *a.energies], steps, distance):
            r["phi_minus_phi_j"] = float(d)
            if target is not None:  # the rung is at this U/L^2 (within RUNG_RTOL)
                summary[f"phi_minus_phi_j_{energy_tag(target)}"] = float(d)
        if len(steps) > 2:
            summary.update(frequency_exponents(
                [r["energy_density"] for r in steps],
                np.array([[r[name] for name in BAND_FREQUENCIES] for r in steps])))
        ladder += [{"variant": variant, "seed": seed, **r} for r in steps]
        for k, (t, r) in enumerate(zip(states, steps)):
            t = t.assign(variant=variant, seed=seed, energy_density=r["energy_density"])
            per_mode.append(t)
            rungs.setdefault(variant, {}).setdefault(k, []).append(t)  # seeds pooled
        rows.append({"variant": variant, "seed": seed, **summary})
        tables.setdefault(variant, []).append(table)
    if not rows:
        raise SystemExit(f"no finished run among {len(a.runs)} to take modes of")
    _write_csv(pd.DataFrame(rows), a.table)
    _write_csv(pd.DataFrame(ladder), a.table.with_name(a.table.stem + ".energies.csv"))
    _write_csv(pd.concat(per_mode), a.table.with_name(a.table.stem + ".modes.csv.gz"),
               compression="gzip")

    def by_value(variant: str) -> tuple:  # alpha0.5 before alpha1, not after alpha0.25
        digits = "".join(ch for ch in variant if ch.isdigit() or ch == ".")
        try:
            return (0, float(digits), variant)
        except ValueError:
            return (1, 0.0, variant)

    # the density of states up the energy ladder: rung k of every seed pooled
    ladder_tables = {v: [pd.concat(by_rung[k]) for k in sorted(by_rung)]
                     for v, by_rung in rungs.items() if len(by_rung) > 1}
    plot_modes({v: pd.concat(tables[v]) for v in sorted(tables, key=by_value)}, a.out,
               ladder_tables)
    return 0


if __name__ == "__main__":
    sys.exit(main())
