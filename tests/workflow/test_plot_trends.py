"""The trends figure keeps runs of another protocol (LIGGGHTS' settled rod beds) apart
from the study's compressions, so that no line joins the two."""
import numpy as np
import pandas as pd
import pytest

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


def test_deposits_draw_one_line_per_bond_number(tmp_path, monkeypatch):
    """Deposits vary the aspect ratio and the Bond number: with ``--series bond_number``
    each engine gets one line per Bond number on every deposit observable, and the mean
    angle and K panels carry the isotropic references (32.7 deg in 3-D, K = 1)."""
    from analysis import plots

    rows = []
    for alpha in (1.0, 4.0):
        for bo in (0.0, 1000.0):
            for engine in ("pysim", "lammps"):
                for obs, value in (("phi_deposit", 0.5 - bo * 1e-4), ("angle_mean", 25 + alpha),
                                   ("k_ratio", 0.5 + bo * 1e-4), ("settled", 1.0)):
                    rows.append(dict(study="dep", case=f"a{alpha}_b{bo}", engine=engine,
                                     seed=1, observable=obs, value=value, alpha=alpha,
                                     bond_number=bo))
    summary = tmp_path / "summary.csv"
    pd.DataFrame(rows).to_csv(summary, index=False)
    figs = []
    monkeypatch.setattr(plots, "_save", lambda fig, out: figs.append(fig))
    assert plot_trends.main(["--summary", str(summary), "--study", "dep", "--parameter", "alpha",
                             "--series", "bond_number", "--protocol", "deposit",
                             "--out", str(tmp_path / "t.png")]) == 0
    axes = figs[0].axes
    assert [ax.get_ylabel() for ax in axes] == ["phi_deposit", "angle_mean", "k_ratio"]
    # every deposit reports 'settled' (its settling test): no '<engine> settled' series
    for ax in axes:
        labels = {ln.get_label() for ln in ax.get_lines()} | \
            {c.get_label() for c in ax.containers}
        assert {"pysim, bond_number 0", "pysim, bond_number 1000", "lammps, bond_number 0",
                "lammps, bond_number 1000"} <= labels
    refs = {ax.get_ylabel(): [ln.get_ydata()[0] for ln in ax.get_lines()
                              if ln.get_label().startswith("isotropic")] for ax in axes}
    assert refs["angle_mean"] == [pytest.approx(32.704, abs=1e-3)]
    assert refs["k_ratio"] == [1.0]
    # an unknown series column is a clear error
    with pytest.raises(ValueError, match="series 'nope'"):
        plot_trends.main(["--summary", str(summary), "--study", "dep", "--parameter", "alpha",
                          "--series", "nope", "--out", str(tmp_path / "t.png")])


def test_3d_rods_get_theory_and_caging_number():
    """3-D packings versus alpha carry the random contact equation and its thin-rod limit
    on phi_J, and the isostatic count and the caging number (computed at the study's
    aspect ratios: a sphere needs 7 contacts) on z_J."""
    refs = plot_trends.references("alpha", 3, alphas=[0.0, 4.0])
    assert [r[0] for r in refs["phi_j"]] == ["random contact eq., <C> = 10",
                                             "thin-rod limit, phi alpha = 5"]
    label, x, y = refs["phi_j"][1]
    assert np.allclose(x * y, 5.0)
    (iso, _, _), (cage, ca, cn) = refs["z_j"]
    assert cage == "caging number" and list(ca) == [0.0, 4.0]
    assert abs(cn[0] - 7.0) < 0.6 and 9.0 < cn[1] < 11.5  # 200 trials: stderr ~0.2
    assert "z_j" not in plot_trends.references("alpha", 2) and plot_trends.references("sigma", 3) == {}


def test_deposits_against_the_bond_number_alone(tmp_path, monkeypatch):
    """A deposition study that varies only the Bond number (0 to 1e4) is drawn against it
    on an axis linear up to the smallest positive Bond number and logarithmic above,
    with the seeds' mean and the isotropic references, major stress axes included."""
    from analysis import plots

    rows = []
    for bo in (0.0, 100.0, 1e3, 1e4):
        for seed in (1, 2, 3):
            for obs, value in (("phi_deposit", 0.5 - 0.01 * seed), ("major_order", 0.6),
                               ("angle_mean", 26.0)):
                rows.append(dict(study="dep", case=f"bo{bo:g}", engine="pysim", seed=seed,
                                 observable=obs, value=value, bond_number=bo))
    summary = tmp_path / "summary.csv"
    pd.DataFrame(rows).to_csv(summary, index=False)
    figs = []
    monkeypatch.setattr(plots, "_save", lambda fig, out: figs.append(fig))
    assert plot_trends.main(["--summary", str(summary), "--study", "dep", "--parameter",
                             "bond_number", "--dimension", "2", "--protocol", "deposit",
                             "--out", str(tmp_path / "t.png")]) == 0
    axes = {ax.get_ylabel(): ax for ax in figs[0].axes}
    assert set(axes) == {"phi_deposit", "angle_mean", "major_order"}
    assert all(ax.get_xscale() == "symlog" for ax in axes.values())
    means = np.asarray(axes["phi_deposit"].containers[0].lines[0].get_ydata(), dtype=float)
    np.testing.assert_allclose(means, 0.48)  # the mean over the three seeds
    refs = {ylabel: [ln.get_ydata()[0] for ln in ax.get_lines()
                     if ln.get_label().startswith(("isotropic", "major axes"))]
            for ylabel, ax in axes.items()}
    assert refs["angle_mean"] == [45.0] and refs["major_order"] == [0.0]


def test_the_papers_values_ride_along_the_trend(tmp_path):
    """A 2-D jamming study over alpha gets Marschall & Teitel's phi_J and z_J at their
    aspect ratios (every alpha of the table, not only ours), each with its uncertainty."""
    import yaml

    from workflows.studies import load_config

    cfg = load_config("workflows/config/jamming_2d_paper.yaml")
    (study, variant, seed), case = next(iter(cfg["_cases"].items()))
    d = tmp_path / study / variant / f"seed{seed}"
    d.mkdir(parents=True)
    (d / "case.yaml").write_text(yaml.safe_dump(case))
    pts = plot_trends.paper_points(tmp_path, study, "alpha", ["phi_j", "z_j_bonds"])
    phi = {p["x"]: p["y"] for p in pts if p["observable"] == "phi_j"}
    assert phi[0.0] == pytest.approx(0.8412) and phi[1.0] == pytest.approx(0.8875)
    assert phi[4.0] == pytest.approx(0.866)
    z = {p["x"]: p for p in pts if p["observable"] == "z_j_bonds"}
    assert z[0.01]["y"] == pytest.approx(4.43) and z[0.01]["yerr"] == pytest.approx(0.03)
    assert all(p["label"].startswith("marschall2018") for p in pts)
    assert plot_trends.paper_points(tmp_path, study, "kappa", ["phi_j"]) == []
    assert plot_trends.paper_points(tmp_path, "no_such_study", "alpha", ["phi_j"]) == []


def test_the_jamming_limits_ride_on_the_phi_j_panel(tmp_path):
    """Polydisperse spheres along sigma get Baranau and Tsigelnitskiy's phi_LT, phi_RCP
    and phi_GCP (Table 4) on the phi_J panel, each under its own name."""
    import yaml

    from workflows.studies import load_config

    cfg = load_config("workflows/config/random_packings_paper.yaml")
    key, case = next((k, c) for k, c in cfg["_cases"].items()
                     if k[0] == "random_packings_paper_poly")
    d = tmp_path / key[0] / key[1] / f"seed{key[2]}"
    d.mkdir(parents=True)
    (d / "case.yaml").write_text(yaml.safe_dump(case))
    pts = plot_trends.paper_points(tmp_path, key[0], "sigma", ["phi_j"])
    assert {p["observable"] for p in pts} == {"phi_j"}
    by = {(p["label"], p["x"]): p["y"] for p in pts}
    assert by[("baranau2014 phi_rcp", 0.3)] == pytest.approx(0.6676)
    assert by[("baranau2014 phi_gcp", 0.25)] == pytest.approx(0.6716)
    assert by[("baranau2014 phi_lt", 0.15)] == pytest.approx(0.6426)


def test_rods_get_the_papers_contact_and_caging_numbers(tmp_path):
    """3-D rods along alpha: Wouterse et al.'s <C> (rattlers counted) on the
    z_j_with_rattlers panel and their caging numbers on the z_j panel."""
    import yaml

    from workflows.studies import load_config

    cfg = load_config("workflows/config/random_packings_paper.yaml")
    key, case = next((k, c) for k, c in cfg["_cases"].items()
                     if c["particles"]["aspect_ratio"] == 1.5)
    d = tmp_path / key[0] / key[1] / f"seed{key[2]}"
    d.mkdir(parents=True)
    (d / "case.yaml").write_text(yaml.safe_dump(case))
    pts = plot_trends.paper_points(tmp_path, key[0], "alpha", plot_trends.OBSERVABLES)
    c = {p["x"]: p["y"] for p in pts if p["observable"] == "z_j_with_rattlers"}
    assert c[1.5] == pytest.approx(9.5)
    assert any(p["observable"] == "z_j" and p["label"] == "wouterse caging_number"
               for p in pts)
