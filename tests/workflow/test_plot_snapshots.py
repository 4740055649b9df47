"""The packing snapshot of a case: the last frame of each engine's first seed, read from
the end of its dump, for 3-D rods (a slab through the box) and 2-D packings (whole)."""
import json

import numpy as np

from analysis import plots
from analysis.io import read_particle_frames
from pysim import io
from workflows.scripts import plot_snapshots


def fake_run(d, rng, n, dim, steps=(0, 10, 20)):
    d.mkdir(parents=True)
    box = np.array([8.0, 8.0, 8.0 if dim == 3 else 0.0])
    with open(d / "particles.dump", "w") as fh:
        for step in steps:
            x = rng.uniform(0, 8, (n, 3))
            u = rng.normal(size=(n, 3))
            if dim == 2:
                x[:, 2] = 0.0
                u[:, 2] = 0.0
            u /= np.linalg.norm(u, axis=1)[:, None]
            io.write_particles_frame(fh, step, box, np.ones(3, bool), np.arange(1, n + 1),
                                     np.ones(n, int), x, np.full(n, 0.5), u, np.full(n, 1.5))
    (d / "run.json").write_text(json.dumps({"status": "ok"}))


def test_last_frame_is_read_from_the_end(tmp_path, rng):
    fake_run(tmp_path / "r", rng, 30, 3)
    whole = read_particle_frames(tmp_path / "r" / "particles.dump")
    last = read_particle_frames(tmp_path / "r" / "particles.dump", last_only=True)
    assert len(last) == 1 and last[0].step == 20
    assert np.array_equal(last[0].x, whole[-1].x) and np.array_equal(last[0].axis, whole[-1].axis)


def test_snapshots_of_3d_and_2d_packings(tmp_path, rng, monkeypatch):
    drawn = []
    real = plots.packing_snapshots
    monkeypatch.setattr(plots, "packing_snapshots",
                        lambda frames, out: (drawn.append(frames), real(frames, out)))
    for dim in (3, 2):
        case = tmp_path / f"d{dim}"
        for seed in (1, 2):
            for engine in ("pysim", "lammps"):
                fake_run(case / f"seed{seed}" / engine, rng, 40, dim)
        out = tmp_path / f"packing{dim}.png"
        dirs = [str(p) for p in sorted(case.glob("seed*/*"))]
        assert plot_snapshots.main(["--out", str(out), *dirs]) == 0
        assert out.stat().st_size > 5000
        assert [t.split(",")[0] for t, _ in drawn[-1]] == ["lammps", "pysim"]  # one seed each
        assert all(f.step == 20 for _, f in drawn[-1])
