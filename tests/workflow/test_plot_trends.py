"""The trends figure keeps runs of another protocol (LIGGGHTS' settled rod beds) apart
from the study's compressions, so that no line joins the two."""
import pandas as pd

from workflows.scripts import plot_trends


def test_settled_runs_get_their_own_series(tmp_path):
    rows = []
    for case, alpha in (("alpha0", 0.0), ("alpha1", 1.0)):
        for engine in ("pysim", "liggghts"):
            rows.append(dict(study="s", case=case, engine=engine, seed=1, observable="phi_j",
                             value=0.6 + alpha / 10, alpha=alpha))
    rows.append(dict(study="s", case="alpha1", engine="liggghts", seed=1, observable="settled",
                     value=1.0, alpha=1.0))
    df = plot_trends.label_protocols(pd.DataFrame(rows))
    phi = df[df.observable == "phi_j"].set_index(["case", "engine"]).value
    assert set(phi.index) == {("alpha0", "pysim"), ("alpha1", "pysim"), ("alpha0", "liggghts"),
                              ("alpha1", "liggghts settled")}
    summary = tmp_path / "summary.csv"
    pd.DataFrame(rows).to_csv(summary, index=False)
    out = tmp_path / "trends.png"
    assert plot_trends.main(["--summary", str(summary), "--study", "s", "--parameter", "alpha",
                             "--out", str(out)]) == 0
    assert out.stat().st_size > 1000
