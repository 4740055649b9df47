"""The engines' verdict: a Welch equivalence test with the tolerance."""
import numpy as np
import pandas as pd
from scipy import stats

from analysis.compare import compare, verdict


def _v(a, b, tol):
    a, b = np.asarray(a, float), np.asarray(b, float)
    return verdict(a.mean(), a.std(ddof=1) if len(a) > 1 else np.nan, len(a),
                   b.mean(), b.std(ddof=1) if len(b) > 1 else np.nan, len(b), tol)


def test_p_values_equal_scipys_one_sided_welch_tests_on_shifted_samples():
    rng = np.random.default_rng(3)
    a, b, tol = rng.normal(0.640, 0.003, 4), rng.normal(0.642, 0.005, 3), 0.01
    v = _v(a, b, tol)
    p_lower = stats.ttest_ind(b + tol, a, equal_var=False, alternative="greater").pvalue
    p_upper = stats.ttest_ind(b - tol, a, equal_var=False, alternative="less").pvalue
    assert np.isclose(v["p_equivalent"], max(p_lower, p_upper), rtol=1e-10)
    shift = tol if b.mean() > a.mean() else -tol
    p_diff = stats.ttest_ind(b - shift, a, equal_var=False,
                             alternative="greater" if shift > 0 else "less").pvalue
    assert np.isclose(v["p_different"], p_diff, rtol=1e-10)


def test_agree_differ_and_inconclusive():
    tol = 0.01
    assert _v([0.640, 0.641, 0.639, 0.640], [0.642, 0.641, 0.643, 0.642], tol)["verdict"] == \
        "agree"
    assert _v([0.640, 0.641, 0.639, 0.640], [0.690, 0.691, 0.689, 0.690], tol)["verdict"] == \
        "DIFFER"
    # two seeds each, a spread as large as the tolerance: neither can be shown
    v = _v([0.630, 0.650], [0.645, 0.665], tol)
    assert v["verdict"] == "inconclusive" and v["dof"] > 0
    # a difference just beyond the tolerance is not called DIFFER on two noisy seeds
    assert _v([0.640, 0.650], [0.652, 0.662], tol)["verdict"] == "inconclusive"


def test_one_seed_falls_back_to_the_tolerance_and_says_so():
    v = _v([0.640], [0.645, 0.646], 0.01)
    assert v["verdict"] == "agree" and "one seed" in v["basis"]
    assert _v([0.640], [0.660], 0.01)["verdict"] == "DIFFER"
    assert verdict(np.nan, 0, 2, 0.6, 0.0, 2, 0.01)["verdict"] == "n/a"


def test_compare_pairs_engines_in_reference_order():
    rows = [{"study": "s", "case": "c", "engine": e, "seed": k, "observable": "phi_j",
             "value": v, "uncertainty": np.nan}
            for e, vals in (("lammps", [0.640, 0.641]), ("pysim", [0.6405, 0.6402]))
            for k, v in enumerate(vals, start=1)]
    cmp = compare(pd.DataFrame(rows))
    assert list(cmp[["engine_a", "engine_b"]].iloc[0]) == ["pysim", "lammps"]
    assert cmp.verdict.iloc[0] in {"agree", "inconclusive"}
    assert "Welch" in cmp.basis.iloc[0]
