"""The matching of published values against runs, on small made-up tables."""
import math

import numpy as np
import pandas as pd
import pytest

from analysis.vs_paper import (REFERENCE_COLUMNS, ReferenceError, match, parse_conditions,
                               read_references)


def ref(**kw):
    row = {c: np.nan for c in REFERENCE_COLUMNS}
    row.update(id="p-01", paper="p", where="Table 1", study="jamming_2d", kind="value",
               observable="phi_j", alpha=1.0, value=0.88, uncertainty=0.002,
               uncertainty_kind="stated", conditions="dimension=2; n=1024", claim="x")
    row.update(kw)
    return row


def refs(*rows):
    return pd.DataFrame(list(rows), columns=REFERENCE_COLUMNS)


def runs_and_results(values, alpha=1.0, n=1024, engine="pysim", observable="phi_j",
                     case="a1", **terms):
    runs = pd.DataFrame([{"study": "jamming_2d_paper", "case": case, "engine": engine,
                          "seed": s, "family": "jamming_2d", "alpha": alpha, "d": 1 + alpha,
                          "sigma": np.nan, "e_n": np.nan, "Gamma": np.nan, "bo_g": np.nan,
                          "n": float(n), "dimension": 2.0, **terms}
                         for s in range(1, len(values) + 1)])
    results = pd.DataFrame([{"study": "jamming_2d_paper", "case": case, "engine": engine,
                             "seed": s, "observable": observable, "value": v,
                             "uncertainty": np.nan}
                            for s, v in enumerate(values, start=1)])
    return runs, results


def test_agrees_within_the_combined_uncertainty():
    runs, res = runs_and_results([0.8795, 0.8805, 0.8800])
    out = match(refs(ref()), runs, res)
    assert list(out.verdict) == ["agrees"]
    r = out.iloc[0]
    assert r.n_seeds == 3 and math.isclose(r.ours, 0.88)
    assert math.isclose(r.ours_uncertainty, 0.0005 / math.sqrt(3), rel_tol=1e-9)
    assert abs(r.diff_sigma) < 1e-9


def test_a_value_outside_the_uncertainty_differs():
    runs, res = runs_and_results([0.894, 0.895])
    r = match(refs(ref()), runs, res).iloc[0]
    assert r.verdict == "differs"
    # (0.8945 - 0.88) / hypot(0.002, 0.0005)
    assert math.isclose(r.diff_sigma, 0.0145 / math.hypot(0.002, 0.0005), rel_tol=1e-9)


def test_a_condition_mismatch_says_which_and_keeps_our_value():
    runs, res = runs_and_results([0.88, 0.88], n=512)
    r = match(refs(ref()), runs, res).iloc[0]
    assert r.verdict.startswith("conditions differ: ")
    assert "n (ours 512, paper 1024)" in r.verdict
    assert math.isclose(r.ours, 0.88)


def test_a_missing_run_is_not_run():
    runs, res = runs_and_results([0.88], alpha=4.0)
    out = match(refs(ref()), runs, res)
    assert list(out.verdict) == ["not run"] and out.iloc[0].engine == ""
    # no runs at all
    out = match(refs(ref()), pd.DataFrame(), pd.DataFrame())
    assert list(out.verdict) == ["not run"]


def test_an_observable_no_run_reports_is_not_run_with_a_note():
    runs, res = runs_and_results([0.88])
    r = match(refs(ref(observable="flat_fraction")), runs, res).iloc[0]
    assert r.verdict == "not run" and "flat_fraction" in r.note


def test_a_value_the_runs_report_as_not_measured_is_not_run_with_those_runs():
    runs, res = runs_and_results([np.nan, np.nan], observable="omega_low_exponent")
    r = match(refs(ref(observable="omega_low_exponent")), runs, res).iloc[0]
    assert r.verdict == "not run" and r.runs == "jamming_2d_paper/a1"
    assert "not measured" in r.note
    # one seed with a value: that seed is the measurement
    runs, res = runs_and_results([np.nan, 0.88], observable="omega_low_exponent")
    r = match(refs(ref(observable="omega_low_exponent")), runs, res).iloc[0]
    assert r.n_seeds == 1 and math.isclose(r.ours, 0.88)


def test_inequality_conditions_and_unchecked_keys():
    runs, res = runs_and_results([0.88, 0.88], rate=1e-8)
    r = match(refs(ref(conditions="dimension=2; rate<=1e-9; side_contacts=two_bonds")),
              runs, res).iloc[0]
    assert "rate (ours 1e-08, paper <=1e-09)" in r.verdict
    runs, res = runs_and_results([0.88, 0.88], rate=1e-10)
    r = match(refs(ref(conditions="dimension=2; rate<=1e-9; law=harmonic")), runs, res).iloc[0]
    assert r.verdict == "agrees" and "unchecked: law" in r.note


def test_observable_conditions_separate_contact_counts():
    # the paper counts side-to-side contacts twice: z_j (once) is the wrong observable
    runs, res = runs_and_results([4.4, 4.4], observable="z_j")
    r = match(refs(ref(observable="z_j", value=4.43, uncertainty=0.03,
                       conditions="side_contacts=two_bonds")), runs, res).iloc[0]
    assert "side_contacts (ours one, paper two_bonds)" in r.verdict


def test_a_band_agrees_inside_it_only():
    row = ref(study="tapping", observable="angle_late", layer=2, value=85.0, uncertainty=5.0,
              uncertainty_kind="band", conditions="")
    runs, res = runs_and_results([81.0, 82.0], observable="angle_late_layer2")
    runs["family"] = "tapping"
    assert match(refs(row), runs, res).iloc[0].verdict == "agrees"
    runs, res = runs_and_results([70.0, 71.0], observable="angle_late_layer2")
    runs["family"] = "tapping"
    assert match(refs(row), runs, res).iloc[0].verdict == "differs"


def trend_data(means, spread=0.001):
    parts = [runs_and_results([m - spread, m + spread], alpha=a, case=f"a{a}")
             for a, m in means.items()]
    return (pd.concat([p[0] for p in parts], ignore_index=True),
            pd.concat([p[1] for p in parts], ignore_index=True))


def trend(expect, over="0.5;1;4"):
    return ref(kind="trend", alpha=np.nan, value=np.nan, uncertainty=np.nan,
               uncertainty_kind=np.nan, vary="alpha", over=over, expect=expect)


def test_trends():
    runs, res = trend_data({0.5: 0.80, 1.0: 0.85, 4.0: 0.90})
    assert match(refs(trend("increasing")), runs, res).iloc[0].verdict == "agrees"
    assert match(refs(trend("decreasing")), runs, res).iloc[0].verdict == "differs"
    assert match(refs(trend("constant")), runs, res).iloc[0].verdict == "differs"
    runs, res = trend_data({0.5: 0.85, 1.0: 0.85, 4.0: 0.85})
    assert match(refs(trend("constant")), runs, res).iloc[0].verdict == "agrees"
    assert match(refs(trend("increasing")), runs, res).iloc[0].verdict == "unresolved"
    # a point of the trend that was never run
    r = match(refs(trend("increasing", over="0.5;1;8")), runs, res).iloc[0]
    assert r.verdict == "not run" and "alpha 8" in r.note


def test_a_trend_leaves_out_a_study_at_other_conditions():
    """Another study with one point of the trend at other conditions (N = 512) adds no
    row when a study under the paper's conditions exists, and is reported alone."""
    runs, res = trend_data({0.5: 0.80, 1.0: 0.85, 4.0: 0.90})
    other_runs, other_res = runs_and_results([0.84], alpha=1.0, n=512, case="small")
    other_runs["study"] = other_res["study"] = "other"
    both = match(refs(trend("increasing")), pd.concat([runs, other_runs]),
                 pd.concat([res, other_res]))
    assert list(both.verdict) == ["agrees"] and "other" not in both.iloc[0].runs
    alone = match(refs(trend("increasing")), other_runs, other_res)
    assert list(alone.verdict) == ["not run"]


def test_alternatives_in_a_condition():
    runs, res = runs_and_results([0.88, 0.88], protocol="ls")
    either = match(refs(ref(conditions="dimension=2; protocol=ls|fb")), runs, res)
    assert list(either.verdict) == ["agrees"]
    other = match(refs(ref(conditions="dimension=2; protocol=fb|growth")), runs, res)
    assert other.iloc[0].verdict == "conditions differ: protocol (ours ls, paper fb|growth)"


def test_conditions_parse_and_reject_junk():
    assert parse_conditions("dimension=2; rate<=1e-9;law=harmonic") == [
        ("dimension", "=", 2.0), ("rate", "<=", 1e-9), ("law", "=", "harmonic")]
    assert parse_conditions(np.nan) == []
    with pytest.raises(ReferenceError, match="not key=value"):
        parse_conditions("dimension two")


def test_reference_tables_are_checked(tmp_path):
    good = refs(ref(), ref(id="p-02", kind="trend", value=np.nan, uncertainty=np.nan,
                           uncertainty_kind=np.nan, vary="alpha", over="1;2",
                           expect="increasing"))
    good.to_csv(tmp_path / "p.csv", index=False)
    assert len(read_references(tmp_path)) == 2
    refs(ref(), ref()).to_csv(tmp_path / "p.csv", index=False)
    with pytest.raises(ReferenceError, match="duplicated reference id 'p-01'"):
        read_references(tmp_path)
    refs(ref(kind="guess")).to_csv(tmp_path / "p.csv", index=False)
    with pytest.raises(ReferenceError, match="kind 'guess'"):
        read_references(tmp_path)
    refs(ref(uncertainty_kind="about")).to_csv(tmp_path / "p.csv", index=False)
    with pytest.raises(ReferenceError, match="uncertainty_kind 'about'"):
        read_references(tmp_path)
    refs(ref(id="p-03", kind="trend", vary="colour", over="1;2",
             expect="up")).to_csv(tmp_path / "p.csv", index=False)
    with pytest.raises(ReferenceError, match="vary 'colour'"):
        read_references(tmp_path)


def test_trends_along_the_layers_and_the_taps_of_one_run():
    row = ref(kind="trend", study="tapping", observable="angle_late", value=np.nan,
              uncertainty=np.nan, uncertainty_kind=np.nan, conditions="", vary="layer",
              over="1;2;3", expect="increasing")
    parts = [runs_and_results([m - 0.5, m + 0.5], observable=f"angle_late_layer{k}")
             for k, m in ((1, 40.0), (2, 50.0), (3, 60.0))]
    runs = parts[0][0].assign(family="tapping")
    res = pd.concat([p[1] for p in parts], ignore_index=True)
    r = match(refs(row), runs, res).iloc[0]
    assert r.verdict == "agrees" and r.ours == "40;50;60"
    assert r.observable == "angle_late_layer1 ... angle_late_layer3"
    # along the taps: angle_late at tap k is the observable angle_tap<k>; tap 1000 missing
    row.update(vary="tap", over="10;100;1000", layer=2)
    parts = [runs_and_results([m - 0.5, m + 0.5], observable=f"angle_tap{k}_layer2")
             for k, m in ((10, 40.0), (100, 50.0))]
    res = pd.concat([p[1] for p in parts], ignore_index=True)
    r = match(refs(row), runs, res).iloc[0]
    assert r.verdict == "not run" and "tap 1000" in r.note


def test_a_value_at_a_tap_takes_the_observable_there_from_runs_that_reach_it():
    row = ref(study="tapping", observable="phi_late_enclosing", tap=2000.0, value=0.75,
              uncertainty=0.005, uncertainty_kind="digits", conditions="")
    runs, res = runs_and_results([0.62, 0.63], observable="phi_tap2000_enclosing",
                                 tap=4134.0)
    runs["family"] = "tapping"
    r = match(refs(row), runs, res).iloc[0]
    assert r.observable == "phi_tap2000_enclosing" and r.verdict == "differs"
    assert math.isclose(r.ours, 0.625)
    # a run that stops before tap 2000 is not at the paper's condition
    runs["tap"] = 1000.0
    r = match(refs(row), runs, res).iloc[0]
    assert r.verdict.startswith("conditions differ: ") and "tap (ours 1000" in r.verdict


def test_one_seed_has_no_uncertainty_of_ours():
    runs, res = runs_and_results([0.8801])
    res["uncertainty"] = 0.01  # a spread over frames, not an error of the mean
    r = match(refs(ref()), runs, res).iloc[0]
    assert r.n_seeds == 1 and np.isnan(r.ours_uncertainty) and "one seed" in r.note
    assert r.verdict == "agrees"


def test_two_cases_at_one_point_are_two_results_not_two_seeds():
    """Runs that differ in something the paper leaves open (friction) are never pooled."""
    a = runs_and_results([0.880, 0.881], case="mu0", friction=0.0)
    b = runs_and_results([0.890, 0.891], case="mu0.5", friction=0.5)
    runs = pd.concat([a[0], b[0]], ignore_index=True)
    res = pd.concat([a[1], b[1]], ignore_index=True)
    out = match(refs(ref()), runs, res)
    assert list(out.runs) == ["jamming_2d_paper/mu0", "jamming_2d_paper/mu0.5"]
    assert list(out.n_seeds) == [2, 2] and list(out.verdict) == ["agrees", "differs"]
    # a trend across alpha with two cases at one alpha cannot say which one makes it
    c = runs_and_results([0.90, 0.90], alpha=4.0, case="a4")
    runs = pd.concat([runs, c[0]], ignore_index=True)
    res = pd.concat([res, c[1]], ignore_index=True)
    r = match(refs(trend("increasing", over="1;4")), runs, res).iloc[0]
    assert r.verdict == "unresolved" and "several cases at alpha 1: mu0, mu0.5" in r.note


def test_small_alpha_fit_recovers_its_parameters():
    from analysis.vs_paper import small_alpha_fit

    alpha = np.array([0.001, 0.003, 0.01, 0.03])
    fit = small_alpha_fit(alpha, 4.31 + 1.5 * alpha**0.68, np.full(4, 1e-3))
    assert fit["x"] == pytest.approx(0.68, abs=1e-6)
    assert fit["a"] == pytest.approx(0.31, abs=1e-6)
    assert fit["limit"] == pytest.approx(4.31, abs=1e-6) and fit["u_x"] > 0


def fit_data(alphas, spread=0.002):
    return trend_data({a: 4.31 + 1.5 * a**0.68 for a in alphas}, spread=spread)


def fit_ref(observable, value, uncertainty):
    return ref(observable=observable, alpha=np.nan, value=value, uncertainty=uncertainty)


def test_fitted_values_across_aspect_ratios():
    runs, res = fit_data([0.001, 0.003, 0.01, 0.03, 0.1, 1.0])
    res["observable"] = "z_j_bonds"
    table = match(refs(fit_ref("z_j_bonds_fit_exponent", 0.68, 0.13),
                       {**fit_ref("z_j_bonds_limit_alpha0", 4.31, 0.08), "id": "p-02"},
                       {**fit_ref("z_j_bonds_fit_offset", 0.9, 0.08), "id": "p-03"}),
                  runs, res)
    assert list(table.verdict) == ["agrees", "agrees", "differs"]
    assert table.iloc[0].ours == pytest.approx(0.68, abs=0.05)
    assert "fit over alpha = 0.001, 0.003, 0.01, 0.03" in table.iloc[0].note
    # the fit of z_j_bonds needs runs that report z_j_bonds
    other = match(refs(fit_ref("z_j_bonds_fit_exponent", 0.68, 0.13)), runs,
                  res.assign(observable="z_j"))
    assert other.iloc[0].verdict == "not run"


def test_a_fit_with_too_few_aspect_ratios_is_not_run():
    runs, res = fit_data([0.01, 0.03, 0.1])
    res["observable"] = "z_j_bonds"
    row = match(refs(fit_ref("z_j_bonds_fit_exponent", 0.68, 0.13)), runs, res).iloc[0]
    assert row.verdict == "not run" and "jamming_2d_paper has 3" in row.note


def test_a_fit_over_the_papers_aspect_ratios_waits_for_all_of_them():
    """With ``over`` the fit takes exactly those aspect ratios: one missing makes the row
    ``not run`` (never a fit over the next larger alpha), and larger ones never enter."""
    over = "0.001;0.003;0.01;0.03"
    row = {**fit_ref("z_j_bonds_fit_exponent", 0.68, 0.13), "over": over}
    runs, res = fit_data([0.001, 0.01, 0.03, 0.1, 0.5])
    res["observable"] = "z_j_bonds"
    out = match(refs(row), runs, res).iloc[0]
    assert out.verdict == "not run" and "lacks 0.003" in out.note
    runs, res = fit_data([0.5, 0.03, 0.01, 0.003, 0.001])
    res["observable"] = "z_j_bonds"
    out = match(refs(row), runs, res).iloc[0]
    assert out.verdict == "agrees" and "fit over alpha = 0.001, 0.003, 0.01, 0.03" in out.note


def test_a_fit_of_runs_under_other_conditions_says_so_and_gives_ours():
    """The study has every aspect ratio of the fit, but under another rod contact rule
    than the paper's: ``conditions differ`` with its fit beside it, not ``not run``."""
    over = "0.001;0.003;0.01;0.03"
    row = {**fit_ref("z_j_bonds_fit_exponent", 0.68, 0.13), "over": over,
           "conditions": "dimension=2; rod_contact=end_bonds_distinct"}
    runs, res = fit_data([0.001, 0.003, 0.01, 0.03])
    res["observable"] = "z_j_bonds"
    out = match(refs(row), runs.assign(rod_contact="end_bonds"), res).iloc[0]
    assert out.verdict == ("conditions differ: rod_contact (ours end_bonds, paper "
                           "end_bonds_distinct)")
    assert out.ours == pytest.approx(0.68, abs=0.05) and np.isnan(out.diff_sigma)
    out = match(refs(row), runs.assign(rod_contact="end_bonds_distinct"), res).iloc[0]
    assert out.verdict == "agrees"


def test_a_fit_that_does_not_determine_its_parameter_is_unresolved():
    """Points that a power law with an offset cannot pin down (one of them far off the
    curve, one seed each) give an exponent with an error larger than itself: no verdict."""
    runs, res = fit_data([0.001, 0.01, 0.03, 0.5], spread=0.0)
    res["observable"] = "z_j_bonds"
    res.loc[res["value"] == res["value"].min(), "value"] += 0.5  # alpha 0.001 off the law
    out = match(refs(fit_ref("z_j_bonds_fit_exponent", 0.68, 0.13)), runs, res).iloc[0]
    assert out.verdict == "unresolved" and "does not determine x" in out.note


def test_a_constant_trend_compares_every_pair_not_only_neighbours():
    """A scattered middle point is within reach of both ends, which differ from each
    other by far more than their errors: not constant."""
    runs, res = trend_data({0.5: 0.80, 1.0: 0.85, 4.0: 0.90}, spread=0.001)
    wide = res["case"] == "a1.0"
    res.loc[wide, "value"] = res.loc[wide, "value"].to_numpy() + np.array([-0.2, 0.2])
    assert match(refs(trend("constant")), runs, res).iloc[0].verdict == "differs"
