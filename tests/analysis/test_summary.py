"""Per-run summaries of :mod:`analysis.summary` that need no engine run."""
import numpy as np
import pandas as pd
import pytest

from analysis.summary import late_window


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
