"""Per-run summaries of :mod:`analysis.summary` that need no engine run."""
import numpy as np
import pandas as pd
import pytest

from analysis.summary import cycle_rows, late_window, tap_cycle


def curves(taps: int, frames_per_tap: int) -> pd.DataFrame:
    """Frame 0 (the settled packing, tap 0), then ``frames_per_tap`` frames per tap; the
    angle counts the frames so that a window's mean tells which frames it holds."""
    tap = np.concatenate([[0.0], np.arange(1, taps * frames_per_tap + 1) / frames_per_tap])
    return pd.DataFrame({"tap": tap, "angle": np.arange(len(tap), dtype=float)})


@pytest.mark.parametrize("taps, per_tap, first, n", [
    (400, 1, 351, 50),    # the last 50 of 400 taps, one frame per tap
    (100, 4, 87.75, 50),  # 12.5 taps of 4 frames: after tap 87.5
    (50, 4, 44.0, 25),    # 6.25 taps: after tap 43.75
    (4, 4, 3.25, 4),      # an eighth is less than a tap: the last tap
])
def test_late_window_holds_the_last_eighth_of_the_taps(taps, per_tap, first, n):
    late = late_window(curves(taps, per_tap))
    assert len(late) == n
    assert late.tap.min() == pytest.approx(first) and late.tap.max() == taps
    assert np.all(np.diff(late.angle) == 1)  # consecutive frames, up to the last


def test_late_window_of_a_run_without_taps_is_its_last_frame():
    settled = pd.DataFrame({"tap": [0.0], "angle": [20.0]})
    assert late_window(settled).angle.tolist() == [20.0]


def thermo(every: int, steps: int, start: int, dt: float, period: float) -> pd.DataFrame:
    """Thermo rows every ``every`` steps of a bed whose kinetic energy is ``2 + cos(2 pi
    phase)`` J and which keeps ``100`` contacts, ``40`` in the half period after phase 0.5."""
    step = np.arange(0, steps + 1, every)
    phase = np.mod((step - start) * dt / period, 1.0)
    return pd.DataFrame({"step": step, "ke": 2.0 + np.cos(2 * np.pi * phase),
                         "n_contacts": np.where((phase > 0.45) & (phase < 0.95), 40, 100)})


def test_tap_cycle_bins_the_thermo_rows_by_their_phase():
    # 1000 steps of 2e-5 s every period of 1/30 s: rows visit phases 0, 0.6, 0.2, 0.8, 0.4
    th = thermo(1000, 200_000, 25_000, 2e-5, 1 / 30)
    cyc = tap_cycle(th, 25_000, 2e-5, 1 / 30, first_tap=10.0)
    assert cyc.phase.tolist() == pytest.approx([0.0, 0.2, 0.4, 0.6, 0.8])
    assert cyc.ke.to_numpy() == pytest.approx(2 + np.cos(2 * np.pi * cyc.phase.to_numpy()))
    assert cyc.n_contacts.tolist() == [100, 100, 100, 40, 40]
    # only rows from tap 10 on: (200000 - 25000 - 10 * 1666.67) / 1000 rows, all counted
    assert cyc.rows.sum() == np.sum((th.step - 25_000) * 2e-5 * 30 >= 10.0)
    rows = dict((name, value) for name, value, _ in cycle_rows(cyc, n_grains=4))
    assert rows["ke_cycle"] == pytest.approx(cyc.ke.mean() / 4)
    assert rows["ke_cycle_peak"] == pytest.approx(3.0 / 4)
    assert rows["contacts_flight"] == pytest.approx(0.4)
    assert rows["cycle_bins"] == 5


def test_cycle_observables_need_several_phases():
    # rows every 5000 steps of 2e-5 s: every third period, always at the same phase
    th = thermo(5000, 200_000, 25_000, 2e-5, 1 / 30)
    cyc = tap_cycle(th, 25_000, 2e-5, 1 / 30)
    assert len(cyc) == 1
    rows = dict((name, value) for name, value, _ in cycle_rows(cyc, n_grains=4))
    assert rows["cycle_bins"] == 1
    assert np.isnan(rows["ke_cycle"]) and np.isnan(rows["contacts_flight"])
