"""Readers of the common format: round trips and precise errors."""
import numpy as np
import pytest

from analysis.io import FormatError, read_contact_frames, read_particle_frames, read_thermo
from pysim import io


def write_two_frames(path):
    x = np.array([[0.5, 0.5, 0.5], [1.4, 0.5, 0.5], [3.0, 3.0, 3.0]])
    with open(path, "w") as fh:
        for step in (0, 100):
            io.write_particles_frame(fh, step, np.full(3, 4.0), np.ones(3, bool),
                                     np.array([3, 1, 2]), np.ones(3, np.int64), x,
                                     np.full(3, 0.5))
    return x


def test_particle_round_trip_sorted_by_id(tmp_path):
    p = tmp_path / "particles.dump"
    x = write_two_frames(p)
    frames = read_particle_frames(p)
    assert [f.step for f in frames] == [0, 100]
    f = frames[1]
    assert f.ids.tolist() == [1, 2, 3]
    np.testing.assert_allclose(f.x, x[[1, 2, 0]])
    assert f.box.tolist() == [4.0, 4.0, 4.0] and f.periodic.all()
    assert np.all(f.length == 0)


def test_truncated_dump_names_file_and_line(tmp_path):
    p = tmp_path / "particles.dump"
    write_two_frames(p)
    lines = p.read_text().splitlines()
    p.write_text("\n".join(lines[:-1]) + "\n")
    with pytest.raises(FormatError, match=r"particles.dump:\d+: truncated"):
        read_particle_frames(p)
    bad = lines.copy()
    bad[10] = "1 1 0.5 zz 0.5 0.5"
    p.write_text("\n".join(bad) + "\n")
    with pytest.raises(FormatError, match=r"particles.dump:11: not a number"):
        read_particle_frames(p)


def test_contact_round_trip(tmp_path):
    p = tmp_path / "contacts.dump"
    rec = np.arange(20, dtype=float).reshape(2, 10)
    with open(p, "w") as fh:
        io.write_contacts_frame(fh, 7, np.full(3, 4.0), np.ones(3, bool), np.array([[1, 2], [2, 3]]), rec)
    (c,) = read_contact_frames(p)
    assert c.step == 7 and c.i.tolist() == [1, 2] and c.j.tolist() == [2, 3]
    np.testing.assert_allclose(c.force, rec[:, 7:10])


def test_thermo_reader(tmp_path):
    p = tmp_path / "thermo.dat"
    p.write_text(io.thermo_header() + "0 0 0.3 0 0 nan 0\n10 0.1 0.31 1.5 2 nan 4\n")
    df = read_thermo(p)
    assert df.step.tolist() == [0, 10] and df.pe.isna().all()
    p.write_text(io.thermo_header() + "0 0 0.3 0 0 nan 0\n10 0.1\n")
    with pytest.raises(FormatError, match="thermo.dat:3"):
        read_thermo(p)
