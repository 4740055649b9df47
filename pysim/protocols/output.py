"""Output files and checkpoints shared by the protocol drivers.

A :class:`RunFiles` owns the common-format files of one run directory while the run is
going: they grow as ``<name>.part`` and are renamed when the run completes
(:meth:`finalize`). :meth:`checkpoint` flushes them, records their sizes and saves the
simulation, so that :meth:`RunFiles.resume` can cut the files back to the checkpoint and
the resumed run writes exactly the bytes an uninterrupted run would have written.
"""
from __future__ import annotations

import os
from contextlib import contextmanager
from pathlib import Path

import numpy as np

from pysim import checkpoint, io
from pysim.simulation import BlowUpError

OUTPUTS = ("particles.dump", "contacts.dump", "thermo.dat")
CHECKPOINT = "checkpoint.npz"


class ResumeError(RuntimeError):
    """A run cannot be resumed (no checkpoint, or its files do not match it)."""


class RunFiles:
    """The growing output files of one run (``extra`` names extra whitespace tables).
    Positions are written as ``origin`` plus the state's (box-relative) positions."""

    def __init__(self, out_dir, ids, extra: dict[str, str] | None = None, origin=(0.0, 0.0, 0.0)):
        self.origin = np.asarray(origin, dtype=np.float64)
        self.dir = Path(out_dir)
        self.dir.mkdir(parents=True, exist_ok=True)
        self.ids = np.asarray(ids)
        self.types = np.ones(len(self.ids), dtype=np.int64)
        self.headers = {"thermo.dat": io.thermo_header(), **(extra or {})}
        self.names = list(OUTPUTS) + [k for k in (extra or {}) if k not in OUTPUTS]
        self.paths = {k: self.dir / k for k in self.names}
        self.ckpt = self.dir / CHECKPOINT
        self.fh = {}

    # -- opening -------------------------------------------------------------------------
    def start(self):
        """Open fresh files (and forget any old checkpoint)."""
        self.fh = {k: open(io.part_path(p), "w") for k, p in self.paths.items()}
        for k, h in self.headers.items():
            self.fh[k].write(h)
        self.ckpt.unlink(missing_ok=True)

    def resume(self):
        """Load the checkpoint, cut the files back to it; returns ``(sim, extra)``."""
        if not self.ckpt.exists():
            raise ResumeError(f"{self.ckpt}: no checkpoint to resume from; run without --resume")
        sim, extra = checkpoint.load(self.ckpt)
        self.cut(extra["files"])
        return sim, extra.get("driver", {})

    def cut(self, sizes: dict):
        """Cut the ``.part`` files back to the ``sizes`` a checkpoint recorded and open them
        to append."""
        for name, size in sizes.items():
            part = io.part_path(self.paths[name])
            have = part.stat().st_size if part.exists() else 0
            if have < size:
                raise ResumeError(f"{part}: missing or shorter ({have} bytes) than the checkpoint "
                                  f"records ({size}); rerun from the start")
            with open(part, "r+b") as fh:
                fh.truncate(size)
                # the cut reaches the disk before the run appends over the freed space
                os.fsync(fh.fileno())
        self.fh = {k: open(io.part_path(p), "a") for k, p in self.paths.items()}

    # -- writing -------------------------------------------------------------------------
    def dump(self, sim):
        """One frame of ``particles.dump`` and ``contacts.dump`` (pair and wall rows)."""
        s = sim.state
        rods = bool(np.any(s.length > 0)) or s.dimension == 2
        axis = s.u
        if s.dimension == 2:  # spines in the plane exactly (quaternion rounding aside)
            axis = s.u.copy()
            axis[:, 2] = 0.0
            axis /= np.linalg.norm(axis, axis=1, keepdims=True)
        shifted = bool(np.any(self.origin != 0.0))
        ids = self.ids[:s.n]  # a fed run holds the first n grains so far
        io.write_particles_frame(self.fh["particles.dump"], s.step, s.box, s.periodic, ids,
                                 self.types[:s.n], s.x + self.origin if shifted else s.x, s.radius,
                                 axis=axis if rods else None, length=s.length if rods else None,
                                 box_lo=self.origin)
        ij, rec = sim.contact_table()
        ij_ids = ids[ij]
        if sim.n_walls:
            iw, wrec = sim.wall_contact_table()
            wall_ids = np.column_stack([ids[iw[:, 0]], -(iw[:, 1] + 1)])
            ij_ids = np.vstack([ij_ids, wall_ids])
            rec = np.vstack([rec, wrec])
        if shifted:
            rec = rec.copy()
            rec[:, 0:3] += self.origin
        io.write_contacts_frame(self.fh["contacts.dump"], s.step, s.box, s.periodic, ij_ids, rec,
                                box_lo=self.origin)

    def thermo(self, row):
        io.write_thermo_row(self.fh["thermo.dat"], row)

    def write(self, name: str, line: str):
        self.fh[name].write(line)

    def checkpoint(self, sim, driver: dict | None = None):
        """Flush the files and save a checkpoint that records their sizes."""
        sizes = {}
        for k, f in self.fh.items():
            f.flush()
            os.fsync(f.fileno())
            sizes[k] = f.tell()
        checkpoint.save(sim, self.ckpt, extra={"files": sizes, "driver": driver or {}})

    # -- closing -------------------------------------------------------------------------
    @contextmanager
    def guard(self, bar):
        """The body of a run: closes the progress ``bar`` and the files however it ends,
        and a :class:`BlowUpError` leaves naming the last good checkpoint."""
        try:
            yield
        except BlowUpError as exc:
            raise BlowUpError(f"{exc}; the last good checkpoint is {self.ckpt}") from None
        finally:
            bar.close()
            self.close()

    def close(self):
        for f in self.fh.values():
            if not f.closed:
                f.close()

    def finalize(self):
        """Close, rename every ``.part`` file to its final name, drop the checkpoint."""
        self.close()
        for p in self.paths.values():
            io.finalize(p)
        self.ckpt.unlink(missing_ok=True)
        io.part_path(self.ckpt).unlink(missing_ok=True)  # a checkpoint cut short by a kill
