"""The engine runner keeps a long run's restart files few (the newest ones, pruned while
the engine runs) and stops an engine that runs past its budget."""
import sys
import time

import pytest

from workflows import engines
from workflows.engines import restarts


def test_prune_keeps_the_newest_restart_files_by_step(tmp_path):
    for step in (9, 10, 100, 20, 1000):
        (tmp_path / f"restart.{step}").write_text("x")
    (tmp_path / "restart.part").write_text("not a restart step")
    gone = engines.prune_restarts(tmp_path, keep=3)
    assert sorted(p.name for p in gone) == ["restart.10", "restart.9"]
    assert sorted(p.name for p in tmp_path.glob("restart.*")) == [
        "restart.100", "restart.1000", "restart.20", "restart.part"]
    with pytest.raises(ValueError, match="keep must be at least 1"):
        engines.prune_restarts(tmp_path, keep=0)


def test_restart_files_are_pruned_while_the_engine_runs(tmp_path, monkeypatch):
    """A stand-in engine writes 30 restart files, one every 0.05 s, and reports how many
    it saw at most: with pruning every 0.2 s there are never more than a handful, and
    the newest KEEP_RESTARTS are left at the end."""
    monkeypatch.setattr(restarts, "PRUNE_SECONDS", 0.2)
    code = ("import pathlib, time\n"
            "most = 0\n"
            "for k in range(1, 31):\n"
            "    pathlib.Path(f'restart.{k * 100}').write_text('x')\n"
            "    most = max(most, len(list(pathlib.Path('.').glob('restart.*'))))\n"
            "    time.sleep(0.05)\n"
            "print('most', most)\n")
    with open(tmp_path / "screen.txt", "w") as screen:
        proc = restarts._run_pruning([sys.executable, "-c", code], screen, tmp_path, None, 60.0)
    assert proc is not None and proc.returncode == 0
    most = int((tmp_path / "screen.txt").read_text().split()[-1])
    assert most <= engines.KEEP_RESTARTS + 6  # one pruning interval of new files
    assert sorted(int(p.name.split(".")[1]) for p in tmp_path.glob("restart.*")) == \
        [2800, 2900, 3000]


def test_an_engine_past_its_budget_is_stopped(tmp_path):
    t0 = time.perf_counter()
    with open(tmp_path / "screen.txt", "w") as screen:
        proc = restarts._run_pruning([sys.executable, "-c", "import time; time.sleep(60)"],
                                    screen, tmp_path, None, 0.5)
    assert proc is None
    assert time.perf_counter() - t0 < 10
