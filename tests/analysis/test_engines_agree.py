"""The same packing written by LAMMPS, LIGGGHTS and pysim gives the same numbers.

One polydisperse, overlapping sphere packing is written as ``init.data``; each engine
reads it, evaluates its linear contact forces once (``run 0``) and writes the common
format (LAMMPS/LIGGGHTS: particle dump plus native contact table, converted by
``workflows.engines``; pysim: its own writers). The analysis of the three run
directories must agree to the precision of the files, and the pressure from the
contact tables must equal each engine's own virial pressure.

Precision: LAMMPS and pysim write 10 significant digits and agree to 1e-6 (in fact
~1e-13). LIGGGHTS 3.8 writes the dump header's BOX BOUNDS with ``%g`` (6 significant
digits), and the contact conversion takes the box from that header for minimum images
across periodic faces: overlaps of such pairs shift by ~1e-6 and the stress by ~1e-6
relative, so LIGGGHTS is compared at 2e-5 relative.
"""
import re
import shutil
import subprocess

import numpy as np
import pytest

from analysis.contacts import ContactNumber, geometric_contacts
from analysis.io import RunData
from analysis.packing import PackingProfile, packing_fraction
from analysis.stress import StressField, StressProfile, pressure, stress_tensor
from pysim import io
from pysim.initial import random_spheres
from tests.conftest import needs_liggghts
from workflows import engines

K_N = 1.0e4

LAMMPS_DECK = """
units           lj
atom_style      sphere
boundary        p p p
comm_modify     vel yes
atom_modify     map array
read_data       {data}
neighbor        0.2 bin
pair_style      granular
pair_coeff      * * hooke {k_n} 0.0 tangential linear_nohistory 0.0 0.0 damping velocity
timestep        1.0e-4
fix             integrate all nve/sphere
compute         press all pressure thermo_temp virial
variable        p equal c_press
compute         pl all pair/local dist fx fy fz p1 p2 p3 p10 p11 p12 cutoff radius
compute         pp all property/local patom1 patom2 cutoff radius
dump            parts all custom 1 {out}/particles.dump id type x y z radius
dump_modify     parts sort id format float %.10g
dump            cont all local 1 {out}/contacts.native c_pp[1] c_pp[2] c_pl[*]
dump_modify     cont format float %.10g
thermo_style    custom step c_press
run             0
print           "RODPACK_PRESSURE ${{p}}"
"""

LIGGGHTS_DECK = """
atom_style      granular
atom_modify     map array
boundary        p p p
newton          off
communicate     single vel yes
units           si
read_data       {data}
neighbor        0.2 bin
neigh_modify    delay 0
fix             m1 all property/global kn peratomtypepair 1 {k_n}
fix             m2 all property/global kt peratomtypepair 1 0.0
fix             m3 all property/global gamman_abs peratomtypepair 1 0.0
fix             m4 all property/global gammat_abs peratomtypepair 1 0.0
fix             m5 all property/global coefficientFriction peratomtypepair 1 0.0
pair_style      gran model hooke/stiffness tangential no_history absolute_damping on
pair_coeff      * *
timestep        1.0e-4
fix             integrate all nve/sphere
compute         press all pressure thermo_temp virial
variable        p equal c_press
compute         gl all pair/gran/local pos id force delta
dump            parts all custom 1 {out}/particles.dump id type x y z radius
dump_modify     parts sort id format "%d %d %.10g %.10g %.10g %.10g"
dump            cont all local 1 {out}/contacts.native c_gl[1] c_gl[2] c_gl[3] c_gl[4] &
                c_gl[5] c_gl[6] c_gl[7] c_gl[8] c_gl[9] c_gl[10] c_gl[11] c_gl[12] c_gl[13]
dump_modify     cont format "{fmt13}"
thermo_style    custom step c_press
run             0
print           "RODPACK_PRESSURE ${{p}}"
"""


@pytest.fixture(scope="module")
def packing(tmp_path_factory):
    """200 spheres, diameters uniform in [0.9, 1.1], placed at phi = 0.35 and squeezed
    affinely to phi = 0.5: overlaps up to about 10 % of a diameter."""
    d = tmp_path_factory.mktemp("packing")
    rng = np.random.default_rng(8)
    diam = rng.uniform(0.9, 1.1, 200)
    x, diam, box = random_spheres(diam, 0.35, seed=8)
    s = (0.35 / 0.5) ** (1 / 3)
    x, box = x * s, np.asarray(box) * s
    io.write_sphere_data(d / "init.data", x, diam, box, density=1.0)
    return d


def run_deck(engine, deck, data, out):
    out.mkdir()
    (out / "in.deck").write_text(deck.format(data=data, out=out, k_n=K_N,
                                             fmt13=" ".join(["%.10g"] * 13)))
    exe = engines.venv_bin("lmp") if engine == "lammps" else shutil.which("liggghts")
    r = subprocess.run([exe, "-in", str(out / "in.deck"), "-log", str(out / "log")], cwd=out,
                       capture_output=True, text=True, timeout=300,
                       env={"OMP_NUM_THREADS": "1", "PATH": "/usr/bin:/bin"})
    assert r.returncode == 0, r.stdout[-2000:] + r.stderr[-2000:]
    convert = engines.convert_lammps_contacts if engine == "lammps" else engines.convert_liggghts_contacts
    stats = convert(out / "contacts.native", out / "particles.dump", out / "contacts.dump")
    assert stats["dropped"] == 0 or engine == "liggghts"
    m = re.search(r"^RODPACK_PRESSURE (\S+)", r.stdout, re.M)
    return float(m.group(1))


def run_pysim(data, out):
    from pysim import State
    from pysim.simulation import ContactModel, Simulation

    out.mkdir()
    ids, x, diam, _rho, lo, box = io.read_sphere_data(data)
    st = State.spheres(x, diam / 2, box)
    sim = Simulation(st, ContactModel("hooke", K_N, 0.0), dt=1e-4)
    ij, rec = sim.contact_table()
    with open(out / "particles.dump", "w") as fh:
        io.write_particles_frame(fh, 0, st.box, st.periodic, ids, np.ones(len(ids), np.int64),
                                 st.x, st.radius)
    with open(out / "contacts.dump", "w") as fh:
        io.write_contacts_frame(fh, 0, st.box, st.periodic, ids[ij], rec)
    return sim.thermo().pressure


def observables(run_dir):
    (frame, contacts), = RunData(run_dir).frames()
    contacts = contacts.canonical()
    cn = ContactNumber(c_min=4).compute(frame, contacts)
    geo = geometric_contacts(frame)
    return {
        "phi": packing_fraction(frame),
        "profile": PackingProfile(thickness=0.5).compute(frame).phi,
        "pairs": np.column_stack([contacts.i, contacts.j]),
        "geometric_pairs": np.column_stack([geo.i, geo.j]),
        "overlap": contacts.overlap, "normal": contacts.normal, "force": contacts.force,
        "per_particle": cn.per_particle, "z": cn.z, "z_rattler_free": cn.z_rattler_free,
        "rattlers": cn.rattlers,
        "stress": stress_tensor(frame, contacts), "pressure": pressure(frame, contacts),
        "stress_profile": StressProfile(thickness=1.0, top=0.0).compute(frame, contacts).sigma,
        "stress_field": StressField(element=2.0).compute(frame, contacts).sigma,
    }


def compare(a, b, rtol=1e-6, atol=1e-7):
    """Floats to ``rtol`` (and ``atol`` times the largest magnitude), the rest exactly."""
    for key in a:
        if a[key].__class__ is float or np.asarray(a[key]).dtype.kind == "f":
            scale = np.max(np.abs(a[key])) if np.size(a[key]) else 1.0
            np.testing.assert_allclose(b[key], a[key], rtol=rtol, atol=atol * scale, err_msg=key)
        else:
            np.testing.assert_array_equal(b[key], a[key], err_msg=key)


@pytest.fixture(scope="module")
def pysim_run(packing):
    p = run_pysim(packing / "init.data", packing / "pysim")
    obs = observables(packing / "pysim")
    # the table is complete: geometry finds exactly the same overlapping pairs
    np.testing.assert_array_equal(obs["geometric_pairs"], obs["pairs"])
    assert obs["pairs"].shape[0] > 150 and obs["pressure"] > 0
    assert obs["pressure"] == pytest.approx(p, rel=1e-9)
    return obs


@pytest.mark.engines
def test_lammps_and_pysim_agree(packing, pysim_run):
    p = run_deck("lammps", LAMMPS_DECK, packing / "init.data", packing / "lammps")
    obs = observables(packing / "lammps")
    assert obs["pressure"] == pytest.approx(p, rel=1e-6)
    compare(pysim_run, obs)


@pytest.mark.engines
@needs_liggghts
def test_liggghts_and_pysim_agree(packing, pysim_run):
    p = run_deck("liggghts", LIGGGHTS_DECK, packing / "init.data", packing / "liggghts")
    (frame, _), = RunData(packing / "liggghts").frames()
    true_box = io.read_sphere_data(packing / "init.data")[5]
    # the cause of the looser tolerance: the header box has 6 significant digits
    assert np.max(np.abs(frame.box / true_box - 1)) < 1e-5
    obs = observables(packing / "liggghts")
    assert obs["pressure"] == pytest.approx(p, rel=2e-5)
    compare(pysim_run, obs, rtol=2e-5, atol=1e-4)
    np.testing.assert_array_equal(obs["force"], pysim_run["force"])  # forces: 10 digits
