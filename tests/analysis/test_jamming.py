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


def test_the_rise_ends_at_the_first_plastic_drop():
    """The fit stops before the first fall of the pressure by more than 5 % (a plastic
    rearrangement, as the paper fits only the rise before any): rows of alpha 4 steps,
    where fitting across the drop at 0.878 gave 0.8572 instead of the rise's 0.8618."""
    phi = 0.862 + 0.001 * np.arange(27)
    p = 1e-4 * np.array([1.92, 4.27, 5.80, 8.22, 10.71, 13.22, 15.77, 18.32, 20.94, 23.52,
                         26.12, 28.79, 31.48, 33.27, 35.93, 38.63, 30.22, 31.75, 34.39,
                         37.01, 39.57, 39.18, 41.82, 44.47, 47.15, 49.82, 52.55])
    rows = first_rise(p, 1e-3, 5e-3)
    assert (phi[rows.start], phi[rows.stop - 1]) == pytest.approx((0.866, 0.877))
    jp = JammingPoint(window=(1e-3, 5e-3)).compute(phi, p)
    assert jp.phi_j == pytest.approx(0.8618, abs=2e-4)
    # a dip of 1 % (as at 0.883) does not end a rise: without the large drop, and with
    # that dip at 0.880, the fit runs to the first row at p_hi (0.882)
    smooth = np.where(phi < 0.878, p, 2.6e-4 * (phi - 0.8618) / 1e-3)
    smooth[18] = 0.99 * smooth[17]
    assert phi[first_rise(smooth, 1e-3, 5e-3).stop - 1] == pytest.approx(0.882)


def test_no_rise_is_a_clear_error():
    with pytest.raises(JammingFitError, match="never reaches"):
        first_rise(np.zeros(10), 1e-3, 1e-2)
    # the maximum named is the one after the fall below p_lo, not a fast stage's before it
    with pytest.raises(JammingFitError, match=r"max 0\.004\)"):
        first_rise(np.array([6e-3, 4e-3, 7e-4, 2e-3, 4e-3]), 1e-3, 5e-3)
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
    removal empties it (z_rattler_free 0). z_J comes from the frames that keep a backbone,
    extrapolated to phi_J (it used to be the first such frame's z at its own phi, 0.632),
    not 0."""
    from analysis import summary
    from pysim import io

    phi = np.linspace(0.60, 0.66, 61)
    p = np.where(phi > 0.63, 0.5 * (phi - 0.63), 0.0)
    with open(tmp_path / "thermo.dat", "w") as fh:
        fh.write(io.thermo_header())
        for k, (f, q) in enumerate(zip(phi, p)):
            io.write_thermo_row(fh, (k * 100, k, f, q, 0.0, 0.0, 0))
    curves = pd.DataFrame({"step": [0, 1, 2, 3], "phi": [0.62, 0.6301, 0.632, 0.64],
                           "pressure": [0.0, 5e-5, 1e-3, 5e-3],
                           "z": [3.0, 4.5, 5.6, 6.2], "z_rattler_free": [0.0, 0.0, 5.9, 6.4],
                           "z_bonds": [3.0, 4.5, 5.6, 6.2], "n_rattlers": [500, 500, 80, 20],
                           "n": [500] * 4, "s_nematic": [np.nan] * 4})
    monkeypatch.setattr(summary, "frame_curves", lambda run, c_min, friction: curves.copy())
    rows, _curves, _thermo = summary.analyse_compression(tmp_path, (1e-3, 1e-2), 1.0)
    got = {name: v for name, v, _e in rows}
    phi_j = got["phi_j"]
    assert phi_j == pytest.approx(0.63, abs=1e-3)
    # the line through (0.632, 5.9) and (0.64, 6.4) at phi_J
    assert got["z_j"] == pytest.approx(5.9 - 0.5 / 0.008 * (0.632 - phi_j), rel=1e-12)
    assert got["phi_at_z_j"] == phi_j and got["z_j_frames"] == 2
    # 80 and 20 rattlers of 500 on the same line
    assert got["rattler_fraction_j"] == pytest.approx(0.16 + 0.12 / 0.008 * (0.632 - phi_j))
    # z with rattlers jumps at phi_J: from the same two frames above it, not interpolated
    # across the jump from the flowing frame at 0.6301
    assert got["z_j_with_rattlers"] == pytest.approx(5.6 - 0.6 / 0.008 * (0.632 - phi_j),
                                                     rel=1e-12)


def jammed_curves(phi, law, p_slope=0.5, phi_j=0.56, n=1000, backbone_from=None):
    """Frames of a compression whose rattler-free contact number follows ``law(phi)``
    from ``backbone_from`` (default ``phi_j``) on (no backbone below) and whose pressure
    rises linearly from ``phi_j``."""
    phi = np.round(np.asarray(phi, dtype=float), 9)
    above = phi >= (phi_j if backbone_from is None else backbone_from)
    z = np.where(above, law(np.maximum(phi, phi_j)), 0.0)
    return pd.DataFrame({"step": np.arange(len(phi)), "phi": phi,
                         "pressure": p_slope * np.clip(phi - phi_j, 0, None),
                         "z": np.where(phi >= phi_j, law(np.maximum(phi, phi_j)) + 0.3, 2.0),
                         "z_rattler_free": z, "z_bonds": z,
                         "n_rattlers": np.where(above, 50, n), "n": n, "s_nematic": 0.1 * phi})


def test_z_j_is_extrapolated_to_the_jamming_point():
    """z_J is the contact number at phi_J, the p -> 0 limit, from the frames above it on
    the first pressure rise: z = 4.3 + 40 (phi - phi_J) gives back 4.3, where the first
    frame above phi_J (0.002 above) reads 4.38, and the first that keeps a backbone when
    those near jamming do not (0.026 above: the frictional spheres of issue 48) 5.34."""
    from analysis.summary import z_at_jamming

    def law(f):
        return 4.3 + 40.0 * (f - 0.56)

    phi = 0.502 + 0.004 * np.arange(25)  # 0.502 ... 0.598, none at phi_J = 0.56
    curves = jammed_curves(phi, law)
    got = z_at_jamming(curves, 0.56, p_max=0.014)
    assert got["z_j"][0] == pytest.approx(4.3, abs=1e-9) and got["z_j"][1] < 1e-6
    assert got["z_j_bonds"][0] == pytest.approx(4.3, abs=1e-9)
    assert got["phi_at_z_j"][0] == 0.56
    assert got["z_j_frames"][0] == 3  # the nearest three of phi 0.562 ... 0.586 (p <= p_max)
    assert got["rattler_fraction_j"][0] == pytest.approx(0.05)
    assert got["s_nematic_j"][0] == pytest.approx(0.056)
    # with rattlers, from the same frames: the line's 4.6, where interpolating between
    # 0.558 (flowing, 2.0) and 0.562 would read 3.34
    assert got["z_j_with_rattlers"][0] == pytest.approx(4.3 + 0.3, abs=1e-9)
    late = jammed_curves(phi, law, backbone_from=0.585)
    got = z_at_jamming(late, 0.56, p_max=0.014)
    assert law(0.586) == pytest.approx(5.34)
    assert got["z_j"][0] == pytest.approx(4.3, abs=1e-9) and got["z_j_frames"][0] == 2
    assert got["phi_at_z_j"][0] == 0.56
    # noise on the line: the intercept's standard error from three frames on
    noisy = curves.copy()
    noisy.loc[noisy.phi > 0.56, "z_rattler_free"] += 0.05 * (-1.0) ** np.arange(
        int((noisy.phi > 0.56).sum()))
    z_j, err = z_at_jamming(noisy, 0.56, p_max=0.014)["z_j"]
    assert abs(z_j - 4.3) < 3 * err and 0.02 < err < 0.3
    # only frames on the first rise: with p_max below the third frame's pressure, two
    assert z_at_jamming(curves, 0.56, p_max=0.004)["z_j_frames"][0] == 2


def test_z_j_from_one_frame_is_read_at_that_frame():
    """With a single frame that keeps a backbone there is nothing to extrapolate with: its
    own z, and its own phi as phi_at_z_j; without any, NaN."""
    from analysis.summary import z_at_jamming

    curves = jammed_curves([0.55, 0.57], lambda f: np.full_like(f, 4.9))
    got = z_at_jamming(curves, 0.56, p_max=1.0)
    assert got["z_j"][0] == 4.9 and got["phi_at_z_j"][0] == 0.57 and got["z_j_frames"][0] == 1
    assert got["z_j_with_rattlers"][0] == pytest.approx(5.2)
    none = z_at_jamming(curves.iloc[:1], 0.56, p_max=1.0)
    assert np.isnan(none["z_j"][0]) and np.isnan(none["phi_at_z_j"][0])
    assert np.isnan(z_at_jamming(curves, np.nan, p_max=1.0)["z_j"][0])
