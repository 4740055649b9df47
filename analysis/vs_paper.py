"""Published values against our runs: the matching behind ``vs_paper.csv``.

A reference row (``references/*.csv``, format in ``references/README.md``) names a point
of a paper by its parameters (``alpha``, ``d``, ``sigma``, ``e_n``, ``Gamma``, ``bo_g``,
``layer``) and the conditions under which the paper's value holds (``tap``, ``n`` and the
``conditions`` list). Our runs are described in the same terms by a table with one row per
``(study, case, engine, seed)`` (built from each run's case by the pipeline). For every
reference row and engine:

* ``not run``: no run of the study family at the row's parameters reports the observable;
* ``conditions differ: <which>``: such runs exist, none under the paper's conditions (the
  closest run's differing conditions are named, ours against the paper's);
* ``agrees`` / ``differs``: runs under the paper's conditions, pooled over seeds. With
  ``d = ours - paper`` and ``u = sqrt(u_paper^2 + u_ours^2)`` (``u_ours`` the standard
  error of the seed mean), a ``band`` row agrees when ``|d| <= u_paper + 2 u_ours`` and
  every other row when ``|d| <= 2 u``;
* values fitted across aspect ratios (:data:`FITS`: the small-alpha fit of the contact
  number) are fitted to the runs' seed means at the row's ``over`` aspect ratios (``not
  run`` while one lacks) and judged like a value row, with the fit's standard error as
  ours; ``unresolved`` when that error exceeds the size of the fitted quantity;
* trend rows (``expect`` increasing, decreasing or constant along ``over``): ``agrees``
  when every step moves as stated by more than two combined standard errors (constant:
  no two points differ by more), ``differs`` when a step moves against it by more than
  that, ``unresolved`` when the seeds cannot tell.

A condition the run table has no column for is listed as unchecked in the ``note``; it
neither passes nor fails a row.
"""
from __future__ import annotations

import itertools
import math
import re
from pathlib import Path

import numpy as np
import pandas as pd

#: the parameters that say which point of a paper a row is
POINT = ("alpha", "d", "sigma", "e_n", "Gamma", "bo_g")
#: conditions with a column of their own in the reference table
CONDITION_COLUMNS = ("tap", "n")
REFERENCE_COLUMNS = ["id", "paper", "where", "study", "kind", "observable", *POINT, "layer",
                     *CONDITION_COLUMNS, "value", "uncertainty", "uncertainty_kind",
                     "conditions", "vary", "over", "expect", "claim"]
KINDS = ("value", "trend")
#: what a trend may run along: a parameter (across runs), the layer or the tap (along one
#: run: the observable ``<name>_layer<k>``, or ``<name>_tap<k>`` for a ``*_late`` name)
VARY = POINT + ("layer", "tap", "n")
UNCERTAINTY_KINDS = ("stated", "figure", "digits", "band")
EXPECTS = ("increasing", "decreasing", "constant")
#: how each observable was counted, in the conditions' terms (the papers say how theirs was)
OBSERVABLE_CONDITIONS = {
    "z_j": {"rattlers": "removed", "side_contacts": "one"},
    "z_j_bonds": {"rattlers": "removed", "side_contacts": "two_bonds"},
    "z_j_with_rattlers": {"rattlers": "counted", "side_contacts": "one"},
    # the vibrational modes (workflows/scripts/modes.py): the backbone's Hessian, a side
    # contact as two end bonds
    **{name: {"rattlers": "removed", "side_contacts": "two_bonds"} for name in (
        "mode_fraction_low", "mode_fraction_middle", "mode_fraction_high",
        "omega_below_gap_exponent", "omega_low_exponent", "omega_middle_exponent")},
}
#: the hard-sphere packings' characteristic densities (analysis.closest_jamming): every
#: sphere is in the density, rattlers included, as Baranau & Tallarek count it
OBSERVABLE_CONDITIONS.update({name: {"rattlers": "counted"} for name in (
    "phi_lt", "phi_rcp", "phi_gcp", "phi_gcp_minus_rcp", "phi_min_fast", "phi_max_fast_ls",
    "phi_max_fast_fb", "phi_gcp_ls_initial", "phi_gcp_ls_densified", "phi_gcp_fb_initial",
    "phi_gcp_fb_densified")})
#: observables whose ``summary.csv`` uncertainty is a standard error (a fit's, or of a mean
#: over packings), used as ours where a single row stands for many runs
STANDARD_ERROR_OBSERVABLES = ("phi_gcp", "phi_gcp_minus_rcp", "phi_gcp_ls_initial",
                              "phi_gcp_ls_densified", "phi_gcp_fb_initial",
                              "phi_gcp_fb_densified", "phi_mean_fast_ls", "phi_mean_fast_fb",
                              "caging_number", "caging_number_max")
OUTPUT_COLUMNS = ["id", "paper", "where", "study", "kind", "engine", "observable", *POINT,
                  "layer", *CONDITION_COLUMNS, "paper_value", "paper_uncertainty",
                  "uncertainty_kind", "ours", "ours_uncertainty", "n_seeds", "diff_sigma",
                  "verdict", "runs", "note", "claim"]
_COND_RE = re.compile(r"^\s*([A-Za-z_][A-Za-z0-9_]*)\s*(<=|>=|=)\s*(\S.*?)\s*$")
#: relative tolerance when a run's parameter or condition is compared with a paper's number
RTOL = 1e-3


class ReferenceError(ValueError):
    """A reference table is malformed; the message names the file, row and value."""


def parse_conditions(text) -> list[tuple[str, str, object]]:
    """``"dimension=2; rate<=1e-9"`` -> ``[("dimension", "=", 2), ("rate", "<=", 1e-9)]``
    (numbers as floats, everything else as stripped strings)."""
    if text is None or (isinstance(text, float) and math.isnan(text)) or not str(text).strip():
        return []
    out = []
    for part in str(text).split(";"):
        if not part.strip():
            continue
        m = _COND_RE.match(part)
        if not m:
            raise ReferenceError(f"condition {part.strip()!r} is not key=value, key<=value "
                                 "or key>=value")
        out.append((m.group(1), m.group(2), _number_or_text(m.group(3))))
    return out


def _number_or_text(s):
    try:
        return float(s)
    except (TypeError, ValueError):
        return str(s).strip()


def read_references(folder) -> pd.DataFrame:
    """Every ``*.csv`` of ``folder`` as one table, checked against the format of
    ``references/README.md``."""
    files = sorted(Path(folder).glob("*.csv"))
    if not files:
        raise ReferenceError(f"no reference tables (*.csv) in {folder}")
    parts = []
    for f in files:
        df = pd.read_csv(f, dtype={"conditions": str, "over": str, "claim": str, "where": str})
        missing = [c for c in REFERENCE_COLUMNS if c not in df.columns]
        if missing:
            raise ReferenceError(f"{f}: missing columns {missing}")
        df["file"] = f.name
        parts.append(df[REFERENCE_COLUMNS + ["file"]])
    refs = pd.concat(parts, ignore_index=True)
    _check(refs)
    return refs


def _check(refs: pd.DataFrame) -> None:
    dup = refs["id"][refs["id"].duplicated()]
    if len(dup):
        raise ReferenceError(f"duplicated reference id {dup.iloc[0]!r}")
    for _, r in refs.iterrows():
        where = f"{r.file}, row {r.id}"
        if r.kind not in KINDS:
            raise ReferenceError(f"{where}: kind {r.kind!r} is not one of {KINDS}")
        parse_conditions(r.conditions)
        if r.kind == "value":
            if not np.isfinite(_float(r.value)):
                raise ReferenceError(f"{where}: value {r.value!r} is not a number")
            if r.uncertainty_kind not in UNCERTAINTY_KINDS:
                raise ReferenceError(f"{where}: uncertainty_kind {r.uncertainty_kind!r} is not "
                                     f"one of {UNCERTAINTY_KINDS}")
            if not _float(r.uncertainty) >= 0:
                raise ReferenceError(f"{where}: uncertainty {r.uncertainty!r} is not a "
                                     "number >= 0")
        else:
            if r.vary not in VARY:
                raise ReferenceError(f"{where}: vary {r.vary!r} is not one of {VARY}")
            if r.expect not in EXPECTS:
                raise ReferenceError(f"{where}: expect {r.expect!r} is not one of {EXPECTS}")
            if len(_over(r)) < 2:
                raise ReferenceError(f"{where}: over {r.over!r} needs two values or more, "
                                     "';'-separated")


def _float(x) -> float:
    try:
        return float(x)
    except (TypeError, ValueError):
        return float("nan")


def _over(ref) -> list[float]:
    if not _given(ref.over):
        return []
    return [float(v) for v in str(ref.over).split(";") if v.strip()]


def _given(x) -> bool:
    return not (x is None or (isinstance(x, float) and math.isnan(x)) or
                (isinstance(x, str) and not x.strip()))


def _same(a, b) -> bool:
    if isinstance(a, (int, float, np.number)) and isinstance(b, (int, float, np.number)):
        return bool(np.isclose(float(a), float(b), rtol=RTOL, atol=0.0))
    return str(a) == str(b)


def _holds(ours, op: str, paper) -> bool:
    if not _given(ours):
        return False
    if op == "=" and isinstance(paper, str) and "|" in paper:  # any of the alternatives
        return any(_same(ours, _number_or_text(alt)) for alt in paper.split("|"))
    if op == "=":
        return _same(ours, paper)
    if not isinstance(ours, (int, float, np.number)):
        return False
    lo = float(paper) * (1 - RTOL if float(paper) > 0 else 1 + RTOL)
    hi = float(paper) * (1 + RTOL if float(paper) > 0 else 1 - RTOL)
    return float(ours) <= hi if op == "<=" else float(ours) >= lo


def observable_name(ref, layer=None, tap=None) -> str:
    """The ``summary.csv`` observable of a row: ``<observable>_layer<k>`` for a layer; at a
    tap ``k`` (the row's ``tap``, or a point of a trend along the taps) ``_late`` becomes
    ``_tap<k>``: ``angle_late`` -> ``angle_tap<k>``, ``phi_late_enclosing`` ->
    ``phi_tap<k>_enclosing``."""
    name = str(ref.observable)
    if tap is None and np.isfinite(_float(ref.tap)):
        tap = _float(ref.tap)
    if tap is not None:
        name = (name.replace("_late", f"_tap{int(tap)}", 1) if "_late" in name
                else f"{name}_tap{int(tap)}")
    layer = _float(ref.layer) if layer is None else float(layer)
    return f"{name}_layer{int(layer)}" if np.isfinite(layer) else name


def _conditions(ref) -> list[tuple[str, str, object]]:
    # a row's tap is where the value holds (observable_name takes it there): a run must
    # reach it, and may go on
    conds = [(c, ">=" if c == "tap" else "=", _float(getattr(ref, c)))
             for c in CONDITION_COLUMNS if np.isfinite(_float(getattr(ref, c)))]
    return conds + parse_conditions(ref.conditions)


def _at_point(runs: pd.DataFrame, ref, skip: str | None = None) -> pd.DataFrame:
    """The runs of the row's study family at its parameters (``skip``: one left free)."""
    sel = runs["family"] == ref.study
    for p in POINT:
        v = _float(getattr(ref, p))  # inf: the infinite rod, a point of its own
        if p == skip or np.isnan(v):
            continue
        col = pd.to_numeric(runs[p], errors="coerce") if p in runs else None
        if col is None:
            return runs.iloc[0:0]
        sel &= np.isclose(col, v, rtol=RTOL, atol=1e-12)  # NaN matches nothing
    return runs[sel]


def _differing(run: pd.Series, conds, observable: str) -> tuple[list[str], list[str]]:
    """Conditions a run fails (``"key (ours X, paper Y)"``) and those it cannot check."""
    known = {**run.to_dict(), **OBSERVABLE_CONDITIONS.get(observable.split("_layer")[0], {})}
    bad, unchecked = [], []
    for key, op, val in conds:
        if key not in known or not _given(known[key]):
            unchecked.append(key)
        elif not _holds(known[key], op, val):
            bad.append(f"{key} (ours {_fmt(known[key])}, paper {op if op != '=' else ''}"
                       f"{_fmt(val)})")
    return bad, unchecked


def unmet_conditions(terms: dict, ref) -> list[str]:
    """The conditions of reference row ``ref`` that a run with case terms ``terms``
    (:func:`workflows.vs_paper.case_terms`) fails, as ``"key (ours X, paper Y)"``."""
    return _differing(pd.Series(terms), _conditions(ref), ref.observable)[0]


def _fmt(x) -> str:
    if isinstance(x, (float, np.floating)):
        return f"{x:g}"
    return str(x)


def _stats(values: pd.Series) -> tuple[float, float, int]:
    """Seed mean, its standard error (``nan`` for one seed) and count."""
    v = values.to_numpy(dtype=float)
    v = v[np.isfinite(v)]
    n = len(v)
    if n == 0:
        return float("nan"), float("nan"), 0
    if n == 1:  # a run's own uncertainty is often a spread over frames, not an error
        return float(v[0]), float("nan"), 1
    return float(v.mean()), float(v.std(ddof=1) / math.sqrt(n)), n


def _run_stats(runs: pd.DataFrame, observable: str) -> tuple[float, float, int]:
    """:func:`_stats` of the runs' values; one run of an observable whose uncertainty is a
    standard error (:data:`STANDARD_ERROR_OBSERVABLES`) gives that as ours."""
    mean, sem, n = _stats(runs["value"])
    if n == 1 and observable in STANDARD_ERROR_OBSERVABLES:
        sem = _float(runs["uncertainty"].iloc[0])
    return mean, sem, n


#: runs pooled as seeds of one result: the same case of the same study on one engine (two
#: cases at one point of the paper differ in something the paper leaves open, friction
#: say, and are two results, never one)
SAME_RUN = ["engine", "study", "case"]


def _engine_groups(runs: pd.DataFrame, results: pd.DataFrame, observable: str,
                   by=SAME_RUN) -> dict:
    """The run rows of ``runs`` joined with their value of ``observable``, grouped by the
    columns ``by`` (keys: tuples of their values)."""
    joined = _joined(runs, results, observable)
    joined = joined[np.isfinite(joined["value"].astype(float))]
    return {k: g for k, g in joined.groupby(list(by), sort=True)}


def _joined(runs: pd.DataFrame, results: pd.DataFrame, observable: str) -> pd.DataFrame:
    """The run rows of ``runs`` with their ``value`` and ``uncertainty`` of
    ``observable`` (runs without it left out)."""
    res = results[results["observable"] == observable][
        ["study", "case", "engine", "seed", "value", "uncertainty"]]
    return runs.merge(res, on=["study", "case", "engine", "seed"], how="inner")


def _unmeasured(runs: pd.DataFrame, results: pd.DataFrame, observable: str) -> pd.DataFrame:
    """The run rows of ``runs`` whose value of ``observable`` is NaN: reported, but
    not measurable in them (a band of modes below the resolution, say)."""
    joined = _joined(runs, results, observable)
    return joined[~np.isfinite(joined["value"].astype(float))]


def _base_row(ref) -> dict:
    row = {c: getattr(ref, c) for c in ("id", "paper", "where", "study", "kind", *POINT,
                                         "layer", *CONDITION_COLUMNS, "uncertainty_kind",
                                         "claim")}
    row["observable"] = observable_name(ref)
    row["paper_value"] = _float(ref.value)
    row["paper_uncertainty"] = _float(ref.uncertainty)
    return row


def _matching(group: pd.DataFrame, conds, observable: str):
    """Split an engine's runs into those under the paper's conditions and the rest; the
    differing conditions of the closest other run, and the unchecked keys."""
    ok, worst, unchecked = [], None, set()
    for idx, run in group.iterrows():
        bad, unc = _differing(run, conds, observable)
        unchecked |= set(unc)
        if not bad:
            ok.append(idx)
        elif worst is None or len(bad) < len(worst[1]):
            worst = (idx, bad)
    return group.loc[ok], worst, sorted(unchecked)


def _runs_label(g: pd.DataFrame) -> str:
    return "; ".join(f"{s}/{c}" for s, c in sorted(set(zip(g["study"], g["case"]))))


def _value_rows(ref, runs, results) -> list[dict]:
    obs = observable_name(ref)
    base = _base_row(ref)
    at = _at_point(runs, ref)
    groups = _engine_groups(at, results, obs)
    if not groups:
        blank = _unmeasured(at, results, obs)
        if len(blank):  # the runs are back, and have no value to give (NaN)
            return [{**base, "engine": "", "verdict": "not run", "runs": _runs_label(blank),
                     "note": f"the runs report {obs} as not measured (NaN)"}]
        return [{**base, "engine": "", "verdict": "not run",
                 "note": "" if obs in set(results["observable"]) or not len(results)
                 else f"no run reports {obs}"}]
    conds = _conditions(ref)
    out = []
    for (engine, *_), g in groups.items():
        good, worst, unchecked = _matching(g, conds, obs)
        note = f"unchecked: {', '.join(unchecked)}" if unchecked else ""
        if len(good):
            use = good
        else:  # the closest run's case, for information next to the verdict
            s, c = g.loc[worst[0], "study"], g.loc[worst[0], "case"]
            use = g[(g["study"] == s) & (g["case"] == c)]
        mean, sem, n = _run_stats(use, obs)
        row = {**base, "engine": engine, "ours": mean, "ours_uncertainty": sem, "n_seeds": n,
               "runs": _runs_label(use), "note": note}
        if not len(good):
            row["verdict"] = "conditions differ: " + "; ".join(worst[1])
            out.append(row)
            continue
        p, up = base["paper_value"], base["paper_uncertainty"]
        uo = sem if np.isfinite(sem) else 0.0
        u = math.hypot(up, uo)
        d = mean - p
        row["diff_sigma"] = d / u if u > 0 else (0.0 if d == 0 else math.copysign(math.inf, d))
        if ref.uncertainty_kind == "band":
            agree = abs(d) <= up + 2.0 * uo
        else:
            agree = abs(d) <= 2.0 * u
        row["verdict"] = "agrees" if agree else "differs"
        if not np.isfinite(sem):
            row["note"] = "; ".join(x for x in (note, "one seed, no uncertainty of ours") if x)
        out.append(row)
    return out


#: values a paper fits across aspect ratios (Marschall & Teitel 2018, Fig. 8b):
#: ``z - 4 = a + b alpha^x`` over the aspect ratios of the row's ``over`` (else the four
#: smallest alpha > 0 of the runs); name -> (observable fitted, parameter reported: ``x``,
#: ``a`` or ``limit`` = ``4 + a``, the value as alpha -> 0+)
FITS = {"z_j_bonds_fit_exponent": ("z_j_bonds", "x"),
        "z_j_bonds_fit_offset": ("z_j_bonds", "a"),
        "z_j_bonds_limit_alpha0": ("z_j_bonds", "limit"),
        "z_j_fit_exponent": ("z_j", "x"),
        "z_j_fit_offset": ("z_j", "a")}
#: how many of the smallest aspect ratios the fit takes
FIT_POINTS = 4


def small_alpha_fit(alpha, z, sem=None) -> dict:
    """Fit ``z - 4 = a + b alpha^x`` (Marschall & Teitel 2018, Fig. 8b) by weighted least
    squares (``sem``: the standard errors of ``z``, or none); returns ``a``, ``b``, ``x``,
    ``limit`` (``4 + a``) with their standard errors (``u_a``, ...) from the covariance."""
    from scipy.optimize import curve_fit

    alpha, y = np.asarray(alpha, float), np.asarray(z, float) - 4.0
    sigma = None if sem is None or not np.all(np.isfinite(sem)) or np.any(np.asarray(sem) <= 0) \
        else np.asarray(sem, float)
    p, cov = curve_fit(lambda a, c, b, x: c + b * a**x, alpha, y, p0=(0.0, y.max(), 0.5),
                       sigma=sigma, absolute_sigma=sigma is not None, maxfev=20000)
    err = np.sqrt(np.clip(np.diag(cov), 0.0, np.inf))
    return {"a": p[0], "b": p[1], "x": p[2], "limit": 4.0 + p[0],
            "u_a": err[0], "u_b": err[1], "u_x": err[2], "u_limit": err[0]}


def _fit_rows(ref, runs, results) -> list[dict]:
    name = str(ref.observable)
    fitted, param = FITS[name]
    base = _base_row(ref)
    conds = _conditions(ref)
    groups = _engine_groups(_at_point(runs, ref, skip="alpha"), results, fitted,
                            by=["engine", "study"])
    over = _over(ref)  # the paper's own points: a fit over others is a different fit
    out = []
    for (engine, study), g in groups.items():
        good, worst, unchecked = _matching(g, conds, fitted)
        alphas = sorted(a for a in good["alpha"].astype(float).unique() if a > 0)
        row = {**base, "engine": engine, "runs": _runs_label(good) if len(good) else study,
               "note": f"unchecked: {', '.join(unchecked)}" if unchecked else ""}
        short, elsewise = _fit_short(alphas, over, study), None
        if short and worst is not None:  # the study's other runs make the fit: ours there
            every = sorted(a for a in g["alpha"].astype(float).unique() if a > 0)
            if not _fit_short(every, over, study):
                short, elsewise, good, alphas = "", worst[1], g, every
                row["runs"] = _runs_label(g)
        use = over if over else alphas[:FIT_POINTS]
        if short:
            row["verdict"] = "not run"
            row["note"] = "; ".join(x for x in (row["note"], short) if x)
            out.append(row)
            continue
        stats = [_stats(good.loc[np.isclose(good["alpha"].astype(float), a), "value"])
                 for a in use]
        z = [m for m, _, _ in stats]
        sem = [e for _, e, _ in stats]
        fit = small_alpha_fit(use, z, sem)
        value, u_ours = fit[param], fit[f"u_{param}"]
        up = base["paper_uncertainty"]
        u = math.hypot(up, u_ours) if np.isfinite(u_ours) else up
        d = value - base["paper_value"]
        row.update(ours=value, ours_uncertainty=u_ours, n_seeds=min(n for *_, n in stats),
                   diff_sigma=d / u if u > 0 else float("nan"),
                   verdict="agrees" if abs(d) <= 2.0 * u else "differs")
        notes = [row["note"], "fit over alpha = " + ", ".join(f"{a:g}" for a in use)]
        # a fit whose error exceeds the size of what it measures (the jump a, or x) says
        # nothing either way: not agreement
        size = abs(base["paper_value"] - (4.0 if param == "limit" else 0.0))
        if not (np.isfinite(u_ours) and u_ours <= size):
            row["verdict"] = "unresolved"
            notes.append(f"the fit does not determine {param} (standard error {u_ours:.3g} "
                         f"against a size of {size:g})")
        if elsewise:  # ours under other conditions: for information, no verdict on it
            row.update(verdict="conditions differ: " + "; ".join(elsewise),
                       diff_sigma=float("nan"))
        row["note"] = "; ".join(x for x in notes if x)
        out.append(row)
    return out or [{**base, "engine": "", "verdict": "not run",
                    "note": f"no run reports {fitted}"}]


def _fit_short(alphas, over, study) -> str:
    """Why the aspect ratios ``alphas`` (> 0) of ``study`` cannot make a fit over the row's
    ``over`` (else :data:`FIT_POINTS` of them); empty when they can."""
    if over:
        lack = [a for a in over if not np.isclose(alphas, a, rtol=RTOL, atol=0.0).any()]
        return (f"the fit takes alpha = {'; '.join(f'{a:g}' for a in over)}, "
                f"{study} lacks {'; '.join(f'{a:g}' for a in lack)}") if lack else ""
    return (f"the fit takes {FIT_POINTS} aspect ratios > 0 under the paper's conditions, "
            f"{study} has {len(alphas)}") if len(alphas) < FIT_POINTS else ""


def _trend_rows(ref, runs, results) -> list[dict]:
    base = _base_row(ref)
    over = _over(ref)
    conds = _conditions(ref)
    along = ref.vary in ("layer", "tap")  # along one run: the observable changes
    names = {v: observable_name(ref, **({ref.vary: v} if along else {})) for v in over}
    base["observable"] = names[over[0]] if not along else f"{names[over[0]]} ... {names[over[-1]]}"
    free = _at_point(runs, ref, skip=None if along else ref.vary)
    # along one run: each case its own trend; across runs: the cases of one study
    by = SAME_RUN if along else ["engine", "study"]
    per_value = {v: _engine_groups(free, results, names[v], by) for v in over}
    keys = sorted(set().union(*per_value.values()))
    if not keys:
        return [{**base, "engine": "", "verdict": "not run"}]
    out, matched = [], []
    for key in keys:
        engine = key[0]
        g = pd.concat([per_value[v][key] for v in over if key in per_value[v]])
        points, missing, differ, several, unchecked = [], [], [], [], set()
        for v in over:
            at = per_value[v].get(key, g.iloc[0:0])
            if not along and len(at):
                col = pd.to_numeric(at[ref.vary], errors="coerce")
                at = at[np.isclose(col.fillna(np.inf), v, rtol=RTOL)]
            if not len(at):
                missing.append(_fmt(v))
                continue
            good, worst, unc = _matching(at, conds, names[v])
            unchecked |= set(unc)
            if not len(good):
                differ.append(f"at {ref.vary} {_fmt(v)}: " + "; ".join(worst[1]))
                continue
            if good["case"].nunique() > 1:
                several.append(f"{ref.vary} {_fmt(v)}: " + ", ".join(sorted(set(good["case"]))))
            points.append((v, *_run_stats(good, names[v])))
        row = {**base, "engine": engine, "runs": _runs_label(g),
               "ours": ";".join(f"{m:.4g}" for _, m, _, _ in points) if points else np.nan,
               "ours_uncertainty": ";".join(f"{s:.2g}" for _, _, s, _ in points)
               if points else np.nan,
               "n_seeds": min((n for *_, n in points), default=0),
               "note": f"unchecked: {', '.join(sorted(unchecked))}" if unchecked else ""}
        if missing:
            row["verdict"] = "not run"
            row["note"] = "; ".join(x for x in (row["note"], f"no run at {ref.vary} "
                                                + ", ".join(missing)) if x)
        elif differ:
            row["verdict"] = "conditions differ: " + " | ".join(differ)
        elif several:  # which of them makes the trend is not the paper's to say
            row["verdict"] = "unresolved"
            row["note"] = "; ".join(x for x in (row["note"], "several cases at "
                                                + " | ".join(several)) if x)
        else:
            row["verdict"], row["diff_sigma"] = _trend_verdict(points, ref.expect)
        out.append(row)
        matched.append(bool(points))
    # a study none of whose runs is under the paper's conditions is left out where
    # another study has such runs (e.g. hard spheres beside the growth runs of a trend
    # in the aspect ratio)
    if any(matched):
        out = [row for row, m in zip(out, matched) if m]
    return out


def _trend_verdict(points, expect: str) -> tuple[str, float]:
    """Verdict and the smallest step in combined standard errors (signed along the
    expectation; for ``constant`` the largest |difference| of any two points)."""
    # constant: every pair of points (references/README.md), not only neighbours, so a
    # scattered middle point cannot bridge two ends that differ
    pairs = (list(itertools.combinations(points, 2)) if expect == "constant"
             else list(zip(points, points[1:])))
    steps = []
    for (_, m0, s0, _), (_, m1, s1, _) in pairs:
        u = math.hypot(s0 if np.isfinite(s0) else np.nan, s1 if np.isfinite(s1) else np.nan)
        steps.append((m1 - m0) / u if u > 0 else float("nan"))
    if any(not np.isfinite(s) for s in steps):
        return "unresolved", float("nan")
    if expect == "constant":
        worst = max(abs(s) for s in steps)
        return ("agrees" if worst <= 2.0 else "differs"), worst
    sign = 1.0 if expect == "increasing" else -1.0
    signed = [sign * s for s in steps]
    least = min(signed)
    if least > 2.0:
        return "agrees", least
    if least < -2.0:
        return "differs", least
    return "unresolved", least


def match(refs: pd.DataFrame, runs: pd.DataFrame, results: pd.DataFrame) -> pd.DataFrame:
    """``vs_paper.csv``: every reference row against the runs (see the module docstring).

    ``runs``: one row per ``study, case, engine, seed`` with ``family`` (the study family
    the run belongs to), the :data:`POINT` parameters and any condition keys;
    ``results``: ``summary.csv`` (``study, case, engine, seed, observable, value,
    uncertainty``)."""
    if not len(runs):
        runs = pd.DataFrame(columns=["study", "case", "engine", "seed", "family", *POINT])
    if not len(results):
        results = pd.DataFrame(columns=["study", "case", "engine", "seed", "observable",
                                        "value", "uncertainty"])
    rows = []
    for ref in refs.itertuples(index=False):
        if ref.kind == "value" and str(ref.observable) in FITS:
            rows += _fit_rows(ref, runs, results)
        else:
            rows += (_value_rows if ref.kind == "value" else _trend_rows)(ref, runs, results)
    out = pd.DataFrame(rows)
    for c in OUTPUT_COLUMNS:
        if c not in out:
            out[c] = np.nan
    return out[OUTPUT_COLUMNS]


def verdict_counts(table: pd.DataFrame) -> dict[str, int]:
    """How many rows carry each verdict (``conditions differ: ...`` counted together)."""
    v = table["verdict"].astype(str).str.replace(r":.*$", "", regex=True)
    return {k: int(n) for k, n in v.value_counts().items()}
