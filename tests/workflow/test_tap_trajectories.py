"""The time-step check of a tapped bed (workflows/scripts/tap_trajectories.py) on the small
tapping case of 30 rods: its first tap, from the same settled bed, converges with the time
step; the CLI writes its samples and refuses what it cannot run."""
import pandas as pd
import pytest

from pysim.io import read_particle_data
from tests.runs import prepared
from tests.cases import TAP
from workflows.scripts import tap_trajectories as tt


@pytest.fixture(scope="module")
def small(tmp_path_factory):
    return prepared(tmp_path_factory, "taptraj", TAP)


def test_first_tap_converges_with_the_time_step(small):
    case, d = small
    df = tt.trajectories(case, read_particle_data(d / "init.data"), [2e-5, 1e-5, 5e-6], 1,
                         log=lambda _line: None)
    assert set(df.tap) == {0} and len(df) == 3 * tt.SAMPLES
    ke = df.groupby("dt").ke_mgd.mean()
    assert ke.min() > 0.05  # the bed is shaken
    # halving the step twice: the tap's mean energy moves by less than 3 %
    assert ke[1e-5] == pytest.approx(ke[5e-6], rel=0.03)
    assert ke[2e-5] == pytest.approx(ke[5e-6], rel=0.03)
    phases = df[df.dt == 5e-6].phase
    assert phases.is_monotonic_increasing and phases.iloc[-1] == pytest.approx(1.0, abs=0.03)


def test_cli_writes_samples_and_refuses_bad_input(small, tmp_path, capsys):
    case, d = small
    (tmp_path / "case.yaml").write_text(__import__("yaml").safe_dump(case))
    out = tmp_path / "s.csv"
    assert tt.main([str(tmp_path / "case.yaml"), str(d / "init.data"), "--dt", "2e-5",
                    "--taps", "1", "--out", str(out)]) == 0
    assert list(pd.read_csv(out).columns) == ["dt", "tap", "phase", "ke_mgd", "contacts"]
    assert tt.main([str(tmp_path / "case.yaml"), str(d / "init.data"), "--dt", "1e-3",
                    "--taps", "1", "--out", str(out)]) == 2
    assert "dt must be in (0, " in capsys.readouterr().err
