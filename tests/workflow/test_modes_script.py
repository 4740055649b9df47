"""``workflows.scripts.modes`` on a small 2-D rod packing written as a finished pysim
``jammed`` run: the per-state summary, the per-mode table and the figure."""
import json

import numpy as np
import pandas as pd
import pytest
import yaml

from pysim import io
from tests.pysim.helpers import overlapping_rods
from rodcase.case import validate_case
from workflows.scripts import modes


def fake_jammed_run(tmp_path, n=30, alpha=1.0, phi=0.9, seed=4):
    """A run directory ``<variant>/seed1/pysim`` whose final frame is a packing of ``n``
    rods squeezed to ``phi`` (overlapping, not yet relaxed: the script relaxes it)."""
    case = validate_case({
        "particles": {"n": n, "dimension": 2, "aspect_ratio": alpha,
                      "diameter": {"distribution": "bidisperse", "mean": 1.0, "ratio": 1.4}},
        "contact": {"law": "harmonic", "k_n": 1.0, "spine_contact": "end_bonds"},
        "protocol": {"name": "jammed", "phi_init": 0.4, "rate": 1e-3, "dt": 0.01},
        "output": {"thermo_every": 500, "dump_every": 100000}, "seed": seed})
    seed_dir = tmp_path / f"alpha{alpha:g}" / "seed1"
    run = seed_dir / "pysim"
    run.mkdir(parents=True)
    (seed_dir / "case.yaml").write_text(yaml.safe_dump(case))
    sim = overlapping_rods(2, n, alpha, phi, seed, "end_bonds")
    s = sim.state
    ids = np.arange(1, n + 1)
    box = s.box.copy()
    with open(run / "particles.dump", "w") as fh:
        io.write_particles_frame(fh, 0, box, s.periodic, ids, np.ones(n, int), s.x, s.radius,
                                 s.u, s.length)
    ij, rec = sim.contact_table()
    with open(run / "contacts.dump", "w") as fh:
        io.write_contacts_frame(fh, 0, box, s.periodic, ids[ij], rec)
    (run / "run.json").write_text(json.dumps({"status": "ok", "converged": True}))
    return run


def test_modes_of_a_relaxed_rod_packing(tmp_path):
    run = fake_jammed_run(tmp_path)
    table, summary = modes.stable_state_modes(run)
    assert not summary["exact"]  # no stable_state.npz: read from the dump
    assert summary["n_dof"] == 3 * summary["n_particles"] == len(table)
    # relaxed to a minimum: no negative mode, the two translations among the zero modes,
    # and the stress part never creates zero modes (H_k has at least as many)
    assert summary["negative_modes"] == 0
    assert summary["zero_modes"] >= 2
    assert summary["zero_modes_stiffness"] >= summary["zero_modes"]
    assert summary["force_residual_max"] < 1e-3
    assert table.omega2.is_monotonic_increasing
    # a rigid translation spreads evenly over the particles in the paper's coordinates:
    # its ratio is 1 to rounding
    assert table.pr.between(0, 1 + 1e-12).all()
    fractions = table[["rotational", "parallel", "perpendicular"]].sum(axis=1)
    np.testing.assert_allclose(fractions, 1.0, atol=1e-9)
    out = tmp_path / "figures" / "modes.png"
    assert modes.main(["--runs", str(run), "--out", str(out),
                       "--table", str(tmp_path / "modes.csv"), "--energies"]) == 0
    assert out.stat().st_size > 10_000
    rows = pd.read_csv(tmp_path / "modes.csv")
    assert list(rows.variant) == ["alpha1"] and rows.n_dof.iloc[0] == summary["n_dof"]
    per_mode = pd.read_csv(tmp_path / "modes.modes.csv.gz")
    assert len(per_mode) == summary["n_dof"]


def test_the_papers_coordinates_and_the_masses_share_zero_and_negative_modes(tmp_path):
    run = fake_jammed_run(tmp_path)
    paper, s_paper = modes.stable_state_modes(run, "paper")
    mass, s_mass = modes.stable_state_modes(run, "mass")
    # the two matrices are congruent (Sylvester's law of inertia), but their spectra and
    # modes differ: the paper's rotations are weighed by A^2, ours by the moment of inertia
    assert s_paper["metric"] == "paper" and s_mass["metric"] == "mass"
    for key in ("zero_modes", "negative_modes", "n_dof", "bonds"):
        assert s_paper[key] == s_mass[key]
    assert not np.allclose(paper.omega2, mass.omega2)
    with pytest.raises(ValueError, match="metric 'inertia' is not one of paper, mass"):
        modes.stable_state_modes(run, "inertia")


def test_a_compression_reaches_the_energy_asked_for(tmp_path):
    run = fake_jammed_run(tmp_path)
    _, start = modes.stable_state_modes(run)
    target = 4.0 * start["energy_density"]
    case, sim, step = modes.compressed_state(run, target, rtol=0.1)
    _, above = modes.modes_of(sim, case, step)
    assert abs(above["energy_density"] / target - 1) <= 0.1
    assert above["phi"] > start["phi"] and above["negative_modes"] == 0
    with pytest.raises(ValueError, match="no compression reached U/L\\^2 = "):
        modes.compressed_state(run, target, rtol=1e-9, tries=1)


def test_the_script_follows_the_bands_up_an_energy_ladder(tmp_path):
    run = fake_jammed_run(tmp_path)
    u0 = modes.stable_state_modes(run)[1]["energy_density"]
    table = tmp_path / "modes.csv"
    assert modes.main(["--runs", str(run), "--out", str(tmp_path / "m.png"),
                       "--table", str(table), "--energies", str(4 * u0), str(16 * u0)]) == 0
    row = pd.read_csv(table).iloc[0]
    for name in ("omega_below_gap", "omega_middle"):
        assert np.isfinite(row[f"{name}_exponent"])
    # the low band is the modes below the resolution but the translations: none here
    # beyond them in this small, well-compressed packing, so no mean and no exponent
    assert (row.zero_modes == row.translations) == np.isnan(row.omega_low_exponent)
    ladder = pd.read_csv(tmp_path / "modes.energies.csv")
    assert len(ladder) == 3 and ladder.energy_density.is_monotonic_increasing
    # phi - phi_J up the ladder, from the line through sqrt(U) against phi
    assert (ladder.phi_minus_phi_j > 0).all() and ladder.phi_minus_phi_j.is_monotonic_increasing
    assert row[f"phi_minus_phi_j_{modes.energy_tag(16 * u0)}"] == ladder.phi_minus_phi_j.iloc[2]
    # the rungs' band frequencies are the ones the exponents are fitted to
    x = modes.frequency_exponents(ladder.energy_density,
                                  ladder[list(modes.BAND_FREQUENCIES)].to_numpy())
    for name in modes.BAND_FREQUENCIES:
        assert row[f"{name}_exponent"] == pytest.approx(x[f"{name}_exponent"], rel=1e-12, nan_ok=True)
        assert row[name] == pytest.approx(ladder[name].iloc[0], rel=1e-12, nan_ok=True)  # rung 0
    per_mode = pd.read_csv(tmp_path / "modes.modes.csv.gz")
    assert per_mode.energy_density.nunique() == 3 and len(per_mode) == 3 * row.n_dof


def test_distance_to_jamming_extrapolates_the_square_root_of_the_energy():
    phi_j, c = 0.85, 0.4
    phi = phi_j + np.array([1e-7, 2e-7, 2e-6, 5e-4])
    u = (c * (phi - phi_j)) ** 2
    u[-1] *= 3.0  # far above jamming the line bends: left out of the fit (> 1e-12)
    np.testing.assert_allclose(modes.distance_to_jamming(u, phi), phi - phi_j, rtol=1e-6)
    assert np.isnan(modes.distance_to_jamming(u[:1], phi[:1])).all()
    assert [modes.energy_tag(x) for x in (1e-15, 1e-9, 3e-12)] == ["u1e15", "u1e9", "u3e12"]


def test_frequency_exponents_leave_out_bands_without_a_mean():
    u = np.array([1e-15, 1e-12, 1e-9])
    means = np.column_stack([u**0.25, [np.nan, 1e-6, 3e-5], [np.nan, np.nan, 1.0]])
    x = modes.frequency_exponents(u, means)
    assert x["omega_below_gap_exponent"] == pytest.approx(0.25, rel=1e-9)
    assert x["omega_low_exponent"] == pytest.approx(np.log10(30) / 3, rel=1e-9)
    assert np.isnan(x["omega_middle_exponent"])


def test_frequency_exponents_are_log_log_slopes():
    u = np.array([1e-15, 1e-14, 1e-12])
    means = np.column_stack([3.0 * u**0.25, 0.1 * u**0.5, 2.0 * u**0.25])
    x = modes.frequency_exponents(u, means)
    assert x["omega_below_gap_exponent"] == pytest.approx(0.25, rel=1e-9)
    assert x["omega_low_exponent"] == pytest.approx(0.5, rel=1e-9)
    assert x["omega_middle_exponent"] == pytest.approx(0.25, rel=1e-9)


def test_modes_read_the_full_precision_state_when_there_is_one(tmp_path):
    from pysim import checkpoint
    from pysim.protocols.jammed import STABLE_STATE

    run = fake_jammed_run(tmp_path)
    sim = overlapping_rods(2, 30, 1.0, 0.9, 4, "end_bonds")
    sim.minimize(f_tol=1e-12, max_iter=50_000)
    checkpoint.save(sim, run / STABLE_STATE)
    _, summary = modes.stable_state_modes(run)
    assert summary["exact"] and summary["negative_modes"] == 0
    assert summary["force_residual_max"] < 1e-3


def test_modes_refuse_another_contact_law(tmp_path):
    run = fake_jammed_run(tmp_path)
    case = yaml.safe_load((run.parent / "case.yaml").read_text())
    case["contact"]["law"] = "hooke"
    (run.parent / "case.yaml").write_text(yaml.safe_dump(case))
    with pytest.raises(ValueError, match="harmonic law, got 'hooke'"):
        modes.stable_state_modes(run)
    # the script skips states that came apart, not cases it cannot read
    with pytest.raises(ValueError, match="harmonic law, got 'hooke'"):
        modes.main(["--runs", str(run), "--out", str(tmp_path / "m.png"),
                    "--table", str(tmp_path / "modes.csv"), "--energies"])


def test_a_packing_that_relaxes_apart_is_skipped_with_its_reason(tmp_path, capsys):
    """A run marked converged whose packing, relaxed again, unjams (every particle a
    rattler) has no modes to take: a one-line reason, and the other runs go on."""
    loose = fake_jammed_run(tmp_path / "loose", phi=0.5)
    with pytest.raises(ValueError, match="has no rigid backbone .* it was not jammed$"):
        modes.stable_state_modes(loose)
    good = fake_jammed_run(tmp_path / "good")
    assert modes.main(["--runs", str(loose), str(good), "--out", str(tmp_path / "m.png"),
                       "--table", str(tmp_path / "modes.csv"), "--energies"]) == 0
    assert f"modes: skipping {loose}: the relaxed packing" in capsys.readouterr().err
    assert len(pd.read_csv(tmp_path / "modes.csv")) == 1
