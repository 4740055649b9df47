"""Shared fixtures of the workflow tests: a tapping case and a small reference table."""
import pandas as pd

CASE_TAP = {"particles": {"n": 1000, "aspect_ratio": 4.0,
                          "diameter": {"distribution": "mono", "mean": 0.523e-3}},
            "contact": {"law": "hooke", "restitution": 0.4, "friction": 0.5},
            "container": {"shape": "cylinder", "diameter": 8e-3},
            "protocol": {"name": "tapping", "intensity": 2.0, "taps": 1000}}


def reference_tables(tmp_path):
    """A folder with one reference table: a tapping density at Gamma 2 (t-01) and 1.5
    (t-02)."""
    folder = tmp_path / "refs"
    folder.mkdir()
    cols = ["id", "paper", "where", "study", "kind", "observable", "alpha", "d", "sigma",
            "e_n", "Gamma", "bo_g", "layer", "tap", "n", "value", "uncertainty",
            "uncertainty_kind", "conditions", "vary", "over", "expect", "claim"]
    row = dict.fromkeys(cols, "")
    row.update(id="t-01", paper="t", where="Sec. 5", study="tapping", kind="value",
               observable="phi_late", alpha=4, e_n=0.4, Gamma=2, tap=2000, n=1000,
               value=0.75, uncertainty=0.01, uncertainty_kind="figure",
               conditions="dimension=3;protocol=tapping", claim="density after 2000 taps")
    other = {**row, "id": "t-02", "Gamma": 1.5}
    pd.DataFrame([row, other], columns=cols).to_csv(folder / "t.csv", index=False)
    return folder
