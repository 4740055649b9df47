"""The caging-number script of a study (workflows/scripts/caging_numbers.py): its table
and figure, and a one-line error for a bad aspect ratio."""
import numpy as np
import pandas as pd
import pytest

from workflows.scripts import caging_numbers


def test_table_and_figure(tmp_path):
    table, figure = tmp_path / "caging.csv", tmp_path / "figures" / "caging.png"
    assert caging_numbers.main(["--table", str(table), "--figure", str(figure), "--trials",
                                "20", "--alphas-3d", "0", "2", "inf", "--alphas-2d", "0"]) == 0
    t = pd.read_csv(table)
    assert list(zip(t.dimension, t.alpha)) == [(2, 0.0), (3, 0.0), (3, 2.0), (3, np.inf)]
    assert (t.trials == 20).all() and (t.stderr > 0).all()
    # a disk needs 3 contacts at least, a sphere 4, a rod (4 freedoms) 5
    assert (t["mean"] >= [3, 4, 5, 5]).all()
    assert figure.stat().st_size > 10_000
    # the papers' numbers drawn beside ours: disk, sphere and the two infinite rods
    paper = caging_numbers.paper_values()
    assert sorted(zip(paper.dimension, paper.alpha, paper.value)) == [
        (2.0, 0.0, 5.0), (2.0, np.inf, 5.0), (3.0, 0.0, 7.0), (3.0, np.inf, 9.0)]


def test_bad_input_is_one_line(tmp_path, capsys):
    with pytest.raises(SystemExit):
        caging_numbers.main(["--table", str(tmp_path / "t.csv"), "--figure",
                             str(tmp_path / "f.png"), "--alphas-3d", "-1"])
    assert "aspect ratios must be >= 0" in capsys.readouterr().err
    with pytest.raises(SystemExit):
        caging_numbers.main(["--table", str(tmp_path / "t.csv"), "--figure",
                             str(tmp_path / "f.png"), "--trials", "1", "--alphas-2d", "0"])
    assert "--trials must be >= 2" in capsys.readouterr().err
