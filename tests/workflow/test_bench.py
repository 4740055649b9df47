"""A tiny run of the benchmark driver: every case, the CSV columns, the ratios, the plot."""
import csv

import numpy as np
import pytest

from workflows import bench
from workflows.glued import glued_spheres, write_glued_rods_data


@pytest.mark.slow
def test_tiny_bench_writes_every_case(tmp_path):
    out = tmp_path / "bench.csv"
    rows = bench.run(out, n_spheres=300, n_rods=200, steps=20, rod_steps=10, repeats=1,
                     cores=(1,), engines=("pysim", "lammps-legacy"), scaling=(300, 310, 600),
                     scaling_steps=5, scaling_work=3100, scaling_repeats=2, log=lambda *a: None)
    with open(out) as fh:
        table = list(csv.DictReader(fh))
    assert list(table[0]) == bench.FIELDS
    cases = {(r["case"], r["engine"]) for r in table}
    assert {("spheres_friction", "pysim"), ("spheres_friction", "lammps-legacy"),
            ("spheres_frictionless", "pysim"), ("rods_a4", "pysim"), ("rods_a4", "lammps-rigid"),
            ("scaling_spheres", "pysim"), ("scaling_rods", "pysim")} <= cases
    assert all(float(r["seconds"]) > 0 and float(r["throughput"]) > 0 for r in table)
    # a scaling point times scaling_steps steps, repeated from the tiled state until about
    # scaling_work particle-steps: 300 spheres twice, 600 once
    assert {(int(r["n"]), int(r["steps"])) for r in table
            if r["case"] == "scaling_spheres"} == {(300, 10), (600, 5)}
    assert {(int(r["n"]), int(r["steps"])) for r in table
            if r["case"] == "scaling_rods"} == {(200, 15), (400, 10), (600, 5)}
    # each scaling size is timed scaling_repeats times per core count, in rounds over
    # all sizes (a slow spell of the machine then slows one timing of each), once per
    # round even where two targets tile to it (310 spheres tile to 300; rods of 200
    # tile to 200, 400 and 600)
    points = [(r["case"], int(r["n"])) for r in table if r["case"].startswith("scaling")]
    assert len(points) == 10 and points[:5] == points[5:]
    assert len(set(points)) == 5
    q = bench.ratios(rows)
    assert {(c, p) for c, _, p, *_ in q} >= {("spheres_friction", "lammps-legacy"),
                                              ("rods_a4", "lammps-rigid")}
    bench.plot(rows, tmp_path / "bench.png")
    assert (tmp_path / "bench.png").stat().st_size > 1000


def test_scaling_segments_time_the_same_steps_of_one_trajectory(tmp_path):
    """Each segment of a scaling point starts from the state as written: the contacts at
    the end of every segment are those after WARM_STEPS + steps steps of one run, not
    of a run that went on."""
    import pysim.simulation as ps
    from pysim import State

    x, u, r, length, box = bench.dense_rods(200, 4.0, 0.5)
    path = tmp_path / "rods.npz"
    np.savez(path, x=x, u=u, radius=r, length=length, box=box)
    got = bench.run_pysim(path, 1, 5, True, segments=3)
    m = bench.MODEL
    sim = ps.Simulation(State.create(x, r, length, box, axis=u),
                        ps.ContactModel("hooke", m["k_n"], m["gamma_n"], k_t=m["k_t"],
                                        gamma_t=m["gamma_t"], mu=m["mu"]), dt=m["dt"])
    seen = []
    for _ in range(3):
        sim.run(bench.WARM_STEPS + 5 if not seen else 5)
        seen.append(sim.thermo().n_contacts)
    assert got["segment_contacts"] == [seen[0]] * 3
    assert got["seconds"] > 0
    # the state unjams: a run that went on would have ended with other contacts
    assert seen[1:] != seen[:1] * 2


def test_scaling_spread_is_time_per_particle_step_over_that_near_1e4():
    rows = [dict(case="scaling_spheres", engine="pysim", cores=c, n=n, steps=s,
                 seconds=sec) for c, n, s, sec in
            [(1, 1000, 100, 0.1), (1, 10_000, 10, 0.1), (1, 10_000, 10, 0.13),
             (1, 1_000_000, 2, 3.0),
             (2, 12_000, 10, 0.06), (2, 900_000, 2, 2.7)]]
    rows.append(dict(case="spheres_friction", engine="pysim", cores=1, n=10, steps=1,
                     seconds=1.0))
    got = {(c, n): q for _, c, n, q in bench.scaling_spread(rows)}
    # 1 core: 1e-6 s per particle-step at 10^4 (the faster of two), 1.5e-6 at 10^6; the
    # point below 10^4 left out
    assert got.keys() == {(1, 10_000), (1, 1_000_000), (2, 12_000), (2, 900_000)}
    assert np.isclose(got[1, 10_000], 1.0) and np.isclose(got[1, 1_000_000], 1.5)
    assert np.isclose(got[2, 900_000], (2.7 / 1.8e6) / (0.06 / 1.2e5))


def test_tiled_states_hold_every_image_sorted_by_cell(rng):
    """Tiling copies every particle into each periodic image, with its other arrays, and
    sorts the whole by cell, so that neighbours lie close in memory."""
    from pysim.neighbors import spatial_order

    box = np.array([3.0, 4.0, 5.0])
    x = rng.uniform(0, 1, (50, 3)) * box
    tag = np.arange(50.0)
    (xs, ts), big = bench.tile([x, tag], box, (2, 1, 3))
    np.testing.assert_array_equal(big, box * [2, 1, 3])
    assert len(xs) == 300
    np.testing.assert_array_equal(spatial_order(xs, big), np.arange(300))
    # each particle's six images: its own position shifted by whole boxes
    for k in (0, 17, 49):
        images = xs[ts == k]
        assert len(images) == 6
        shifts = (images - x[k]) / box
        np.testing.assert_allclose(shifts, np.round(shifts), atol=1e-12)
        assert len({tuple(s) for s in np.round(shifts)}) == 6


def test_glued_rods_have_nine_spheres_at_half_diameter_spacing(tmp_path):
    x = np.array([[1.0, 2.0, 3.0]])
    u = np.array([[0.0, 0.6, 0.8]])
    c, mol = glued_spheres(x, u, 0.5, 4.0, 9)
    np.testing.assert_allclose(np.linalg.norm(np.diff(c, axis=0), axis=1), 0.5)
    np.testing.assert_allclose(c.mean(axis=0), x[0])
    assert mol.tolist() == [1] * 9
    vol = write_glued_rods_data(tmp_path / "g.data", x, u, 0.5, 4.0, [10, 10, 10], 9, 2.0)
    assert vol == np.pi * 4 / 4 + np.pi / 6
    text = (tmp_path / "g.data").read_text()
    assert "9 atoms" in text and "Molecules" in text


def test_busy_cores_measures_another_busy_process():
    """The warning's measure: a spinning child process keeps about one core busy."""
    import subprocess
    import sys

    idle = bench.busy_cores(0.5)
    assert 0.0 <= idle <= (__import__("os").cpu_count() or 1)
    spin = subprocess.Popen([sys.executable, "-c", "while True: pass"])
    try:
        busy = bench.busy_cores(1.0)
    finally:
        spin.kill()
        spin.wait()
    assert busy >= 0.7
