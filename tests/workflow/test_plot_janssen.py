"""The Janssen figure against the paper: each run's element profile of the trace and its
fit are read from its files, and the paper's fit is found by the case's aspect ratio and Bond number, with
the paper's conditions the case does not meet listed."""
import json

import numpy as np
import pandas as pd
import pytest
import yaml

from rodcase.case import validate_case
from tests.cases import FEED, changed
from workflows.scripts import plot_janssen


def _run(root, variant, width, n, bond, sigma_m=4.0, h_s=0.8, wall_cohesion=True):
    """A finished 2-D run folder of d = 10 rods with a Janssen-shaped element profile of
    the trace at every fifth slab."""
    case = validate_case(changed(FEED, particles__aspect_ratio=9.0, particles__n=n,
                                 container__width=width, contact__bond_number=bond,
                                 contact__cohesion_range=1e-4,
                                 contact__wall_cohesion=wall_cohesion,
                                 contact__spine_contact="end_bonds",
                                 contact__tangential_spring="keep",
                                 protocol__feed__height=5000.0))
    seed = root / "deposit" / variant / "seed1"
    run = seed / "pysim"
    run.mkdir(parents=True)
    (seed / "case.yaml").write_text(yaml.safe_dump(case))
    (run / "run.json").write_text(json.dumps({"status": "ok"}))
    x = np.linspace(0.05, 2.0, 40)
    fit = sigma_m * (1.0 - np.exp(-x / h_s))
    rve = np.where(np.arange(40) % 5 == 2, fit, np.nan)
    pd.DataFrame({"x": x, "pressure": fit / 2, "trace_rve": rve, "trace_rve_err": 0.1 * rve,
                  "trace_rve_fit": fit}).to_csv(run / "curves.csv", index=False)
    pd.DataFrame({"observable": ["sigma_m_trace_rve", "h_s_trace_rve"],
                  "value": [sigma_m, h_s]}).to_csv(run / "observables.csv", index=False)
    return run


def test_paper_fit_by_case_and_its_unmet_conditions(tmp_path, monkeypatch):
    runs = [_run(tmp_path, "paper_box", 200.0, 6000, 1e4),     # W = 20 rod lengths
            _run(tmp_path, "small_box", 50.0, 200, 0.0),
            _run(tmp_path, "bo1000", 200.0, 6000, 1e3),
            _run(tmp_path, "inert_walls", 200.0, 6000, 1e4, wall_cohesion=False)]
    seen = {}
    monkeypatch.setattr(plot_janssen.plots, "janssen_against_paper",
                        lambda panels, out: seen.update(panels=panels))
    assert plot_janssen.main(["--out", str(tmp_path / "j.png"), *map(str, runs)]) == 0
    panels = {p["title"]: p for p in seen["panels"]}
    # the paper's Fig. 6: Bo_g = 1e4 -> 2500 N/m, h_s/W 1.2; Bo_g = 0 -> 4800, 2.2
    assert panels["paper_box"]["paper"]["sigma_m"] == 2500.0
    assert panels["paper_box"]["paper"]["h_s"] == 1.2
    assert panels["paper_box"]["paper"]["unmet"] == []
    small = panels["small_box"]["paper"]
    assert (small["sigma_m"], small["h_s"]) == (4800.0, 2.2)
    assert any(u.startswith("width_over_length (ours 5") for u in small["unmet"])
    assert any(u.startswith("n (ours 200") for u in small["unmet"])
    assert panels["bo1000"]["paper"] is None  # the paper fits no profile at Bo_g = 1e3
    # the paper's walls attract the grains: walls that do not are another condition
    assert panels["inert_walls"]["paper"]["unmet"] == ["wall_cohesion (ours no, paper yes)"]
    (run,) = panels["paper_box"]["runs"]
    prof = pd.read_csv(runs[0] / "curves.csv")
    rows = prof.trace_rve.notna()  # the rows of elements, not the slabs between them
    assert len(run["x"]) == 8
    np.testing.assert_allclose(run["x"], prof.x[rows])
    np.testing.assert_allclose(run["trace"], prof.trace_rve[rows])
    np.testing.assert_allclose(run["err"], prof.trace_rve_err[rows])
    np.testing.assert_allclose(run["fit"][1], prof.trace_rve_fit)
    assert run["sigma_m"] == pytest.approx(4.0) and run["h_s"] == pytest.approx(0.8)
    # and the real figure is drawn
    monkeypatch.undo()
    assert plot_janssen.main(["--out", str(tmp_path / "j.png"), *map(str, runs)]) == 0
    assert (tmp_path / "j.png").stat().st_size > 10_000
