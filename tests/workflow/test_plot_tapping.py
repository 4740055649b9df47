"""The tapping study's figures over several seeds (workflows/scripts/plot_tapping.py): the
seeds of a variant drawn as their mean and band, and the per-set table of seed means and
standard errors, on run directories written here (no engine runs)."""
import json

import numpy as np
import pandas as pd
import pytest
import yaml

from analysis.plots import _seed_groups
from tests.cases import TAP
from workflows.scripts.plot_tapping import main, sets_table

#: per (variant, seed): late density and angle of the synthetic runs
LATE = {("an6", 1): (0.55, 30.0), ("an6", 2): (0.57, 34.0), ("an6", 3): (0.56, 29.0),
        ("an9", 1): (0.62, 26.0)}


def fake_run(root, variant, seed, phi_late, angle_late, status="ok"):
    """A finished pysim tapping run directory: case.yaml, run.json, observables.csv and
    curves.csv of 9 frames (settled, then 8 taps) whose averaged curves end at the late
    values."""
    case = json.loads(json.dumps(TAP))
    if variant == "an9":
        case["particles"].update(n=40, aspect_ratio=1.5)
    d = root / variant / f"seed{seed}" / "pysim"
    d.mkdir(parents=True)
    (d.parent / "case.yaml").write_text(yaml.safe_dump(case))
    (d / "run.json").write_text(json.dumps({"status": status}))
    obs = [("phi_settled", 0.42), ("phi_late", phi_late), ("angle_settled", 20.0),
           ("angle_late", angle_late), ("p2_z_late", -0.3), ("phi_tapped", phi_late)]
    pd.DataFrame({"study": "tap", "case": variant, "engine": "pysim", "seed": seed,
                  "observable": [o for o, _ in obs], "value": [v for _, v in obs],
                  "uncertainty": np.nan}).to_csv(d / "observables.csv", index=False)
    tap = np.arange(9.0)
    ramp = tap / 8
    cv = pd.DataFrame({"step": 1000 + 100 * np.arange(9), "tap": tap, "phase": 0,
                       "phi": 0.42 + (phi_late - 0.42) * ramp,
                       "angle": 20.0 + (angle_late - 20.0) * ramp})
    for k in range(1, 5):
        cv[f"phi_layer{k}"] = cv.phi
        cv[f"angle_layer{k}"] = cv.angle
    for col in [c for c in list(cv.columns) if c.startswith(("phi", "angle"))]:
        cv[f"{col}_avg"] = cv[col]
    cv.to_csv(d / "curves.csv", index=False)
    return d


@pytest.fixture
def runs(tmp_path):
    dirs = [fake_run(tmp_path, v, s, *LATE[v, s]) for v, s in LATE]
    dirs.append(fake_run(tmp_path, "an9", 2, 0.0, 0.0, status="failed"))
    return dirs


def test_sets_table_gives_seed_means_and_standard_errors(runs):
    values, stats, labels = sets_table(runs)
    assert set(values.variant) == {"an6", "an9"}  # the failed run is left out
    row = stats[(stats.variant == "an6") & (stats.observable == "angle_late")].iloc[0]
    angles = [LATE["an6", s][1] for s in (1, 2, 3)]
    assert row.seeds == 3 and row["mean"] == pytest.approx(np.mean(angles))
    assert row["std"] == pytest.approx(np.std(angles, ddof=1))
    assert row["sem"] == pytest.approx(np.std(angles, ddof=1) / np.sqrt(3))
    one = stats[(stats.variant == "an9") & (stats.observable == "phi_late")].iloc[0]
    assert one.seeds == 1 and one["mean"] == pytest.approx(0.62) and np.isnan(one["sem"])
    assert "phi_tapped" not in set(stats.observable)
    assert "alpha 1.5, N 40" in labels["an9"] and "e_n 0.4, Gamma 2" in labels["an6"]


def test_seed_groups_average_the_curves_with_a_band(runs):
    group = [{"label": f"an6 pysim seed{s}", "engine": "pysim", "index": 0,
              "group": ("an6", "pysim"), "curves": pd.read_csv(d / "curves.csv")}
             for d, s in zip(runs[:3], (1, 2, 3))]
    alone = {"label": "an9 pysim seed1", "engine": "pysim", "index": 1,
             "group": ("an9", "pysim"), "curves": pd.read_csv(runs[3] / "curves.csv")}
    (first, mean, n), (other, cv, m) = _seed_groups(group + [alone])
    assert (n, m) == (3, 1) and other is alone and cv is alone["curves"]
    angles = [LATE["an6", s][1] for s in (1, 2, 3)]
    assert mean.angle_avg.iloc[-1] == pytest.approx(np.mean(angles))
    assert mean.angle_avg_min.iloc[-1] == min(angles)
    assert mean.angle_avg_max.iloc[-1] == max(angles)
    assert mean.angle_avg.iloc[0] == pytest.approx(20.0) and len(mean) == 9


def test_script_writes_the_figures_and_the_table(runs, tmp_path):
    out = tmp_path / "figures"
    assert main(["--curves-out", str(out / "tapping.png"), "--sets-out", str(out / "sets.png"),
                 "--sets-table", str(out / "sets.csv"), *map(str, runs)]) == 0
    assert (out / "tapping.png").stat().st_size > 0 and (out / "sets.png").stat().st_size > 0
    table = pd.read_csv(out / "sets.csv")
    assert list(table.columns) == ["variant", "engine", "observable", "seeds", "mean", "std",
                                   "sem"]
    assert len(table) == 2 * 5  # five of the set observables in each variant's runs


@pytest.mark.parametrize("flight, panels", [([0.4, 0.6], 3), ([np.nan, np.nan], 2)])
def test_sets_figure_shows_how_far_the_bed_flies_when_measured(monkeypatch, tmp_path, flight,
                                                               panels):
    from analysis import plots

    saved = {}
    monkeypatch.setattr(plots, "_save", lambda fig, out: saved.update(fig=fig))
    rows = []
    for variant, cf in zip(("an3", "an6"), flight):
        for obs, value in (("phi_settled", 0.42), ("phi_late", 0.57), ("angle_settled", 21.0),
                           ("angle_late", 40.0), ("contacts_flight", cf)):
            rows += [{"variant": variant, "engine": "pysim", "observable": obs, "seed": s,
                      "value": value + 0.01 * s} for s in (1, 2)]
    plots.tapping_sets(pd.DataFrame(rows), tmp_path / "sets.png")
    axes = saved["fig"].axes
    assert len(axes) == panels
    if panels == 3:
        assert "flight" in axes[2].get_ylabel()
        assert len(axes[2].lines) > 0


def test_set_labels_name_a_changed_tangential_law_and_the_clip():
    """Sets told apart by their tangential law or by ``limit_damping`` get a third line;
    a set with the tangential law the schema derives gets none."""
    from rodcase.case import deep_merge, validate_case
    from workflows.scripts.plot_tapping import set_label

    plain = validate_case(TAP)
    assert set_label(plain) == "e_n 0.4, Gamma 2\nalpha 2, N 30"
    c = plain["contact"]
    swapped = validate_case(deep_merge(TAP, {"contact": {"k_t": 1.5 * c["k_t"],
                                                         "gamma_t": 0.4 * c["gamma_t"]}}))
    assert set_label(swapped).endswith("\nk_t x1.5, \u03b3_t x0.4")
    clipped = validate_case(deep_merge(TAP, {"contact": {"limit_damping": True}}))
    assert set_label(clipped).endswith("\nf_n >= 0")
    paper = validate_case(deep_merge(TAP, {
        "contact": {"tangential_spring": "keep"},
        "protocol": {"preparation": {"mode": "free", "ke_stop": 1e-8, "max_time": 2.0},
                     "integrator": "euler"}}))
    assert set_label(paper).endswith("\nspring kept, free settling, euler")


def test_snapshots_at_the_papers_taps_show_a_short_runs_last_frame_once(monkeypatch, tmp_path):
    """The rule asks for taps 0, 300, 900 and the last (the paper's Figs. 4 and 5): a run
    that stops earlier shows its last frame once, not once per tap past its end."""
    from types import SimpleNamespace

    from workflows.scripts import plot_tapping

    d = fake_run(tmp_path, "an6", 1, 0.6, 70.0)  # taps 0-8 at steps 1000-1800
    monkeypatch.setattr(plot_tapping, "read_particle_frames", lambda path: [
        SimpleNamespace(step=1000 + 100 * k) for k in range(9)])
    drawn = {}
    monkeypatch.setattr(plot_tapping.plots, "tapping_snapshots",
                        lambda frames, out, dc: drawn.update(frames=frames))
    assert main(["--snapshots-out", str(tmp_path / "s.png"), str(d), "--taps", "0", "3",
                 "300", "900", "-1"]) == 0
    assert [t for t, _ in drawn["frames"]] == ["pysim, seed1, tap 0", "pysim, seed1, tap 3",
                                               "pysim, seed1, tap 8"]
    assert [f.step for _, f in drawn["frames"]] == [1000, 1300, 1800]
