"""The finite-size order script: table and figure from the runs' frame curves."""
import json

import numpy as np
import pandas as pd
import pytest
import yaml

from workflows.scripts.plot_order import main, run_curves


def _run(root, variant, seed, n, alpha, status="ok", rng=None):
    d = root / "study" / variant / f"seed{seed}" / "pysim"
    d.mkdir(parents=True)
    (d / "run.json").write_text(json.dumps({"status": status}))
    (d.parent / "case.yaml").write_text(yaml.safe_dump({
        "particles": {"n": n, "dimension": 2, "aspect_ratio": alpha,
                      "diameter": {"distribution": "mono", "mean": 1.0}},
        "contact": {"law": "harmonic", "k_n": 1.0},
        "protocol": {"name": "compress", "integrator": "overdamped", "phi_init": 0.4,
                     "rate": 1e-3, "phi_final": 0.88, "dt": 0.01},
        "seed": seed}))
    phi = np.linspace(0.4, 0.88, 25)
    s = rng.rayleigh(np.sqrt(0.5), size=(2, len(phi)))  # sqrt(N) S_n of random angles
    pd.DataFrame({"step": np.arange(len(phi)), "phi": phi, "n": n, "sqrt_n_s2": s[0],
                  "sqrt_n_s4": s[1]}).to_csv(d / "curves.csv", index=False)
    return d


def test_order_scaling_table_and_figure(tmp_path, rng):
    runs = [_run(tmp_path, f"alpha1_n{n}", seed, n, 1.0, rng=rng)
            for n in (256, 1024) for seed in (1, 2)]
    runs.append(_run(tmp_path, "alpha1_n4096", 1, 4096, 1.0, status="failed", rng=rng))
    cv = run_curves(runs)
    assert set(cv.n) == {256, 1024} and set(cv.seed) == {1, 2} and set(cv.alpha) == {1.0}
    out, table = tmp_path / "order.png", tmp_path / "order.csv"
    assert main(["--runs", *map(str, runs), "--out", str(out), "--table", str(table)]) == 0
    assert out.stat().st_size > 0
    t = pd.read_csv(table)
    assert list(t.n) == [256, 1024] and list(t.seeds) == [2, 2]
    # frames at phi >= 0.7 only: 10 of the 25 per run, two runs per N
    assert list(t.frames) == [2 * int(np.sum(np.linspace(0.4, 0.88, 25) >= 0.7))] * 2
    assert t.mean_s2.iloc[0] == pytest.approx(t.mean_sqrt_n_s2.iloc[0] / 16)
    # one sample per run: the mean over its dense frames
    dense = cv[(cv.phi >= 0.7) & (cv.n == 256)].groupby("seed").sqrt_n_s2.mean()
    assert t.mean_sqrt_n_s2.iloc[0] == pytest.approx(dense.mean())
    assert t.sem_sqrt_n_s2.iloc[0] == pytest.approx(dense.std(ddof=1) / np.sqrt(2))
    with pytest.raises(SystemExit, match="no successful run"):
        main(["--runs", str(runs[-1]), "--out", str(out), "--table", str(table)])
