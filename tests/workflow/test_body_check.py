"""The two-rod check of LAMMPS' body styles (workflows/body_check.py) in 2-D: with the
skin the packing deck uses, body rounded/polygon rods collide elastically like pysim's;
with a plain skin the head-on collision is missed by the neighbour list and blows up,
and the check says so."""
import pytest

from workflows import body_check


@pytest.mark.engines
def test_2d_head_on_collision(tmp_path):
    ok = body_check.run_lammps("tip_tip", 2.0, tmp_path, dimension=2)
    ref = body_check.run_pysim("tip_tip", 2.0, dimension=2)
    for rec in (ok, ref):
        assert rec["verdict"] == "ok" and rec["bounced"] and rec["finite"]
        assert rec["ke_ratio"] == pytest.approx(1.0, abs=1e-3)
    bare = body_check.run_lammps("tip_tip", 2.0, tmp_path, dimension=2,
                                 skin=body_check.BARE_SKIN, label="lammps-body-bare-skin")
    assert bare["verdict"] == "WRONG" and not bare["finite"]


def test_2d_geometries_stay_in_the_plane(tmp_path):
    with pytest.raises(ValueError, match="leaves the plane"):
        body_check.run_lammps("crossed", 2.0, tmp_path, dimension=2)
