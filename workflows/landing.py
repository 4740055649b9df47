"""The first page of the report and the end of ``make run``: what was run and how every
result stands, against the other engines and against the papers, in one place."""
from __future__ import annotations

import html
from pathlib import Path

import pandas as pd

from analysis.vs_paper import verdict_counts
from workflows.vs_paper import cell

COLORS = {"agree": "#d9f2d9", "agrees": "#d9f2d9", "DIFFER": "#f8d0d0", "differs": "#f8d0d0",
          "inconclusive": "#fde9c4", "unresolved": "#fde9c4", "conditions differ": "#e4e4f7",
          "not run": "#eeeeee", "n/a": "#eeeeee"}


def _read(path: Path) -> pd.DataFrame:
    try:
        return pd.read_csv(path)
    except (FileNotFoundError, pd.errors.EmptyDataError):
        return pd.DataFrame()


def tables(results) -> dict[str, pd.DataFrame]:
    """``summary``, ``comparison``, ``failures`` and ``vs_paper`` of a results folder (empty
    where missing)."""
    root = Path(results)
    return {k: _read(root / f"{k}.csv") for k in ("summary", "comparison", "failures",
                                                   "vs_paper")}


def _runs_line(summary: pd.DataFrame) -> list[str]:
    if not len(summary):
        return ["No run has finished yet."]
    out = []
    for study, g in summary.groupby("study", sort=True):
        runs = g.drop_duplicates(["case", "engine", "seed"])
        engines = ", ".join(f"{e} {n}" for e, n in runs.groupby("engine").size().items())
        out.append(f"{study}: {runs['case'].nunique()} cases, runs per engine: {engines}")
    return out


def _verdict_key(v: str) -> str:
    return "conditions differ" if str(v).startswith("conditions differ") else str(v)


def _html_table(df: pd.DataFrame, columns: list[str], verdict: str) -> str:
    head = "".join(f"<th>{html.escape(c)}</th>" for c in columns)
    body = []
    for _, r in df.iterrows():
        color = COLORS.get(_verdict_key(r[verdict]), "#ffffff")
        body.append(f'<tr style="background:{color}">'
                    + "".join(f"<td>{html.escape(cell(r[c]))}</td>" for c in columns) + "</tr>")
    return (f'<table border="1" style="border-collapse:collapse;font-size:small">'
            f"<tr>{head}</tr>{''.join(body)}</table>")


def _counts(series: pd.Series) -> str:
    counts = series.map(_verdict_key).value_counts()
    return ", ".join(f"{n} {v}" for v, n in counts.items()) or "none"


def landing_html(results) -> str:
    """The report's first page (an HTML fragment)."""
    t = tables(results)
    cmp, vsp, fail = t["comparison"], t["vs_paper"], t["failures"]
    parts = ["<h2>What was run</h2><ul>"
             + "".join(f"<li>{html.escape(s)}</li>" for s in _runs_line(t["summary"]))
             + "</ul>"]
    if len(fail):
        parts.append(f"<p><b>{len(fail)} runs failed</b>: see <code>failures.csv</code> "
                     "(category Tables) for their errors and logs.</p>")
    parts.append("<h2>Do the engines agree?</h2>")
    if len(cmp):
        parts.append(f"<p>{_counts(cmp['verdict'])} (Welch equivalence test with each "
                     "observable's tolerance; <code>comparison.csv</code> has the p-values; "
                     "the figure <i>engine differences</i> shows them against the tolerance"
                     ").</p>")
        parts.append(_html_table(cmp, ["study", "case", "observable", "engine_a", "mean_a",
                                       "engine_b", "mean_b", "difference", "tolerance",
                                       "verdict", "basis"], "verdict"))
    else:
        parts.append("<p>No case ran on two engines.</p>")
    parts.append("<h2>Against the papers</h2>")
    if len(vsp):
        ran = vsp[vsp["verdict"] != "not run"]
        parts.append(f"<p>{len(vsp)} rows of the papers' reference tables: "
                     f"{', '.join(f'{n} {v}' for v, n in sorted(verdict_counts(vsp).items()))}"
                     ". The rows with a run at the paper's point:</p>")
        if len(ran):
            parts.append(_html_table(ran, ["id", "where", "engine", "observable",
                                           "paper_value", "paper_uncertainty", "ours",
                                           "ours_uncertainty", "n_seeds", "verdict"],
                                     "verdict"))
        else:
            parts.append("<p>None: this profile runs no point of the papers.</p>")
    return "\n".join(parts)


def landing_text(results) -> str:
    """The same verdicts as lines for the terminal."""
    t = tables(results)
    cmp, vsp, fail = t["comparison"], t["vs_paper"], t["failures"]
    lines = ["what was run:"] + [f"  {s}" for s in _runs_line(t["summary"])]
    if len(fail):
        lines.append(f"  {len(fail)} runs FAILED: see failures.csv")
    lines.append(f"engines against each other: {_counts(cmp['verdict']) if len(cmp) else 'none'}")
    for _, r in cmp.iterrows():
        lines.append(f"  {r.study}/{r.case} {r.observable}: {r.engine_a} {r.mean_a:.4g} vs "
                     f"{r.engine_b} {r.mean_b:.4g} -> {r.verdict}")
    if len(vsp):
        lines.append("against the papers: " + ", ".join(
            f"{n} {v}" for v, n in sorted(verdict_counts(vsp).items())))
        for _, r in vsp[vsp["verdict"] != "not run"].iterrows():
            lines.append(f"  {r.id} {r.observable} ({r.engine}): paper {cell(r.paper_value)}, "
                         f"ours {cell(r.ours)} -> {r.verdict}")
    return "\n".join(lines)
