"""Observables of one compression run, as tidy rows, the same for every engine.

``analyse_compression`` reads a run directory in the common format and returns

* observables: ``phi_j`` (with its fit error), ``jamming_slope`` (``dp/dphi`` of the
  fit), ``z_j`` (rattler-free contact number at ``phi_J``, extrapolated from the frames
  just above it: :func:`z_at_jamming`), ``z_j_with_rattlers``, ``rattler_fraction_j``,
  ``phi_at_z_j`` (``phi_J``, or the frame's packing fraction where only one frame could
  be used), ``z_j_frames``, ``phi_final``, ``pressure_final``;
* curves: per output frame, ``phi``, contact ``pressure`` (from the contact table),
  ``z``, ``z_rattler_free``, ``n_rattlers`` and the thermo ``p(phi)``.

:func:`problems` words what a reader of the numbers must know: NaN observables, frames
whose rattler removal empties the packing.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd

from analysis.contacts import ContactNumber
from analysis.io import RunData
from analysis.jamming import JammingFitError, JammingPoint
from analysis.order import NematicOrder
from analysis.packing import packing_fraction
from analysis.stress import pressure

TIDY_COLUMNS = ["study", "case", "engine", "seed", "observable", "value", "uncertainty"]
#: columns per horizontal axis over which a deposit's slab stresses spread, for their
#: standard errors (:func:`analysis.stress.slab_stress_errors`): 4 in 2-D, 2 x 2 in 3-D
STRESS_COLUMNS = {2: 4, 3: 2}


def frame_curves(run: RunData, c_min: int | None = None, friction: float = 0.0,
                 caging: bool = False) -> pd.DataFrame:
    """Per output frame: ``phi``, contact ``pressure`` (from the contact table), ``z``,
    ``z_rattler_free``, ``z_bonds`` (2-D: parallel side contacts twice), ``n_rattlers``,
    and for rods the nematic order ``s_nematic`` (3-D) or ``sqrt(N) S_2``, ``sqrt(N) S_4``
    (2-D). Rattlers follow the rule for the frame and the packing's ``friction``
    (:class:`analysis.contacts.ContactNumber`, ``c_min`` overrides it); the rule in words
    is ``attrs["rattler_rule"]``; ``attrs["rods"]``: whether any frame holds a rod.

    ``caging``: also ``noncaged_fraction``, the fraction of particles whose contacts in
    the frame do not cage them (:class:`analysis.cages.CagedParticles`; about 0.3 s per
    frame of 2048 jammed particles)."""
    from analysis.cages import CagedParticles

    rows = []
    rule = ""
    rods = False
    for frame, contacts in run.frames():
        rods = rods or bool(np.any(frame.length > 0))
        counter = ContactNumber(c_min, friction=friction)
        rule = counter.describe(frame)
        cn = counter.compute(frame, contacts)
        row = {"step": frame.step, "phi": packing_fraction(frame),
               "pressure": pressure(frame, contacts, dim=frame.dim), "z": cn.z,
               "z_rattler_free": cn.z_rattler_free, "z_bonds": cn.z_bonds,
               "n_rattlers": cn.n_rattlers, "n": frame.n, "s_nematic": np.nan,
               "sqrt_n_s2": np.nan, "sqrt_n_s4": np.nan}
        if np.any(frame.length > 0):
            if frame.dim == 2:
                from analysis.order import OrientationOrder2D

                o2 = OrientationOrder2D().compute(frame)
                row["sqrt_n_s2"], row["sqrt_n_s4"] = o2.sqrtN_S2, o2.sqrtN_S4
            else:
                row["s_nematic"] = NematicOrder().compute(frame).S
        if caging:
            row["noncaged_fraction"] = CagedParticles().compute(frame, contacts).noncaged_fraction
        rows.append(row)
    curves = pd.DataFrame(rows)
    curves.attrs["rattler_rule"] = rule
    curves.attrs["rods"] = rods
    return curves


def pc_table(run: RunData, phis=None) -> pd.DataFrame:
    """Contact-number distributions ``P(C)`` of a run's frames (Wouterse, Luding &
    Philipse, Fig. 3; :func:`analysis.contacts.contact_number_distribution`: every
    touching partner, rattlers included, walls not): a table with columns ``step``,
    ``phi``, ``c``, ``fraction`` (``c = 0 .. max C`` of each frame), ready for a
    ``pc.csv``. Every frame, or with ``phis`` the frame nearest in ``phi`` to each of
    them (each frame once, in the order of ``phis``)."""
    from analysis.contacts import contact_number_distribution

    frames = run.frames()
    columns = ["step", "phi", "c", "fraction"]
    if not frames:
        return pd.DataFrame(columns=columns)
    phi = np.array([packing_fraction(f) for f, _c in frames])
    if phis is None:
        pick = list(range(len(frames)))
    else:
        pick = []
        for target in np.atleast_1d(np.asarray(phis, dtype=float)):
            k = int(np.argmin(np.abs(phi - target)))
            if k not in pick:
                pick.append(k)
    parts = []
    for k in pick:
        frame, contacts = frames[k]
        dist = contact_number_distribution(frame, contacts)
        parts.append(pd.DataFrame({"step": frame.step, "phi": phi[k],
                                   "c": np.arange(len(dist)), "fraction": dist}))
    return pd.concat(parts, ignore_index=True)[columns]


#: frames above the jamming point whose contact numbers are extrapolated to it
#: (:func:`z_at_jamming`): the fewest that give the line an error
JAMMED_FRAMES = 3
#: observables read at the jamming point of a compression (:func:`z_at_jamming`)
JAMMED_NAMES = ("z_j", "z_j_bonds", "z_j_with_rattlers", "rattler_fraction_j", "phi_at_z_j",
                "s_nematic_j", "z_j_frames")


def z_at_jamming(curves: pd.DataFrame, phi_j: float, p_max: float) -> dict:
    """Contact numbers of a compression at its jamming point ``phi_J`` (the ``p -> 0``
    limit), from its frames (:func:`frame_curves`): ``{name: (value, uncertainty)}`` for
    :data:`JAMMED_NAMES`.

    The frames used are the first :data:`JAMMED_FRAMES` at or above ``phi_J`` that keep a
    rattler-free backbone and whose contact pressure is at most ``p_max`` (the top of the
    jamming-fit window: the first rise, where ``phi_J`` was fitted), and at least the
    first two such frames (a local line: further up, ``z(phi)`` bends).
    From two or more, ``z_j``, ``z_j_bonds``, ``z_j_with_rattlers`` and
    ``rattler_fraction_j`` are the least-squares line through them in ``phi`` at
    ``phi_J``, as ``phi_J`` is the line ``p(phi)`` of the same rise at ``p = 0`` (with the
    standard error of the intercept from three frames on; the fraction clipped to
    [0, 1]); ``phi_at_z_j = phi_J``. With one frame, that frame's values at its own
    ``phi_at_z_j``; with none, NaN. ``s_nematic_j``, which every frame has, is
    interpolated linearly at ``phi_J``; the contact number with rattlers is not, since it
    jumps at ``phi_J`` (a frame just below holds the flowing packing's few contacts).
    ``z_j_frames``: the frames used. Below ``phi_J`` the packing flows: the limit is
    taken from above. (The first frame above ``phi_J`` that keeps a
    backbone, read as it is, may lie far above jamming and overstate ``z_J``:
    docs/analysis.md.)
    """
    nan = (np.nan, np.nan)
    out = {name: nan for name in JAMMED_NAMES}
    if not np.isfinite(phi_j) or not len(curves):
        return out
    c = curves.sort_values("phi", kind="stable")
    v = c["s_nematic"].to_numpy(dtype=float)
    ok = np.isfinite(v)
    if ok.any() and c.phi[ok].min() <= phi_j <= c.phi[ok].max():
        out["s_nematic_j"] = (float(np.interp(phi_j, c.phi[ok], v[ok])), np.nan)
    above = c[(c.phi >= phi_j) & (c.n_rattlers < c.n)]
    use = above[above.pressure <= p_max].iloc[:JAMMED_FRAMES]
    if len(use) < 2:
        use = above.iloc[:2]
    out["z_j_frames"] = (float(len(use)), np.nan)
    if len(use) == 0:
        return out
    if len(use) == 1:
        first = use.iloc[0]
        out.update(z_j=(float(first.z_rattler_free), np.nan),
                   z_j_bonds=(float(first.z_bonds), np.nan),
                   z_j_with_rattlers=(float(first.z), np.nan),
                   rattler_fraction_j=(float(first.n_rattlers / first.n), np.nan),
                   phi_at_z_j=(float(first.phi), np.nan))
        return out
    dphi = use.phi.to_numpy() - phi_j
    for name, col in (("z_j", "z_rattler_free"), ("z_j_bonds", "z_bonds"),
                      ("z_j_with_rattlers", "z")):
        out[name] = _intercept(dphi, use[col].to_numpy(dtype=float))
    frac = use.n_rattlers.to_numpy() / use.n.to_numpy()
    out["rattler_fraction_j"] = (float(np.clip(_intercept(dphi, frac)[0], 0.0, 1.0)), np.nan)
    out["phi_at_z_j"] = (float(phi_j), np.nan)
    return out


def _intercept(x: np.ndarray, y: np.ndarray) -> tuple[float, float]:
    """``a`` of the least-squares line ``y = a + b x`` and its standard error (NaN from
    fewer than three points)."""
    design = np.column_stack([np.ones_like(x), x])
    coef, *_ = np.linalg.lstsq(design, y, rcond=None)
    if len(x) < 3:
        return float(coef[0]), np.nan
    resid = y - design @ coef
    cov = np.linalg.pinv(design.T @ design) * float(resid @ resid) / (len(x) - 2)
    return float(coef[0]), float(np.sqrt(cov[0, 0]))


def problems(rows, curves: pd.DataFrame | None = None) -> list[str]:
    """One-line warnings a reader of a run's observables must see: the observables that
    are NaN (the nematic order and the jump of ``<C>`` of spheres, which have none,
    aside), and the frames at or
    above the jamming point (all frames when there is none) in which every grain is a
    rattler (the rule, ``curves.attrs["rattler_rule"]``, removed the whole packing)."""
    values = {name: v for name, v, _err in rows}
    out = []
    no_rods = (curves is not None and "s_nematic" in curves
               and not np.isfinite(curves["s_nematic"].to_numpy(dtype=float)).any())
    # spheres have no jump of <C> (frame_curves marks runs without rods)
    spheres = curves is not None and curves.attrs.get("rods") is False
    bad = [name for name, v in values.items() if isinstance(v, (int, float, np.floating))
           and not np.isfinite(v) and not (no_rods and name.startswith("s_nematic"))
           and not (spheres and name in ("c_mean_before_jump", "phi_before_jump"))]
    if bad:
        out.append(f"observable{'s' if len(bad) > 1 else ''} {', '.join(bad)} "
                   f"{'are' if len(bad) > 1 else 'is'} NaN")
    if curves is None or not {"n_rattlers", "n", "phi"} <= set(curves.columns) or not len(curves):
        return out
    phi_j = values.get("phi_j", np.nan)
    at = curves[curves.phi >= phi_j] if np.isfinite(phi_j) else curves
    where = f"at or above phi_j = {phi_j:.4g}" if np.isfinite(phi_j) else "of the run"
    empty = at[(at.n_rattlers >= at.n) & (at.n > 0)]
    if len(empty):
        rule = curves.attrs.get("rattler_rule") or "the rattler rule"
        out.append(f"every grain is a rattler ({rule}) in {len(empty)} of the {len(at)} frames "
                   f"{where} (phi {empty.phi.min():.4g} to {empty.phi.max():.4g}); set "
                   "analysis.c_min in the study's configuration if the rule does not fit "
                   "these grains")
    return out


def analyse_compression(run_dir, window, p_scale: float, c_min: int | None = None,
                        fit_from: float | None = None, friction: float = 0.0):
    """Observables ``[(name, value, uncertainty)]`` and per-frame curves of one
    compression run.

    ``window`` is the jamming-fit pressure window in units of ``p_scale`` (``k_n/D``);
    ``c_min`` overrides the rattler rule (default: the rule for the frame and the
    packing's ``friction``, :func:`analysis.contacts.default_c_min`);
    ``fit_from``: only thermo rows from the first with ``phi >= fit_from`` on are fitted
    (the slow stage of a two-stage compression: the fast stage's transient pressure is
    not a jamming rise). The contact numbers at jamming: :func:`z_at_jamming`.
    """
    run = RunData(run_dir)
    thermo = run.thermo
    rows = []
    curves = frame_curves(run, c_min, friction)
    first = 0
    if fit_from is not None:
        reached = np.flatnonzero(thermo.phi.to_numpy() >= fit_from)
        first = int(reached[0]) if len(reached) else len(thermo)
    try:
        jp = JammingPoint(window, p_scale).compute(thermo.phi.to_numpy()[first:],
                                                   thermo.pressure.to_numpy()[first:])
        phi_j, phi_j_err, slope = jp.phi_j, jp.phi_j_err, jp.slope
        fit = {"rows": (first + jp.rows.start, first + jp.rows.stop)}
    except JammingFitError as exc:
        phi_j, phi_j_err, slope, fit = np.nan, np.nan, np.nan, {"error": str(exc)}
    rows += [("phi_j", phi_j, phi_j_err), ("jamming_slope", slope, np.nan)]
    at_j = z_at_jamming(curves, phi_j, window[1] * p_scale)
    rows += [(name, *at_j[name]) for name in JAMMED_NAMES]
    last = thermo.iloc[-1]
    rows += [("phi_final", float(last.phi), np.nan), ("pressure_final", float(last.pressure), np.nan)]
    curves.attrs["fit"] = fit
    return rows, curves, thermo


def analyse_hard(run_dir, c_min: int | None = None):
    """Observables of a hard-sphere run (pysim's ``ls``, ``fb`` and ``mls`` protocols,
    Baranau & Tallarek 2014).

    ``phi`` (the density the compression reached) and, after the closest-jamming search,
    ``phi_j`` come from ``run.json``; ``reduced_pressure`` is the last block's ``Z``;
    ``collisions_per_particle`` the run's work. With ``phi_j``, the last frame's near
    contacts (gaps below the run's ``contact_gap``) give ``z_j`` (rattler-free: fewer
    than ``c_min`` contacts, 4 by default, removed until none is left), ``z_j_with_rattlers``
    and ``rattler_fraction_j``. Curves: the block table (:func:`analysis.io.read_blocks`).
    """
    import json

    from analysis.io import read_blocks

    run = RunData(run_dir)
    rec = json.loads((Path(run_dir) / "run.json").read_text())
    blocks = read_blocks(Path(run_dir) / "blocks.dat")
    z_last = float(blocks["reduced_pressure"].iloc[-1]) if len(blocks) else np.nan
    rows = [("phi", float(rec["phi"]), np.nan), ("reduced_pressure", z_last, np.nan),
            ("collisions_per_particle", float(rec["collisions_per_particle"]), np.nan)]
    if "phi_j" in rec:
        frame, contacts = run.frames()[-1]
        cn = ContactNumber(c_min).compute(frame, contacts)
        rows += [("phi_j", float(rec["phi_j"]), np.nan), ("z_j", cn.z_rattler_free, np.nan),
                 ("z_j_with_rattlers", cn.z, np.nan),
                 ("rattler_fraction_j", cn.n_rattlers / frame.n, np.nan),
                 ("mls_rate_decreases", float(rec.get("mls_rate_decreases", np.nan)), np.nan)]
    return rows, blocks


def analyse_growth(run_dir, c_min: int | None = None, friction: float = 0.0):
    """Observables and curves of a growth-to-jamming run (pysim's ``cycles.dat``).

    ``phi_j`` is the first jammed packing fraction of the bisection and its uncertainty
    the distance to the last unjammed one; ``z_j`` etc. are those of the jammed relaxed
    packing at ``phi_j``, ``residual_j`` its largest force over the mean contact force
    when the relaxation stopped, and ``settled_j`` 1 when that relaxation ended at a
    minimum, 0 when it ran out of rounds with the energy still falling (a jammed decision
    without proof; NaN for older runs, whose files lack the column: docs/formats.md).
    Curves: every output frame, with ``relaxed`` and ``jammed`` flags for the frames of
    the relax/increment cycles and the ``noncaged_fraction`` of each frame
    (:func:`frame_curves`; the contact-number distributions of chosen frames:
    :func:`pc_table`).

    Along the growing packing (Wouterse, Luding & Philipse, Figs. 2 and 6; the frames of
    :func:`analysis.growth.growing_frames`): ``c_mean_before_jump`` and
    ``phi_before_jump``, the mean contact number ``z`` (rattlers included) where its
    sharp rise towards the jammed value starts and the packing fraction there
    (:func:`analysis.growth.jump_onset`; NaN for spheres, which have no jump, and where
    no rise of 2 contacts is found), and ``noncaged_fraction_j``, the fraction of
    non-caged particles of the jammed packing at ``phi_j``.
    """
    from analysis.growth import growing_frames, jump_onset

    run = RunData(run_dir)
    thermo = run.thermo
    cycles = pd.read_csv(Path(run_dir) / "cycles.dat", sep=r"\s+", comment="#", header=None,
                         names=["step", "phi", "e", "p", "nc", "jammed", "iterations",
                                "residual", "settled"])  # older files lack the last three
    curves = frame_curves(run, c_min, friction, caging=True)
    curves["relaxed"] = curves.step.isin(cycles.step)
    curves["jammed"] = curves.step.isin(cycles.step[cycles.jammed == 1])
    jam = cycles[cycles.jammed == 1]
    free = cycles[cycles.jammed == 0]
    rows = []
    if len(jam) and len(free):
        hi = jam.loc[jam.phi.idxmin()]
        lo = free.phi.max()
        rows.append(("phi_j", float(hi.phi), float(hi.phi - lo)))
        first = curves[curves.step == hi.step].iloc[0]
        rows += [("z_j", first.z_rattler_free, np.nan), ("z_j_bonds", first.z_bonds, np.nan),
                 ("z_j_with_rattlers", first.z, np.nan),
                 ("rattler_fraction_j", first.n_rattlers / first.n, np.nan),
                 ("phi_at_z_j", first.phi, np.nan), ("s_nematic_j", first.s_nematic, np.nan),
                 ("residual_j", float(hi.residual), np.nan),
                 ("settled_j", float(hi.settled), np.nan)]
    else:
        rows += [(k, np.nan, np.nan) for k in ("phi_j", "z_j", "z_j_bonds", "z_j_with_rattlers",
                                               "rattler_fraction_j", "phi_at_z_j", "s_nematic_j",
                                               "residual_j", "settled_j")]
    rows += [("relax_cycles", float(len(cycles)), np.nan)]
    at_j = curves[curves.step == hi.step] if len(jam) and len(free) else curves.iloc[0:0]
    rows.append(("noncaged_fraction_j",
                 float(at_j.noncaged_fraction.iloc[0]) if len(at_j) else np.nan, np.nan))
    growing = growing_frames(curves)
    rods = curves.attrs["rods"]
    phi_b, c_b = jump_onset(growing.phi, growing.z) if rods else (np.nan, np.nan)
    rows += [("c_mean_before_jump", c_b, np.nan), ("phi_before_jump", phi_b, np.nan)]
    return rows, curves, thermo

def tidy(rows, study, case, engine, seed, parameters: dict | None = None) -> pd.DataFrame:
    """Tidy table of observables with one column per varying case parameter."""
    df = pd.DataFrame(rows, columns=["observable", "value", "uncertainty"])
    df.insert(0, "seed", seed)
    df.insert(0, "engine", engine)
    df.insert(0, "case", case)
    df.insert(0, "study", study)
    for k, v in (parameters or {}).items():
        df[k] = v
    return df


def analyse_jammed(run_dir, c_min: int | None = None, friction: float = 0.0):
    """Observables of a mechanically stable packing (pysim's ``jammed`` protocol).

    ``phi_j`` comes from ``jammed.json``; the residual forces and torques of the
    rattler-free backbone (means and maxima, relative to the mean contact force and
    torque; ``torque_residual_split`` with the forces of kinked parallel side contacts
    placed along their overlap, :mod:`analysis.balance`) from the last contact table;
    ``z_j`` (rattler-free, each
    contact once: ``z_tilde``), ``z_j_bonds`` (2-D parallel side contacts counted twice),
    the fractions of tip-tip, tip-side and side-side contacts, the fraction of rods with
    a contact on a flat side (``flat_side_contact_fraction``; ``_backbone``: of the
    rattler-free rods), and the orientational
    order ``s2``, ``s4`` (2-D) or ``s_nematic`` (3-D) of the final frame. ``converged``
    is the record's own verdict (``jammed.json``, ``docs/formats.md``).
    """
    import json

    from analysis.balance import ForceBalance
    from analysis.contacts import TYPE_NAMES, ContactTypes, flat_side_contact_fraction
    from analysis.order import OrientationOrder2D

    run = RunData(run_dir)
    res = json.loads((Path(run_dir) / "jammed.json").read_text())
    frame, contacts = run.frames()[-1]
    cn = ContactNumber(c_min, friction=friction).compute(frame, contacts)
    bal = ForceBalance(c_min=c_min, friction=friction).compute(frame, contacts)
    rows = [("phi_j", res["phi_j"], np.nan), ("energy_density", res["energy_density"], np.nan),
            ("z_j", cn.z_rattler_free, np.nan), ("z_j_bonds", cn.z_bonds, np.nan),
            ("z_j_with_rattlers", cn.z, np.nan),
            ("rattler_fraction_j", cn.n_rattlers / frame.n, np.nan),
            ("force_residual", bal.force_mean, np.nan),
            ("force_residual_max", bal.force_max, np.nan),
            ("torque_residual", bal.torque_mean, np.nan),
            ("torque_residual_max", bal.torque_max, np.nan),
            ("torque_residual_split", bal.torque_split_mean, np.nan),
            ("torque_residual_split_max", bal.torque_split_max, np.nan),
            ("kink_contacts", float(bal.n_kink), np.nan),
            ("bisections", float(res["bisections"]), np.nan),
            ("converged", float(res["converged"]), np.nan)]
    if np.any(frame.length > 0):
        types = ContactTypes().compute(frame, contacts)
        rows += [(f"fraction_{k.replace('-', '_')}", float(v), np.nan)
                 for k, v in zip(TYPE_NAMES, types.fractions)]
        rows += [("flat_side_contact_fraction",
                  flat_side_contact_fraction(frame, contacts), np.nan),
                 ("flat_side_contact_fraction_backbone",
                  flat_side_contact_fraction(frame, contacts, ~cn.rattlers), np.nan)]
        if frame.dim == 2:
            order = OrientationOrder2D().compute(frame)
            rows += [("s2", order.S2, np.nan), ("s4", order.S4, np.nan),
                     ("sqrt_n_s2", order.sqrtN_S2, np.nan), ("sqrt_n_s4", order.sqrtN_S4, np.nan)]
        else:
            rows.append(("s_nematic", NematicOrder().compute(frame).S, np.nan))
    curves = frame_curves(run, c_min, friction)
    return rows, curves, run.thermo


def tap_curves(run: RunData, start_step: int | None, dt: float, period: float,
               amplitude: float, frames_per_tap: int, container_diameter: float,
               layer_thickness: float, n_layers: int = 4) -> pd.DataFrame:
    """Per frame of a tapping run: ``tap`` (periods since tapping began), ``phase``
    (index of the frame within its tap), base height ``z_base``, volumetric density
    ``phi`` of the filled part of the cylinder (grain volume between the base and the top
    surface over ``pi D_c^2 / 4`` times that height), its moving average ``phi_avg`` over
    one oscillation, the surface height ``top``, the density of Pournin et al. (2005)
    ``phi_enclosing`` (grain volume of the bed over the enclosing truncated cylinder,
    :class:`analysis.packing.EnclosingPackingFraction`) with that cylinder's height
    ``height_enclosing`` and the number of ``outliers`` it leaves out, the mean angle
    between spines and the base ``angle`` (degrees), order
    with respect to gravity ``p2_z`` and, for each of ``n_layers`` layers of
    ``layer_thickness`` stacked on the base, ``phi_layer<k>`` and ``angle_layer<k>``
    (grains assigned to layers by centre); every density and angle column also as
    ``<column>_avg``, its moving average over one oscillation. ``start_step`` ``None``:
    the tapping began at the first frame (frame 0 is the settled packing; a free
    preparation's start is known from its run only)."""
    from analysis.order import AngleToHorizontal
    from analysis.packing import (EnclosingPackingFraction, FilledPackingFraction,
                                  layer_edges, period_average, slab_packing_fraction)

    area = np.pi * container_diameter**2 / 4
    omega = 2 * np.pi / period
    rows = []
    frames = run.frames()
    if start_step is None and len(frames):
        start_step = frames[0][0].step
    for frame, _contacts in frames:
        t = (frame.step - start_step) * dt
        zb = amplitude * np.sin(omega * t) if t > 0 else 0.0
        fill = FilledPackingFraction(bottom=zb, area=area).compute(frame)
        enc = EnclosingPackingFraction(area=area).compute(frame)
        edges = layer_edges(zb, layer_thickness, n_layers)
        ang = AngleToHorizontal(layers=edges).compute(frame)
        row = {"step": frame.step, "tap": t / period,
               "phase": int(round(t / period * frames_per_tap)) % frames_per_tap,
               "z_base": zb, "phi": fill.phi, "top": fill.top,
               "phi_enclosing": enc.phi, "height_enclosing": enc.height,
               "outliers": enc.outliers, "angle": ang.mean_deg,
               "p2_z": NematicOrder().compute(frame).gravity_order, "n": len(frame.ids)}
        phil = slab_packing_fraction(frame, edges, area=area)
        for k in range(n_layers):
            row[f"phi_layer{k + 1}"] = phil[k]
            row[f"angle_layer{k + 1}"] = np.degrees(ang.layer_mean[k])
        rows.append(row)
    curves = pd.DataFrame(rows)
    for col in ["phi", "phi_enclosing", "angle"] + [f"{q}_layer{k + 1}" for k in range(n_layers)
                                                    for q in ("phi", "angle")]:
        curves[f"{col}_avg"] = (period_average(curves[col].to_numpy(), frames_per_tap)
                                if len(curves) else [])
    return curves


#: fraction of a tapping run's taps whose frames make its late-state means (the last 50 of
#: 400 taps, 12.5 of 100; never less than the last tap)
LATE_FRACTION = 1.0 / 8.0


def late_window(curves: pd.DataFrame, fraction: float = LATE_FRACTION) -> pd.DataFrame:
    """The frames of the last ``fraction`` of the taps of a tapping run (at least the
    frames of its last tap; the last frame if it has no tap), from :func:`tap_curves`."""
    taps = float(curves.tap.max())
    width = max(1.0, fraction * taps)
    late = curves[(curves.tap > taps - width + 1e-9) & (curves.tap > 0)]
    return late if len(late) else curves.iloc[-1:]


def tap_cycle(thermo: pd.DataFrame, start_step: int, dt: float, period: float,
              first_tap: float = 0.0, bins: int = 10) -> pd.DataFrame:
    """Kinetic energy and contacts over the tap cycle: the thermo rows from tap
    ``first_tap`` on, grouped by their phase ``((step - start_step) dt / T) mod 1`` into
    ``bins`` equal bins centred on the phases ``k / bins`` (round-off in the step plan
    keeps a row near its nominal phase). Returns one row per bin that holds rows:
    ``phase`` (the bin's centre, in periods; 0 is the base at rest on its way up),
    ``ke`` and ``n_contacts`` (means over the bin's rows, as the thermo table has them:
    total kinetic energy in J, contacts) and ``rows``. Thermo rows every ``s`` steps
    visit the phases ``k s dt / T mod 1`` only, so when ``s dt / T`` is a ratio of small
    integers few bins are sampled."""
    tap = (thermo.step.to_numpy() - start_step) * dt / period
    keep = tap >= first_tap
    phase = np.mod(tap[keep], 1.0)
    b = np.rint(phase * bins).astype(int) % bins
    g = pd.DataFrame({"bin": b, "ke": thermo.ke.to_numpy()[keep],
                      "n_contacts": thermo.n_contacts.to_numpy()[keep]}).groupby("bin")
    out = g.agg(ke=("ke", "mean"), n_contacts=("n_contacts", "mean"), rows=("ke", "size"))
    out.insert(0, "phase", out.index.to_numpy() / bins)
    return out.reset_index(drop=True)


#: fewest phase bins (of ten) the late thermo rows must sample for the cycle observables
MIN_CYCLE_BINS = 3


def cycle_rows(cycle: pd.DataFrame, n_grains: int) -> list[tuple[str, float, float]]:
    """Observables of :func:`tap_cycle`'s bins: ``ke_cycle`` (kinetic energy per grain
    averaged over the sampled phases, J), ``ke_cycle_peak`` (that of the most agitated
    phase), ``contacts_flight`` (mean contacts at the phase with fewest over those at the
    phase with most: 1 for a bed that never lifts, small for one that flies) and
    ``cycle_bins`` (phases sampled); all but the last ``nan`` below
    :data:`MIN_CYCLE_BINS` sampled phases."""
    ok = len(cycle) >= MIN_CYCLE_BINS and cycle.n_contacts.max() > 0
    nan = np.nan
    return [("ke_cycle", float(cycle.ke.mean() / n_grains) if ok else nan, nan),
            ("ke_cycle_peak", float(cycle.ke.max() / n_grains) if ok else nan, nan),
            ("contacts_flight",
             float(cycle.n_contacts.min() / cycle.n_contacts.max()) if ok else nan, nan),
            ("cycle_bins", float(len(cycle)), nan)]


#: tap counts at which the tapping paper states its densities and angles (and its snapshots)
TAP_MARKS = (10, 100, 300, 900, 1000, 2000, 4134)


def tap_mark_rows(curves: pd.DataFrame, fraction: float = LATE_FRACTION) -> list[tuple]:
    """The state at each tap count of :data:`TAP_MARKS` a run reaches: ``phi_tap<k>``,
    ``phi_tap<k>_enclosing`` (the density of the enclosing cylinder, where the curves have
    it), ``angle_tap<k>`` and ``angle_tap<k>_layer<j>``, means over the frames of the taps in
    ``(k (1 - fraction), k]`` (at least tap ``k``'s own frames), as :func:`late_window`
    averages the end of a run."""
    rows = []
    for k in TAP_MARKS:
        if curves.tap.max() < k - 1e-9:
            break
        w = curves[(curves.tap > k - max(1.0, fraction * k) + 1e-9) & (curves.tap <= k + 1e-9)]
        rows += [(f"phi_tap{k}", float(w.phi.mean()), np.nan),
                 (f"angle_tap{k}", float(w.angle.mean()), np.nan)]
        if "phi_enclosing" in w:
            rows.append((f"phi_tap{k}_enclosing", float(w.phi_enclosing.mean()), np.nan))
        j = 1
        while f"angle_layer{j}" in w:
            rows.append((f"angle_tap{k}_layer{j}", float(w[f"angle_layer{j}"].mean()), np.nan))
            j += 1
    return rows


def analyse_tapping(run_dir, **plan):
    """Observables and per-frame curves (:func:`tap_curves`, keyword arguments ``plan``) of
    a tapping run: ``phi_settled`` and ``angle_settled`` (the packing before the first
    tap), ``phi_tapped`` and ``angle_tapped`` (means over the frames of the last tap, with
    their standard deviation as uncertainty), the changes ``phi_gain`` and
    ``angle_gain``, ``p2_z_tapped``, ``taps`` and the tapped angle per layer; and the late
    state, ``phi_late``, ``angle_late`` (degrees), ``p2_z_late``, ``angle_late_layer<k>``
    and ``phi_late_layer<k>`` (the slab density of the layer): means over the frames of
    the last eighth of the taps (:func:`late_window`), with the standard deviation over
    those frames as the uncertainty of the first two (a spread
    over taps, not a seed-to-seed error); and how the late taps shake the bed, from the
    thermo rows of the same window (:func:`tap_cycle`, :func:`cycle_rows`); the state at
    the paper's tap counts (:func:`tap_mark_rows`). The density of Pournin et al. (2005)
    comes alongside: ``phi_settled_enclosing``, ``phi_tapped_enclosing`` and
    ``phi_late_enclosing`` (``phi_enclosing`` of :func:`tap_curves`), the enclosing
    cylinder's late height ``height_late_enclosing`` (its spread over the frames as
    uncertainty: how much the bed dilates at the frames' phase), and ``outliers_late``,
    the mean number of grains it left out over the late window.
    ``plan["start_step"]`` ``None``: tapping began at the first frame."""
    run = RunData(run_dir)
    curves = tap_curves(run, **plan)
    if not len(curves):
        raise ValueError(f"{run_dir}: no frames in particles.dump")
    first = curves.iloc[0]
    last_tap = curves[curves.tap > curves.tap.max() - 1.0 + 1e-9]
    if not len(last_tap):
        last_tap = curves.iloc[-1:]
    late = late_window(curves)
    rows = [("phi_settled", float(first.phi), np.nan),
            ("angle_settled", float(first.angle), np.nan),
            ("phi_tapped", float(last_tap.phi.mean()), float(last_tap.phi.std(ddof=0))),
            ("angle_tapped", float(last_tap.angle.mean()), float(last_tap.angle.std(ddof=0))),
            ("phi_gain", float(last_tap.phi.mean() - first.phi), np.nan),
            ("angle_gain", float(last_tap.angle.mean() - first.angle), np.nan),
            ("p2_z_tapped", float(last_tap.p2_z.mean()), np.nan),
            ("taps", float(round(curves.tap.max(), 6)), np.nan)]
    rows += [("phi_late", float(late.phi.mean()), float(late.phi.std(ddof=0))),
             ("angle_late", float(late.angle.mean()), float(late.angle.std(ddof=0))),
             ("p2_z_late", float(late.p2_z.mean()), np.nan)]
    rows += [("phi_settled_enclosing", float(first.phi_enclosing), np.nan),
             ("phi_tapped_enclosing", float(last_tap.phi_enclosing.mean()),
              float(last_tap.phi_enclosing.std(ddof=0))),
             ("phi_late_enclosing", float(late.phi_enclosing.mean()),
              float(late.phi_enclosing.std(ddof=0))),
             ("height_late_enclosing", float(late.height_enclosing.mean()),
              float(late.height_enclosing.std(ddof=0))),
             ("outliers_late", float(late.outliers.mean()), np.nan)]
    k = 1
    while f"angle_layer{k}" in curves:
        rows.append((f"angle_tapped_layer{k}", float(last_tap[f"angle_layer{k}"].mean()), np.nan))
        rows.append((f"angle_late_layer{k}", float(late[f"angle_layer{k}"].mean()), np.nan))
        if f"phi_layer{k}" in curves:  # the paper monitors the density layer by layer too
            rows.append((f"phi_late_layer{k}", float(late[f"phi_layer{k}"].mean()), np.nan))
        k += 1
    rows += tap_mark_rows(curves)
    thermo = run.thermo
    start = plan["start_step"] if plan["start_step"] is not None else int(first.step)
    cycle = tap_cycle(thermo, start, plan["dt"], plan["period"],
                      first_tap=float(late.tap.min()) - 1.0)
    rows += cycle_rows(cycle, int(curves.n.iloc[0]))
    return rows, curves, thermo


#: side of the stress elements of a deposit, in particle lengths ``L + D`` (science.md: "square
#: elements of 5 particle lengths")
STRESS_ELEMENT = 5.0
#: a deposit's ``Q(r)`` out to this many particle lengths ``L + D``, in shells of a quarter
#: of the width ``D``
ORDER_RANGE = 3.0
#: the window, in particle lengths, in which ``Q(r)`` may peak for rods touching end to end
#: (centre distance ``L + D``); the shells nearer than 1.5 widths hold only rods side by side
END_TO_END = (0.75, 1.25)


def _no_saturation(tag: str) -> list[tuple[str, float, float]]:
    """The Janssen rows of a profile without a saturation fit: NaN."""
    names = [f"sigma_m_{tag}", f"h_s_{tag}"] + (["sigma_m_trace"] if tag == "p" else [])
    return [(name, np.nan, np.nan) for name in names]


def _trace_rve(frame, contacts, prof: pd.DataFrame, edges, width: float, top: float,
               length: float) -> list[tuple[str, float, float]]:
    """The paper's Janssen fit (Hidalgo et al., Fig. 6): the trace of the mean stress in
    square elements :data:`STRESS_ELEMENT` particle lengths wide, in rows of
    :data:`STRESS_ELEMENT` slabs from the base, against the depth of the row centre over
    ``W``, weighted by the standard error over the row's elements (relative weights:
    the covariance is scaled by the reduced chi-square, which is reported, since errors
    from a few elements scatter too much to be taken at their word). Rows reaching above
    the surface (elements partly empty) or holding an element with fewer than 3 grains
    are left out. The fit is reported when it resolves the profile's curvature
    (``h_s`` to better than half of itself), even where ``h_s`` lies beyond the deepest
    point, as the paper's own fits do. Writes ``trace_rve``, ``trace_rve_err`` (at the slab
    in the middle of each row, NaN elsewhere) and ``trace_rve_fit`` into ``prof``; returns
    the rows ``sigma_m_trace_rve``, ``h_s_trace_rve`` (in ``W``), ``chi2_dof_trace_rve``
    and ``x_max_trace_rve``, the depth of the deepest point fitted (in ``W``)."""
    from analysis.janssen import JanssenFit, JanssenFitError, janssen
    from analysis.stress import element_trace

    names = ("sigma_m_trace_rve", "h_s_trace_rve", "chi2_dof_trace_rve", "x_max_trace_rve")
    per = int(STRESS_ELEMENT)  # slabs of one particle length per row of elements
    columns = max(int(round(width / (STRESS_ELEMENT * length))), 1)
    row_edges = np.asarray(edges)[::per]
    for col in ("trace_rve", "trace_rve_err", "trace_rve_fit"):
        prof[col] = np.nan
    if len(row_edges) < 2:
        return [(name, np.nan, np.nan) for name in names]
    trace, count = element_trace(frame, contacts, row_edges, 0.0, width, columns)
    mean = trace.mean(axis=1)
    err = (trace.std(axis=1, ddof=1) / np.sqrt(columns) if columns > 1
           else np.full(len(mean), np.nan))
    use = (row_edges[1:] <= top) & (count.min(axis=1) >= 3)
    middle = per * np.arange(len(mean)) + per // 2  # the slab at each row's centre
    use &= middle < len(prof)
    at = middle[use]
    prof.loc[at, "trace_rve"] = mean[use]
    prof.loc[at, "trace_rve_err"] = err[use]
    weights = prof.loc[at, "trace_rve_err"] if columns > 1 else None
    try:
        # a few elements per row make noisy errors: weights only, the covariance scaled
        fit = JanssenFit(form="saturation", width=width, absolute_errors=False).compute(
            prof.loc[at, "depth"], prof.loc[at, "trace_rve"], weights)
    except (JanssenFitError, RuntimeError):
        return [(name, np.nan, np.nan) for name in names]
    x_max = float(prof.loc[at, "x"].max())
    # The paper's own fit runs past its data (h_s / W = 2.2 where 6000 rods of d = 10 fill
    # 1.47 / phi widths), so the fit stands when its curvature 1 / h_s is resolved: more
    # than two standard errors from a straight profile, which fixes only sigma_m / h_s.
    if not (fit.h_s > 0 and np.isfinite(fit.h_s_err) and fit.h_s_err < 0.5 * fit.h_s):
        return [(name, np.nan, np.nan) for name in names[:-1]] + [
            ("x_max_trace_rve", x_max, np.nan)]
    prof["trace_rve_fit"] = janssen(prof["x"].clip(lower=0.0), fit.sigma_m, fit.h_s)
    return [("sigma_m_trace_rve", float(fit.sigma_m), float(fit.sigma_m_err)),
            ("h_s_trace_rve", float(fit.h_s), float(fit.h_s_err)),
            ("chi2_dof_trace_rve", float(fit.chi2 / max(fit.dof, 1)), np.nan),
            ("x_max_trace_rve", x_max, np.nan)]


def analyse_deposit(run_dir, width: float, gravity: float, slab: float, density: float = 1.0,
                    base_wall_id: int | None = None):
    """Observables of a settled deposit in a box of ``width`` ``W`` (the last frame):

    * ``phi_deposit``: packing fraction of the filled part (grain measure below the top
      surface over ``W^(d-1)`` times the height);
    * ``angle_mean`` (degrees), ``flat_fraction`` (spines within 15 degrees of the
      horizontal), ``standing_fraction`` (within 15 degrees of the vertical) and
      ``orientation_mode`` (the most probable angle to the horizontal, degrees: the centre
      of the fullest 5-degree bin, :func:`analysis.order.orientation_mode`);
    * ``phi_profile_change``: rise of the slab packing fraction from the base to the top
      (a straight line over the middle 80 % of the height,
      :func:`analysis.packing.profile_change`), and ``phi_profile_uniform``, 1 when it is
      within :data:`analysis.packing.UNIFORM_PROFILE`, else 0;
    * the radial orientation correlation ``Q(r)`` (:data:`ORDER_RANGE`):
      ``q_r_length_peak``, where it peaks (in widths ``D``) within :data:`END_TO_END`
      particle lengths, NaN without a peak there (:func:`analysis.order.correlation_peak`),
      and ``q_r_peak_amplitude``, its highest maximum above its deepest minimum beyond
      1.5 widths (:func:`analysis.order.correlation_amplitude`);
    * Janssen saturation fits ``sigma(x) = sigma_m (1 - exp(-x / h_s))``, ``x = depth /
      W``, of the vertical stress and of the pressure in slabs of thickness ``slab``
      (compressive positive; fits over slabs with at least 3 grains and a nonzero
      spread over columns, not the loose top slab): ``sigma_m_vv``, ``h_s_vv`` with
      standard errors as uncertainties and ``chi2_dof_vv``, the reduced chi-square of a
      fit weighted by the slab stresses' standard errors (their spread over
      :data:`STRESS_COLUMNS` columns of the container,
      :func:`analysis.stress.slab_stress_errors`), and ``sigma_m_p``, ``h_s_p``
      (unweighted), and ``sigma_m_trace = d sigma_m_p``, the saturation value of the
      trace of the mean stress (the quantity a 2-D paper may fit); ``janssen_saturated``
      1 when the fitted ``h_s`` lies within the depth of the data, else 0 and the fit
      values NaN (a straight profile fixes only the slope ``sigma_m / h_s``);
    * ``k_ratio``: ``sigma_hh / sigma_vv`` averaged over the lower half of the deposit;
    * ``major_order``: how vertical the major principal stress axes are in square (cubic)
      elements of :data:`STRESS_ELEMENT` particle lengths holding 3 grains or more
      (:func:`analysis.stress.major_axis_order`: 1 all vertical, 0 spread uniformly, the
      isotropic distribution of directions), and ``major_order_particles``, the same
      over each grain's own stress tensor (the paper's Fig. 5);
    * the paper's Janssen fit of the trace of the mean stress in elements
      :data:`STRESS_ELEMENT` lengths square (its Fig. 6), ``sigma_m_trace_rve``,
      ``h_s_trace_rve`` and ``chi2_dof_trace_rve`` (``_trace_rve``);
    * ``apparent_mass_fraction``: vertical force on the base over the deposit's weight
      (1 without wall friction; Janssen: below 1; grain ``density`` per volume, per area
      in 2-D), when ``base_wall_id`` names the base's rows in the contact table;
      ``side_wall_fraction``: the upward force of the side walls (every other wall row)
      on the grains over the weight (Janssen: above 0; negative when the walls' friction
      holds the grains down); ``wall_balance``: base and side walls together over the
      weight, 1 for a deposit at rest (below or above 1 by what the grains' last
      accelerations leave unbalanced).

    Returns ``(rows, profile)``: rows ``(observable, value, uncertainty)`` and a table of
    the slab profile (``depth``, ``x``, ``phi``, ``sigma_vv``, ``sigma_hh``, ``pressure``,
    ``count``, ``sigma_vv_err``, ``sigma_hh_err``, the fitted curves, and the Janssen
    apparent mass of every engine: ``mass_above``, the grain mass above the slab centre,
    and ``apparent_mass`` = ``sigma_vv W^(d-1) / g``, the part of it the grains below
    carry; equal without wall friction, saturating with depth when the walls hold
    weight).
    """
    from analysis.janssen import JanssenFit, JanssenFitError, janssen
    from analysis.order import (UPRIGHT_WITHIN, AngleToHorizontal, OrientationCorrelation,
                                correlation_amplitude, correlation_peak, orientation_mode,
                                standing_fraction)
    from analysis.packing import (UNIFORM_PROFILE, FilledPackingFraction, cumulative_measure,
                                  profile_change, slab_packing_fraction)
    from analysis.stress import (StressField, StressProfile, major_axis_order,
                                 particle_major_angles, slab_stress_errors)

    run = RunData(run_dir)
    frames = run.frames()
    if not frames:
        raise ValueError(f"{run_dir}: no frames in particles.dump")
    frame, contacts = frames[-1]
    d, v = frame.dim, frame.vertical
    area = width ** (d - 1)
    fill = FilledPackingFraction(bottom=0.0, area=area).compute(frame)
    ang = AngleToHorizontal().compute(frame)
    k = max(int(np.floor(fill.top / slab)), 1)
    edges = slab * np.arange(k + 1)
    sp = StressProfile(edges=edges, top=fill.top, area=area).compute(frame, contacts)
    phi_slab = slab_packing_fraction(frame, edges, area=area)
    prof = pd.DataFrame({"depth": sp.depth, "x": sp.depth / width, "phi": phi_slab,
                         "sigma_vv": -sp.sigma_vv, "sigma_hh": -sp.sigma_hh,
                         "pressure": sp.pressure, "count": sp.count})
    total = float(np.sum(frame.particle_measures()))
    prof["mass_above"] = density * (total - cumulative_measure(frame, sp.centers))
    prof["apparent_mass"] = prof["sigma_vv"] * area / gravity
    vv_err, hh_err = slab_stress_errors(frame, contacts, edges, 0.0, width,
                                        STRESS_COLUMNS[d])
    prof["sigma_vv_err"], prof["sigma_hh_err"] = vv_err, hh_err
    use = (prof["count"] >= 3) & (prof["depth"] > 0.5 * slab) & (prof["sigma_vv_err"] > 0)
    rows = [("phi_deposit", float(fill.phi), np.nan),
            ("height", float(fill.height), np.nan),
            ("angle_mean", float(ang.mean_deg), np.nan),
            ("flat_fraction", float(np.mean(ang.angles < np.radians(UPRIGHT_WITHIN))), np.nan),
            ("standing_fraction", standing_fraction(ang.angles), np.nan),
            ("orientation_mode", orientation_mode(ang.angles), np.nan)]
    change = profile_change(sp.centers, phi_slab, fill.top)
    rows += [("phi_profile_change", change, np.nan),
             ("phi_profile_uniform",
              float(abs(change) <= UNIFORM_PROFILE) if np.isfinite(change) else np.nan, np.nan)]
    for col, tag in (("sigma_vv", "vv"), ("pressure", "p")):
        err = prof.loc[use, "sigma_vv_err"] if tag == "vv" else None
        try:
            fit = JanssenFit(form="saturation", width=width).compute(
                prof.loc[use, "depth"], prof.loc[use, col], err)
        except (JanssenFitError, RuntimeError):
            rows += _no_saturation(tag)
            prof[f"{col}_fit"] = np.nan
            continue
        x_max = float(prof.loc[use, "x"].max())
        saturated = fit.h_s < x_max  # the profile bends within the data
        if tag == "vv":
            rows.append(("janssen_saturated", float(saturated), np.nan))
        if not saturated:
            # a straight profile: sigma_m and h_s grow without bound together; only their
            # ratio (the slope) is determined, so no saturation values are reported
            rows += _no_saturation(tag)
            prof[f"{col}_fit"] = np.nan
            continue
        rows += [(f"sigma_m_{tag}", float(fit.sigma_m), float(fit.sigma_m_err)),
                 (f"h_s_{tag}", float(fit.h_s), float(fit.h_s_err))]
        if tag == "p":  # the trace is d times the pressure, so its fit scales the same
            rows.append(("sigma_m_trace", d * float(fit.sigma_m), d * float(fit.sigma_m_err)))
        if tag == "vv":
            rows.append(("chi2_dof_vv", float(fit.chi2 / max(fit.dof, 1)), np.nan))
        prof[f"{col}_fit"] = janssen(prof["x"].clip(lower=0.0), fit.sigma_m, fit.h_s)
    lower = use & (prof["depth"] > 0.5 * fill.height)
    with np.errstate(invalid="ignore", divide="ignore"):
        kr = (prof.loc[lower, "sigma_hh"] / prof.loc[lower, "sigma_vv"]).to_numpy()
    rows.append(("k_ratio", float(np.nanmean(kr)) if np.isfinite(kr).any() else np.nan, np.nan))
    length = float(np.mean(frame.length + 2.0 * frame.radius))  # particle length L + D
    width_d = 2.0 * float(np.mean(frame.radius))
    corr = OrientationCorrelation(ORDER_RANGE * length,
                                  bins=max(int(round(4 * ORDER_RANGE * length / width_d)), 1)
                                  ).compute(frame)
    r = corr.centers / width_d
    end = [e * length / width_d for e in END_TO_END]
    rows += [("q_r_length_peak", correlation_peak(r, corr.q, *end, corr.q_err), np.nan),
             ("q_r_peak_amplitude",
              correlation_amplitude(r, corr.q, 1.5, ORDER_RANGE * length / width_d), np.nan)]
    field = StressField(STRESS_ELEMENT * length, min_count=3).compute(frame, contacts)
    rows.append(("major_order", field.major_order, np.nan))
    rows.append(("major_order_particles",
                 major_axis_order(particle_major_angles(frame, contacts), d), np.nan))
    rows += _trace_rve(frame, contacts, prof, edges, width, fill.top, length)
    if base_wall_id is not None:
        on_base = contacts.j == base_wall_id
        f_up = float(np.sum(contacts.force[on_base, v]))  # force on the grains from the base
        weight = density * float(np.sum(frame.particle_measures())) * gravity
        ok = on_base.any() and weight > 0  # tables without wall rows (LAMMPS) say nothing
        on_sides = (contacts.j < 0) & ~on_base
        f_sides = float(np.sum(contacts.force[on_sides, v]))
        rows += [("apparent_mass_fraction", f_up / weight if ok else np.nan, np.nan),
                 ("side_wall_fraction", f_sides / weight if ok else np.nan, np.nan),
                 ("wall_balance", (f_up + f_sides) / weight if ok else np.nan, np.nan)]
    return rows, prof


def settled_window(frame, margins, floor: float = 0.0) -> tuple[float, float, float]:
    """Bulk window ``(lo, hi, top)`` of a bed settled on a floor at height ``floor``:
    ``lo = floor + margins[0] l``, ``hi = top - margins[1] l``, with ``l`` the largest
    particle length ``L + D`` and ``top`` the free surface (the mean over columns of side
    ``l`` of the highest grain surface, :func:`analysis.packing.surface_height`). Raises
    ValueError when the bed is too thin for the margins."""
    from analysis.packing import surface_height

    margins = [float(m) for m in margins]
    if len(margins) != 2 or min(margins) < 0:
        raise ValueError(f"margins must be two numbers >= 0 (particle lengths above the floor "
                         f"and below the surface), got {margins}")
    ell = float(np.max(frame.length + 2.0 * frame.radius))
    top = surface_height(frame)
    lo, hi = floor + margins[0] * ell, top - margins[1] * ell
    if not hi > lo:
        raise ValueError(f"a bed {top - floor:.4g} high (particle length {ell:.4g}) leaves no bulk "
                         f"between {margins[0]} lengths above the floor and {margins[1]} below "
                         "the surface: settle more particles or use smaller margins")
    return lo, hi, top


def settled_contact_numbers(frame, pairs, fixed, lo: float, hi: float, c_min: int):
    """Contact numbers of the particles whose centre lies in the layer ``[lo, hi)`` of a
    settled bed, rattlers removed inside the layer only: contacts with particles outside
    it count like wall contacts and are never removed (see :func:`analyse_settled`).
    ``pairs`` ``(a, b, contacts)``: row indices of the particle-particle contacts and the
    whole table; ``fixed`` (N,) wall contacts. Returns ``(inside, rattlers, c_all,
    c_free)``: masks (N,), and per particle every contact and the rattler-free ones."""
    from analysis.contacts import contact_counts, remove_rattlers

    a, b, _contacts = pairs
    v = frame.vertical
    inside = (frame.x[:, v] >= lo) & (frame.x[:, v] < hi)
    both = inside[a] & inside[b]
    held = (fixed + np.bincount(a[inside[a] & ~inside[b]], minlength=frame.n)
            + np.bincount(b[inside[b] & ~inside[a]], minlength=frame.n))
    ratt = remove_rattlers(frame.n, a[both], b[both], c_min, held) & inside
    keep = both & ~(ratt[a] | ratt[b])
    c_all = contact_counts(frame.n, a, b) + fixed
    c_free = contact_counts(frame.n, a[keep], b[keep]) + held
    return inside, ratt, c_all, c_free


def settled_pairs(frame, contacts):
    """``(pairs, fixed)`` of :func:`settled_contact_numbers` from a frame's contact table
    (wall rows split off)."""
    from analysis.walls import split_wall_contacts

    pp, walls = split_wall_contacts(frame, contacts)
    pairs = (frame.index_of(pp.i), frame.index_of(pp.j), contacts)
    return pairs, np.bincount(frame.index_of(walls.i), minlength=frame.n)


def _settled_layer(frame, pairs, fixed, lo: float, hi: float, c_min: int) -> dict:
    """Observables of the particles whose centre lies in ``[lo, hi)`` (one row); rattlers
    are removed inside the layer only (:func:`settled_contact_numbers`)."""
    from analysis.packing import slab_packing_fraction
    from analysis.stress import StressProfile

    contacts = pairs[2]
    inside, ratt, c_all, c_free = settled_contact_numbers(frame, pairs, fixed, lo, hi, c_min)
    backbone = inside & ~ratt
    order = NematicOrder().compute(frame.subset(inside)) if inside.any() else None
    stress = StressProfile(edges=[lo, hi]).compute(frame, contacts)
    return {"phi": float(slab_packing_fraction(frame, [lo, hi])[0]),
            "pressure": float(stress.pressure[0]),
            "sigma_vv": float(-stress.sigma_vv[0]), "sigma_hh": float(-stress.sigma_hh[0]),
            "z": float(np.mean(c_all[inside])) if inside.any() else np.nan,
            "z_rattler_free": float(np.mean(c_free[backbone])) if backbone.any() else np.nan,
            "n_rattlers": int(np.count_nonzero(ratt)), "n": int(inside.sum()),
            "s_nematic": order.S if order is not None else np.nan,
            "p2_z": order.gravity_order if order is not None else np.nan}


def analyse_settled(run_dir, margins, floor: float = 0.0, c_min: int | None = None,
                    friction: float = 0.0):
    """Observables of a jammed bed settled under gravity (LIGGGHTS' substitute for the
    compression of rods, ``inputs/liggghts/in.rods.settle``), from its last frame, in the
    bulk window of :func:`settled_window` (``margins`` in particle lengths above the floor
    at ``floor`` and below the free surface):

    * ``phi_j``: packing fraction of the window (exact grain volume between its planes
      over ``A (hi - lo)``); uncertainty: the standard error of the packing fractions of
      the window's slabs one particle length thick;
    * ``z_j``: mean rattler-free contact number of the non-rattlers whose centre lies in
      the window. Rattlers (the threshold rule of :class:`analysis.contacts.ContactNumber`,
      ``c_min`` as there: 6 for 3-D rods) are removed iteratively *inside the window
      only*: the particles outside it are held fixed, their contacts with the window's
      particles count and never disappear (as wall contacts). Over the whole bed the rule
      would start at the free surface, whose rods are held by gravity rather than by six
      contacts, and strip the bed layer by layer (measured: every rod of a 60-rod bed with
      8 contacts per rod on average). ``z_j_with_rattlers`` (every particle in the
      window, every contact), ``rattler_fraction_j``;
    * ``pressure_bulk`` (contact pressure of the window, particle-centre weighting) and
      ``pressure_bulk_max`` (that of its lowest slab): how far above jamming the bulk is;
      ``sigma_ratio_bulk``: horizontal over vertical normal stress;
    * ``s_nematic_j`` and ``p2_z_j`` (order with respect to gravity, ``<P2(u_z)>``: 0
      isotropic, -1/2 all horizontal) of the window's rods; ``n_bulk`` particles in it;
      ``bulk_lo``, ``bulk_hi``, ``bed_height`` (lengths).

    Curves: one row per slab one particle length thick from the floor to the top (the
    same columns, each slab taken as its own window for the rattlers, plus ``lo``,
    ``hi``, ``depth`` below the surface and ``bulk`` = 1 for slabs inside the window), so
    that ``phi``, ``pressure`` and ``z`` over the slabs show the gravity gradient.
    """
    from analysis.contacts import default_c_min

    run = RunData(run_dir)
    frames = run.frames()
    if not frames:
        raise ValueError(f"{run_dir}: no frames in particles.dump")
    frame, contacts = frames[-1]
    lo, hi, top = settled_window(frame, margins, floor)
    ell = float(np.max(frame.length + 2.0 * frame.radius))
    pairs, fixed = settled_pairs(frame, contacts)
    c_min = default_c_min(frame, friction) if c_min is None else c_min
    bulk = _settled_layer(frame, pairs, fixed, lo, hi, c_min)
    k = max(int(np.floor((hi - lo) / ell)), 1)
    slab_edges = np.linspace(lo, hi, k + 1)
    slabs = [_settled_layer(frame, pairs, fixed, s, e, c_min)
             for s, e in zip(slab_edges[:-1], slab_edges[1:])]
    phis = np.array([s["phi"] for s in slabs])
    phi_err = float(np.std(phis, ddof=1) / np.sqrt(len(phis))) if len(phis) > 1 else np.nan
    with np.errstate(invalid="ignore", divide="ignore"):
        ratio = bulk["sigma_hh"] / bulk["sigma_vv"]
    rows = [("phi_j", bulk["phi"], phi_err),
            ("z_j", bulk["z_rattler_free"], np.nan),
            ("z_j_with_rattlers", bulk["z"], np.nan),
            ("rattler_fraction_j", bulk["n_rattlers"] / bulk["n"] if bulk["n"] else np.nan,
             np.nan),
            ("s_nematic_j", bulk["s_nematic"], np.nan), ("p2_z_j", bulk["p2_z"], np.nan),
            ("pressure_bulk", bulk["pressure"], np.nan),
            ("pressure_bulk_max", float(slabs[0]["pressure"]), np.nan),
            ("sigma_ratio_bulk", float(ratio), np.nan),
            ("n_bulk", float(bulk["n"]), np.nan), ("bulk_lo", lo, np.nan),
            ("bulk_hi", hi, np.nan), ("bed_height", top - floor, np.nan)]
    # the whole bed in slabs one particle length thick, for the profiles
    edges = floor + ell * np.arange(int(np.ceil((top - floor) / ell)) + 1)
    prof = []
    for s, e in zip(edges[:-1], edges[1:]):
        row = _settled_layer(frame, pairs, fixed, s, e, c_min)
        row.update(step=frame.step, lo=s, hi=e, depth=top - 0.5 * (s + e),
                   bulk=int(s >= lo - 1e-9 and e <= hi + 1e-9))
        prof.append(row)
    return rows, pd.DataFrame(prof), run.thermo
