"""The deposition figure script on a small pysim deposit: profiles, orientations, Q(r)
and the directions of the major principal stress are computed from the run's files."""
import numpy as np
import pytest

from analysis.summary import analyse_deposit
from tests.cases import deposit_with
from tests.runs import run_case
from workflows.scripts import plot_deposit


def test_deposit_figure_from_a_settled_run(tmp_path, monkeypatch):
    rd = run_case(tmp_path, deposit_with())
    _, prof = analyse_deposit(rd, width=6.0, gravity=1.0, slab=3.0, base_wall_id=-5)
    prof.to_csv(rd / "curves.csv", index=False)
    seen = {}
    monkeypatch.setattr(plot_deposit.plots, "deposit_profiles",
                        lambda runs, out: seen.update(runs=runs, out=out))
    assert plot_deposit.main(["--out", str(tmp_path / "deposit.png"), str(rd)]) == 0
    (run,) = seen["runs"]
    r, q = run["q_r"]
    assert r.max() <= plot_deposit.ORDER_RANGE and np.isfinite(q).sum() > 5
    assert np.all(np.abs(q[np.isfinite(q)]) <= 1.0 + 1e-12)
    edges, dens, elements = run["major"]
    assert elements >= 1 and edges[0] == 0.0 and edges[-1] == 90.0
    assert np.sum(dens * np.diff(np.radians(edges))) == pytest.approx(1.0)
    # each loaded grain's own major axis: an elevation in 3-D, for the grains in contact
    per_grain = run["major_particles"]
    assert 50 < len(per_grain) <= 60 and np.all((per_grain >= 0) & (per_grain <= 90))
    # and the real figure is drawn
    monkeypatch.undo()
    assert plot_deposit.main(["--out", str(tmp_path / "deposit.png"), str(rd)]) == 0
    assert (tmp_path / "deposit.png").stat().st_size > 10_000
