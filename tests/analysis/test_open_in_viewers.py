"""The common format opens in OVITO and MDAnalysis as they are, tested with the real
modules (docs/formats.md): rods come in with OVITO's Orientation and Aspherical Shape
set from the columns it maps by name, so that it draws spherocylinders; the contact table
becomes OVITO bonds with the documented column mapping; MDAnalysis reads the positions."""
import numpy as np
import pytest

from pysim import io

ovito = pytest.importorskip("ovito")  # a pinned dependency: present wherever setup ran


def rod_frame(path, rng, n=12):
    x = rng.uniform(0, 10, (n, 3))
    u = rng.normal(size=(n, 3))
    u[0] = (0, 0, 1)
    u[1] = (0, 0, -1)  # the half turn
    u[2] = (1, 0, 0)
    u /= np.linalg.norm(u, axis=1)[:, None]
    radius = rng.uniform(0.4, 0.6, n)
    length = rng.uniform(0.5, 3.0, n)
    with open(path, "w") as fh:
        io.write_particles_frame(fh, 7, np.full(3, 10.0), np.ones(3, bool), np.arange(1, n + 1),
                                 np.ones(n, int), x, radius, u, length)
    return x, u, radius, length


def rotate(q, v):
    """``v`` rotated by the unit quaternions ``q`` given as OVITO's (x, y, z, w)."""
    w, r = q[:, 3:4], q[:, :3]
    return v + 2 * np.cross(r, np.cross(r, v) + w * v)


def test_quaternions_turn_z_onto_the_spine(rng):
    u = rng.normal(size=(50, 3))
    u[:3] = [(0, 0, 1), (0, 0, -1), (0, 1e-13, -1)]
    u /= np.linalg.norm(u, axis=1)[:, None]
    q = io.quaternion_from_z(u)
    xyzw = np.column_stack([q[:, 1:], q[:, :1]])
    assert np.allclose(np.linalg.norm(q, axis=1), 1.0)
    assert np.allclose(rotate(xyzw, np.tile([0.0, 0.0, 1.0], (50, 1))), u, atol=1e-12)


def test_ovito_reads_rods_as_oriented_spherocylinders(tmp_path, rng):
    from ovito.io import import_file

    path = tmp_path / "particles.dump"
    x, u, radius, length = rod_frame(path, rng)
    p = import_file(str(path)).compute().particles
    order = np.argsort(np.asarray(p["Particle Identifier"]))
    assert np.allclose(np.asarray(p["Position"])[order], x, atol=1e-8)
    q = np.asarray(p["Orientation"])[order]  # (x, y, z, w)
    assert np.allclose(rotate(q, np.tile([0.0, 0.0, 1.0], (len(u), 1))), u, atol=1e-6)
    shape = np.asarray(p["Aspherical Shape"])[order]  # its spherocylinder: R, R, L
    assert np.allclose(shape, np.column_stack([radius, radius, length]), rtol=1e-6)  # float32


def test_ovito_loads_the_contact_table_as_bonds(tmp_path, rng):
    """The mapping docs/formats.md gives: ids to OVITO's bond topology, the rest by name
    (a periodic packing: wall rows, ``j <= 0``, name no particle and must be left out)."""
    from ovito.io import import_file
    from ovito.modifiers import LoadTrajectoryModifier

    rod_frame(tmp_path / "particles.dump", rng)
    ij = np.array([[1, 2], [2, 5], [3, 12]])
    rec = rng.normal(size=(3, 10))
    with open(tmp_path / "contacts.dump", "w") as fh:
        io.write_contacts_frame(fh, 7, np.full(3, 10.0), np.ones(3, bool), ij, rec)
    pipe = import_file(str(tmp_path / "particles.dump"))
    mod = LoadTrajectoryModifier()
    mod.source.load(str(tmp_path / "contacts.dump"), columns=[
        "Particle Identifiers.1", "Particle Identifiers.2", "cx", "cy", "cz", "nx", "ny", "nz",
        "overlap", "fx", "fy", "fz"])
    pipe.modifiers.append(mod)
    bonds = pipe.compute().particles.bonds
    assert bonds.count == 3
    assert np.allclose(np.sort(np.asarray(bonds["overlap"])), np.sort(rec[:, 6]), rtol=1e-9)


def test_mdanalysis_reads_the_particle_dump(tmp_path, rng):
    import MDAnalysis as mda

    path = tmp_path / "particles.dump"
    x, *_ = rod_frame(path, rng)
    universe = mda.Universe(str(path), format="LAMMPSDUMP")
    assert universe.atoms.n_atoms == len(x)
    assert np.allclose(universe.atoms.positions, x, atol=1e-4)  # float32
