"""Jamming point from the first linear pressure rise."""
import numpy as np
import pandas as pd
import pytest

from analysis.jamming import JammingFitError, JammingPoint, first_rise


def test_recovers_known_jamming_point(rng):
    phi = np.linspace(0.55, 0.70, 300)
    p = np.where(phi > 0.642, 0.35 * (phi - 0.642), 0.0) + rng.uniform(0, 2e-5, phi.size)
    # a dynamic pressure spike well below jamming must not be taken as the rise
    p[50] = 5e-3
    jp = JammingPoint(window=(1e-3, 1e-2)).compute(phi, p)
    assert jp.phi_j == pytest.approx(0.642, abs=5e-4)
    assert jp.phi_j_err < 1e-3
    assert jp.slope == pytest.approx(0.35, rel=0.05)
    assert jp.rows.start > 50


def test_pressure_scale_is_applied():
    phi = np.linspace(0.6, 0.75, 151)
    p = 1e5 * np.clip(0.2 * (phi - 0.65), 0, None)
    jp = JammingPoint(window=(1e-3, 1e-2), p_scale=1e5).compute(phi, p)
    assert jp.phi_j == pytest.approx(0.65, abs=1e-9)
    assert jp.slope == pytest.approx(0.2 * 1e5)


def test_a_pressure_still_relaxing_at_the_start_is_skipped():
    # the slow stage of a two-stage compression starts with the fast stage's excess
    # pressure (above the whole window), which relaxes before the jamming rise
    phi = np.linspace(0.80, 0.90, 400)
    p = 0.33 * np.clip(phi - 0.842, 0, None) + 8e-3 * np.exp(-(phi - 0.80) / 0.004)
    rows = first_rise(p, 1e-3, 1e-2)
    assert phi[rows.start] > 0.84
    assert JammingPoint(window=(1e-3, 1e-2)).compute(phi, p).phi_j == pytest.approx(0.842,
                                                                                    abs=1e-3)


def test_no_rise_is_a_clear_error():
    with pytest.raises(JammingFitError, match="never reaches"):
        first_rise(np.zeros(10), 1e-3, 1e-2)
    with pytest.raises(JammingFitError, match="starts jammed"):
        first_rise(np.linspace(0.02, 0.05, 10), 1e-3, 1e-2)
    with pytest.raises(ValueError, match="0 < p_lo < p_hi"):
        JammingPoint(window=(1e-2, 1e-3))


def test_two_stage_compression_fits_the_slow_stage_only(tmp_path, rng):
    """A fast stage that overshoots (its pressure crosses the whole fit window) must not be
    fitted: with ``fit_from = phi_fast`` the rise of the slow stage gives phi_J."""
    from analysis.summary import analyse_compression
    from pysim import io

    fast = np.linspace(0.40, 0.80, 200)
    p_fast = 0.05 * np.exp(-((fast - 0.75) / 0.03) ** 2)  # transient jamming
    slow = np.linspace(0.80, 0.90, 300)
    p_slow = np.where(slow > 0.842, 0.33 * (slow - 0.842), 0.0) + rng.uniform(0, 1e-5, 300)
    phi, p = np.concatenate([fast, slow]), np.concatenate([p_fast, p_slow])
    with open(tmp_path / "thermo.dat", "w") as fh:
        fh.write(io.thermo_header())
        for k, (f, q) in enumerate(zip(phi, p)):
            io.write_thermo_row(fh, (k * 100, k, f, q, 0.0, 0.0, 0))
    x = rng.uniform(0, 10, (4, 3))
    x[:, 2] = 0
    with open(tmp_path / "particles.dump", "w") as fh:
        io.write_particles_frame(fh, 0, np.array([10.0, 10.0, 0.0]), np.array([True] * 3),
                                 np.arange(1, 5), np.ones(4, int), x, np.full(4, 0.5),
                                 axis=np.tile([1.0, 0, 0], (4, 1)), length=np.zeros(4))
    with open(tmp_path / "contacts.dump", "w") as fh:
        io.write_contacts_frame(fh, 0, np.array([10.0, 10.0, 0.0]), np.array([True] * 3),
                                np.zeros((0, 2), int), np.zeros((0, 10)))
    window = (1e-3, 1e-2)
    rows, _curves, _thermo = analyse_compression(tmp_path, window, 1.0, fit_from=0.80)
    phi_j = dict((name, v) for name, v, _e in rows)["phi_j"]
    assert phi_j == pytest.approx(0.842, abs=2e-3)
    rows, _curves, _thermo = analyse_compression(tmp_path, window, 1.0)
    assert dict((name, v) for name, v, _e in rows)["phi_j"] < 0.8  # the transient, fitted


def test_z_j_skips_frames_without_a_backbone(tmp_path, monkeypatch):
    """The first frame above the extrapolated phi_J can still be unjammed: rattler
    removal empties it (z_rattler_free 0). z_J is that of the first frame that keeps a
    backbone, not 0."""
    from analysis import summary
    from pysim import io

    phi = np.linspace(0.60, 0.66, 61)
    p = np.where(phi > 0.63, 0.5 * (phi - 0.63), 0.0)
    with open(tmp_path / "thermo.dat", "w") as fh:
        fh.write(io.thermo_header())
        for k, (f, q) in enumerate(zip(phi, p)):
            io.write_thermo_row(fh, (k * 100, k, f, q, 0.0, 0.0, 0))
    curves = pd.DataFrame({"step": [0, 1, 2, 3], "phi": [0.62, 0.6301, 0.632, 0.64],
                           "z": [3.0, 4.5, 5.6, 6.2], "z_rattler_free": [0.0, 0.0, 5.9, 6.4],
                           "z_bonds": [3.0, 4.5, 5.6, 6.2], "n_rattlers": [500, 500, 80, 20],
                           "n": [500] * 4, "s_nematic": [np.nan] * 4})
    monkeypatch.setattr(summary, "frame_curves", lambda run, c_min: curves.copy())
    rows, _curves, _thermo = summary.analyse_compression(tmp_path, (1e-3, 1e-2), 1.0)
    got = {name: v for name, v, _e in rows}
    assert got["phi_j"] == pytest.approx(0.63, abs=1e-3)
    assert got["z_j"] == 5.9 and got["phi_at_z_j"] == 0.632
    assert got["rattler_fraction_j"] == pytest.approx(80 / 500)
