"""What the hard-sphere drivers (:mod:`pysim.protocols.ls`, :mod:`~pysim.protocols.mls`,
:mod:`~pysim.protocols.fb`) share: the system from the start, the output files, the
checkpoints, and running stages of blocks.

A run is a list of *stages* (a generation, LS or FB, then optionally the MLS search),
each an object with ``step(system)`` (one block; returns what it measured), ``done`` and
``to_dict()``. Output, in the common format (docs/formats.md):

* ``thermo.dat``: a row per block: ``step`` = collisions so far (FB: iterations),
  ``time`` the simulated time, ``phi``, ``pressure`` the collisional pressure of the
  block (kinetic part excluded), ``ke`` the block's mean kinetic energy (before the
  rescaling), ``pe`` 0 (hard spheres), ``n_contacts`` the pairs closer than
  ``contact_gap`` times their contact distance;
* ``blocks.dat``: a row per block, ``step time phi rate reduced_pressure temperature
  stage``, the reduced pressure ``Z`` that drives LS and MLS and the block's mean
  temperature (before the rescaling);
* ``particles.dump`` and ``contacts.dump``: frames at the start, every
  ``output.dump_every`` blocks and at the end of every stage; a contact row is a pair
  closer than ``contact_gap`` times its contact distance, its ``overlap`` minus the gap
  (so at most round-off above 0) and its force 0.

The state is checkpointed between blocks (every ``checkpoint_every`` seconds and at the
end of each stage); a resumed run writes the bytes the uninterrupted run writes.
"""
from __future__ import annotations

import json
import os
import time

import numpy as np
from tqdm import tqdm

from pysim import io
from pysim.hard.edmd import EDMD, thermal_velocities
from pysim.hard.start import velocity_rng
from pysim.protocols.output import ResumeError, RunFiles

BLOCKS_HEADER = "# step time phi rate reduced_pressure temperature stage\n"


class StartError(ValueError):
    """The start of a hard-sphere run is not one it can use; the message is one line."""


def start_system(case: dict, init: dict) -> EDMD:
    """The system of a run's start: the data file's spheres as nominal diameters, the
    ratio ``r`` at which its closest pair touches (a Poisson start begins with tiny
    spheres), thermal velocities at the protocol's temperature."""
    box = np.asarray(init["box"], float)
    if not np.allclose(box, box[0], rtol=1e-12) or np.any(init["length"] > 0):
        raise StartError(f"hard-sphere protocols need spheres in a cube; the start has box "
                         f"{box.tolist()} and rods: {bool(np.any(init['length'] > 0))}")
    p = case["protocol"]
    dn = 2.0 * np.asarray(init["radius"], float)
    x = np.asarray(init["x"], float) - np.asarray(init["box_lo"], float)
    v = thermal_velocities(len(dn), p["temperature"], velocity_rng(case["seed"]))
    s = EDMD(x, v, dn, float(box[0]), 0.0)
    s.r = s.closest_ratio()
    return s


class HardFiles(RunFiles):
    """The output files of a hard-sphere run and its checkpoints (the system's arrays,
    the files' sizes and the driver's progress, in one ``.npz``)."""

    def __init__(self, out_dir, ids, contact_gap: float):
        super().__init__(out_dir, ids, extra={"blocks.dat": BLOCKS_HEADER})
        self.contact_gap = float(contact_gap)

    def dump(self, s: EDMD, step: int):
        """One frame of both dumps: the spheres at their diameters ``r D^nom`` and the
        near contacts."""
        io.write_particles_frame(self.fh["particles.dump"], step, np.full(3, s.side),
                                 (True, True, True), self.ids, self.types, s.x % s.side,
                                 0.5 * s.r * s.dn)
        ij, dr, gap = s.near_contacts(self.contact_gap)
        d = np.linalg.norm(dr, axis=1)
        nrm = dr / d[:, None] if len(d) else dr
        xi = (s.x % s.side)[ij[:, 0]]
        point = xi + (0.5 * s.r * s.dn[ij[:, 0]] + 0.5 * gap)[:, None] * nrm
        rec = np.column_stack([point, nrm, -gap, np.zeros((len(gap), 3))])
        io.write_contacts_frame(self.fh["contacts.dump"], step, np.full(3, s.side),
                                (True, True, True), self.ids[ij], rec)

    def row(self, s: EDMD, blk, rate: float, stage: str, step: int):
        """The block's rows of ``thermo.dat`` and ``blocks.dat``."""
        self.rows(step, s.time, s.packing_fraction(), blk.pressure, blk.kinetic_mean, 0.0,
                  len(s.near_contacts(self.contact_gap)[2]), rate, blk.reduced_pressure,
                  2.0 * blk.kinetic_mean / (3.0 * s.n), stage)

    def rows(self, step, t, phi, pressure, ke, pe, nc, rate, z, temperature, stage):
        """A row of ``thermo.dat`` and one of ``blocks.dat``."""
        self.thermo((step, t, phi, pressure, ke, pe, nc))
        self.write("blocks.dat", f"{step} {t:.10g} {phi:.12g} {rate:.10g} {z:.10g} "
                                 f"{temperature:.10g} {stage}\n")

    def save(self, arrays: dict, driver: dict):
        """Flush the files and checkpoint the state's ``arrays`` with the files' sizes and
        the driver's progress."""
        sizes = {}
        for k, f in self.fh.items():
            f.flush()
            os.fsync(f.fileno())
            sizes[k] = f.tell()
        meta = {"files": sizes, "driver": driver}
        arrays = {f"sys_{k}": a for k, a in arrays.items()}
        arrays["meta"] = np.frombuffer(json.dumps(meta).encode(), dtype=np.uint8)
        tmp = self.ckpt.with_name(self.ckpt.name + ".part")
        with open(tmp, "wb") as fh:
            np.savez(fh, **arrays)
            fh.flush()
            os.fsync(fh.fileno())
        os.replace(tmp, self.ckpt)

    def load(self) -> tuple[dict, dict]:
        """The checkpointed arrays and driver progress; the files cut back to them."""
        if not self.ckpt.exists():
            raise ResumeError(f"{self.ckpt}: no checkpoint to resume from; run without --resume")
        with np.load(self.ckpt) as z:
            meta = json.loads(bytes(z["meta"]).decode())
            arrays = {k[4:]: z[k] for k in z.files if k.startswith("sys_")}
        self.cut(meta["files"])
        return arrays, meta["driver"]


def clock(drv: dict, name: str, wall0: float, cpu0: float):
    """Add the wall and CPU time since ``wall0``, ``cpu0`` to stage ``name``'s (over
    every run of a resumed one)."""
    for key, now, then in (("seconds", time.perf_counter(), wall0),
                           ("cpu_seconds", time.process_time(), cpu0)):
        drv.setdefault(key, {})
        drv[key][name] = drv[key].get(name, 0.0) + now - then


def run_stages(s: EDMD, stages: list, names: list[str], files: HardFiles, drv: dict,
               dump_every: int, progress: bool, checkpoint_every: float,
               first: int = 0) -> dict:
    """Run the stages from ``drv["stage"]`` on (their state in ``drv["states"]``; the
    first is stage ``first`` of the run), a block at a time, recording every block at
    step ``drv["step0"]`` (0 unless set) plus the collisions so far; returns ``drv``
    with ``phi`` of each finished stage (``drv["phi"][name]``)."""
    step0 = drv.get("step0", 0)
    last_ckpt = time.perf_counter()
    bar = tqdm(disable=not progress, unit="block", mininterval=1.0, dynamic_ncols=True,
               initial=drv["blocks"], desc="pysim " + "+".join(names))
    try:
        while drv["stage"] - first < len(stages):
            k = drv["stage"]
            stage, name = stages[k - first], names[k - first]
            t_stage, c_stage = time.perf_counter(), time.process_time()
            while not stage.done:
                rate = stage.rate
                blk = stage.step(s)
                drv["blocks"] += 1
                files.row(s, blk, rate, name, step0 + s.collisions)
                if drv["blocks"] % dump_every == 0:
                    files.dump(s, step0 + s.collisions)
                drv["states"][k] = stage.to_dict()
                bar.update(1)
                bar.set_postfix(phi=f"{s.packing_fraction():.6f}",
                                Z=f"{blk.reduced_pressure:.3g}", rate=f"{rate:.3g}",
                                refresh=False)
                if not stage.done and time.perf_counter() - last_ckpt > checkpoint_every:
                    clock(drv, name, t_stage, c_stage)
                    t_stage, c_stage = time.perf_counter(), time.process_time()
                    files.save(s.arrays(), drv)
                    last_ckpt = time.perf_counter()
            drv["phi"][name] = s.packing_fraction()
            clock(drv, name, t_stage, c_stage)
            drv["stage"] = k + 1
            if drv["blocks"] % dump_every != 0:
                files.dump(s, step0 + s.collisions)
            files.save(s.arrays(), drv)
            last_ckpt = time.perf_counter()
    finally:
        bar.close()
    return drv


def mls_params(block: dict, p: dict) -> dict:
    """The :class:`~pysim.hard.mls.MLS` parameters of a case: the search's own
    (``block``) and the protocol's temperature, pressure and block size."""
    return {"initial_rate": block["initial_rate"], "factor": block["factor"],
            "final_rate": block["final_rate"], "max_equilibrations": block["max_equilibrations"],
            "temperature": p["temperature"], "pressure_max": p["pressure_max"],
            "collisions_per_particle": p["collisions_per_particle"]}


def drive(case: dict, init: dict, out_dir, make_stages, progress: bool, resume: bool,
          checkpoint_every: float) -> tuple[EDMD, dict, float]:
    """Run a hard-sphere protocol: ``make_stages(states)`` gives ``(stages, names)`` from
    the stages' saved states (``None`` for a fresh stage). Returns the final system, the
    driver's record (``phi`` per stage, ``states``) and the wall time."""
    p = case["protocol"]
    files = HardFiles(out_dir, init["ids"], p["contact_gap"])
    t0 = time.perf_counter()
    if resume:
        arrays, drv = files.load()
        s = EDMD.from_arrays(arrays)
    else:
        s = start_system(case, init)
        files.start()
        files.dump(s, 0)
        drv = {"stage": 0, "blocks": 0, "states": None, "phi": {},
               "phi_start": s.packing_fraction()}
    stages, names = make_stages(drv["states"])
    if drv["states"] is None:
        drv["states"] = [st.to_dict() for st in stages]
    dump_every = int(case.get("output", {}).get("dump_every", 4000))
    try:
        run_stages(s, stages, names, files, drv, dump_every, progress, checkpoint_every)
    finally:
        files.close()
    files.finalize()
    return s, drv, time.perf_counter() - t0


def summary(s: EDMD, drv: dict, wall: float, resumed: bool) -> dict:
    """What every hard-sphere run puts in ``run.json``."""
    return {"phi_start": drv["phi_start"], "blocks": drv["blocks"], "collisions": s.collisions,
            "collisions_per_particle": s.collisions / s.n, "time": s.time,
            "wall_seconds": wall, "resumed": bool(resumed),
            "stage_seconds": drv.get("seconds", {}),
            "stage_cpu_seconds": drv.get("cpu_seconds", {})}
