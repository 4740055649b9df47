"""``contact.limit_damping`` on the peer engines' decks: LAMMPS gets its ``limit_damping``
keyword and LIGGGHTS its ``limitForce`` option. The same small tapped bed of 30 glued rods,
run with and without the clip from one start: without it some sphere pairs pull each other
while they part (the dashpot outweighs the spring at the end of a contact), with it none
does; the compression, deposition and settling decks take the clip too (without it, their
small runs here have pulling pairs of up to 2 %, 12-19 % and 36 % of the largest force:
measured once). The
pair's clipped law itself is checked against its equation of motion in
``test_restitution_check.py``."""
import numpy as np
import pytest

from pysim.initial import write_initial
from tests.conftest import needs_liggghts
from tests.cases import DEP_SMALL, ENGINE_COMPRESS, SETTLE_RODS, TAP
from workflows import engines
from workflows.engines.convert import _iter_local
from rodcase.case import deep_merge, validate_case


def normal_forces(native, engine: str) -> np.ndarray:
    """Normal force of every sphere pair in every frame of an engine's contact dump: the
    force on ``i`` projected on ``x_i - x_j`` (positive: the pair pushes apart)."""
    out = []
    for _step, box, cols, t in _iter_local(native):
        c = {name: k for k, name in enumerate(cols)}
        flags = box[0].split()[3:]  # ITEM: BOX BOUNDS xx yy zz
        bounds = np.array([[float(v) for v in ln.split()[:2]] for ln in box[1:4]])
        periodic = np.array([f == "pp" for f in flags])
        length = bounds[:, 1] - bounds[:, 0]
        if engine == "lammps":  # patom1 patom2 dist f(3) ft(3) xi-xj(3)
            f = t[:, [c["c_pl[2]"], c["c_pl[3]"], c["c_pl[4]"]]]
            r = t[:, [c["c_pl[8]"], c["c_pl[9]"], c["c_pl[10]"]]]
        else:  # pos_i(3) pos_j(3) id_i id_j periodic f_i(3) delta
            r = t[:, [c["c_gl[1]"], c["c_gl[2]"], c["c_gl[3]"]]] - \
                t[:, [c["c_gl[4]"], c["c_gl[5]"], c["c_gl[6]"]]]
            f = t[:, [c["c_gl[10]"], c["c_gl[11]"], c["c_gl[12]"]]]
        # LIGGGHTS lists a pair across a periodic face with the stored positions
        r[:, periodic] -= length[periodic] * np.round(r[:, periodic] / length[periodic])
        out.append(np.einsum("ij,ij->i", f, r) / np.linalg.norm(r, axis=1))
    return np.concatenate(out)


@pytest.mark.engines
@pytest.mark.parametrize("engine", [
    "lammps", pytest.param("liggghts", marks=needs_liggghts)])
def test_tapping_deck_clips_the_normal_force(engine, tmp_path):
    forces = {}
    for clip in (False, True):
        case = validate_case(deep_merge(TAP, {"contact": {"limit_damping": clip}}))
        assert engines.supports(engine, case) is None
        write_initial(case, tmp_path / "init.data")  # the same start for both runs
        out = tmp_path / f"clip{int(clip)}"
        engines.run(engine, case, tmp_path / "init.data", out, timeout=600)
        forces[clip] = normal_forces(out / "work" / "contacts.native", engine)
    scale = np.abs(forces[False]).max()
    assert (forces[False] < -1e-3 * scale).sum() >= 2  # the plain law pulls
    # clipped: zero at most (LIGGGHTS' dump rounds the positions, so the tangential
    # force leaks into the projection at 1e-8 of the forces)
    assert forces[True].min() >= -1e-6 * scale
    assert len(forces[True]) > 50


@pytest.mark.engines
@pytest.mark.parametrize("engine, base", [
    ("lammps", ENGINE_COMPRESS), pytest.param("liggghts", ENGINE_COMPRESS, marks=needs_liggghts),
    ("lammps", DEP_SMALL), pytest.param("liggghts", DEP_SMALL, marks=needs_liggghts),
    pytest.param("liggghts", SETTLE_RODS, marks=needs_liggghts)],
    ids=["lammps-compress", "liggghts-compress", "lammps-deposit", "liggghts-deposit",
         "liggghts-settle"])
def test_other_decks_clip_the_normal_force(engine, base, tmp_path):
    """Spheres compressed (``in.spheres.compress``), rods deposited with walls
    (``in.rods.deposit``) and, on LIGGGHTS, rods settled (``in.rods.settle``). LAMMPS'
    rod compression (``in.rods.compress``, 52 s for this size) was checked by hand."""
    case = validate_case(deep_merge(base, {"contact": {"limit_damping": True}}))
    write_initial(case, tmp_path / "init.data")
    engines.run(engine, case, tmp_path / "init.data", tmp_path / "run", timeout=600)
    fn = normal_forces(tmp_path / "run" / "work" / "contacts.native", engine)
    assert len(fn) > 100
    assert fn.min() >= -1e-6 * np.abs(fn).max()
