"""Checkpoints: the complete state of a :class:`~pysim.simulation.Simulation`.

Everything the next step depends on is stored — positions, velocities, orientations,
forces and torques of the last evaluation (the next half kick uses them), the pair list
with its tangential springs, wall springs, the clock segment and the driver's own
progress (``extra``, any JSON-serialisable dict) — so that a run resumed from a
checkpoint reproduces the uninterrupted run bit for bit. Files are written to a
temporary name, flushed and renamed: a checkpoint on disk is always complete.

The kernels' scalars are stored as the two records of :mod:`pysim.records`, by field
name (format 2). Format 1 kept them in one float array of slots (``sim_sys``,
:data:`FORMAT1_SLOTS`); such checkpoints load into the records and resume with the same
bits.
"""
from __future__ import annotations

import json
import os
from dataclasses import asdict
from pathlib import Path

import numpy as np

from pysim.records import new_cache, new_params
from pysim.simulation import ContactModel, Simulation
from pysim.state import State

FORMAT = 2
#: the formats :func:`load` reads
READS = (1, 2)
_STATE_ARRAYS = ("x", "v", "q", "u", "omega", "radius", "length", "mass", "inertia", "box",
                 "periodic")
_SIM_ARRAYS = ("half", "r_int", "f", "torque", "virial", "pi", "pj", "hist", "x_ref",
               "u_ref", "box_ref", "whist", "wall_force", "planes", "cyls")
#: the kernels' records (:mod:`pysim.records`), stored by field name, and their makers
_RECORDS = {"params": new_params, "cache": new_cache}
#: arrays that checkpoints of format 1 may lack (rebuilt on load)
_OPTIONAL = ("u_ref",)
#: Format 1's ``sim_sys``: slot ``k`` held ``(record, field, component)``
#: ``FORMAT1_SLOTS[k]`` (component None: a scalar field), as a float. Checkpoints of
#: earlier versions of that format hold the first slots only.
FORMAT1_SLOTS = (
    ("params", "gamma_bg", None), ("params", "gamma_rot", None),
    ("params", "gravity", 0), ("params", "gravity", 1), ("params", "gravity", 2),
    ("params", "strain_rate", 0), ("params", "strain_rate", 1), ("params", "strain_rate", 2),
    ("params", "growth", None), ("params", "skin", None), ("cache", "rint_build", None),
    ("params", "k_d", None), ("cache", "rc_build", None), ("cache", "half_build", None),
    ("params", "rods", None), ("params", "dim2", None), ("cache", "sep_sigma", None),
    ("cache", "sep_shrink", None), ("params", "parts", None), ("cache", "slot_parts", None),
    ("cache", "worst", 0), ("cache", "worst", 1), ("cache", "own_parts", None),
)


def save(sim: Simulation, path, extra: dict | None = None) -> Path:
    """Write a checkpoint of ``sim`` (and the driver's ``extra``) atomically."""
    path = Path(path)
    s = sim.state
    arrays = {f"state_{k}": getattr(s, k) for k in _STATE_ARRAYS}
    arrays.update({f"sim_{k}": getattr(sim, k) for k in _SIM_ARRAYS})
    arrays.update({f"sim_{k}": np.asarray(getattr(sim, k)) for k in _RECORDS})
    meta = {
        "format": FORMAT,
        "state": {"dimension": s.dimension, "density": s.density, "step": s.step, "time": s.time},
        "sim": {"dt": sim._dt, "t_seg": sim._t_seg, "s_seg": sim._s_seg, "skin": sim.skin,
                "max_overlap": sim.max_overlap, "pe": sim._pe, "nc": sim._nc, "nw": sim._nw,
                "rebuilds": sim.rebuilds, "n_walls": sim.n_walls, "integrator": sim.integrator},
        "model": asdict(sim.model),
        "extra": extra or {},
    }
    arrays["meta"] = np.frombuffer(json.dumps(meta).encode(), dtype=np.uint8)
    tmp = path.with_name(path.name + ".part")
    with open(tmp, "wb") as fh:
        np.savez(fh, **arrays)
        fh.flush()
        os.fsync(fh.fileno())
    os.replace(tmp, path)
    return path


def load(path) -> tuple[Simulation, dict]:
    """Restore a :class:`Simulation` and the driver's ``extra`` from a checkpoint (of any
    format in :data:`READS`)."""
    path = Path(path)
    try:
        data = np.load(path)
    except (OSError, ValueError) as exc:
        raise ValueError(f"{path}: not a readable checkpoint ({exc})") from None
    with data:
        meta = json.loads(bytes(data["meta"]).decode())
        fmt = meta.get("format")
        if fmt not in READS:
            raise ValueError(f"{path}: checkpoint format {fmt} is not one of {READS}")
        st = meta["state"]
        state = State(**{k: data[f"state_{k}"].copy() for k in _STATE_ARRAYS},
                      dimension=st["dimension"], density=st["density"], step=st["step"],
                      time=st["time"])
        sim = Simulation.__new__(Simulation)
        sim.state = state
        sim.model = ContactModel(**meta["model"])
        wanted = _SIM_ARRAYS + (("sys",) if fmt == 1 else tuple(_RECORDS))
        missing = [k for k in wanted if f"sim_{k}" not in data.files]
        if set(missing) - set(_OPTIONAL if fmt == 1 else ()):
            raise ValueError(f"{path}: checkpoint lacks {missing}")
        for k in _SIM_ARRAYS:
            if k not in missing:
                setattr(sim, k, data[f"sim_{k}"].copy())
        if fmt == 1:
            sim.params, sim.cache, complete = _from_slots(data["sim_sys"])
        else:
            sim.params, sim.cache = (_record(path, data[f"sim_{k}"], k) for k in _RECORDS)
            complete = True
    m = meta["sim"]
    sim._dt, sim._t_seg, sim._s_seg = m["dt"], m["t_seg"], m["s_seg"]
    sim.skin, sim.max_overlap = m["skin"], m["max_overlap"]
    sim._pe, sim._nc, sim._nw, sim.rebuilds = m["pe"], m["nc"], m["nw"], m["rebuilds"]
    sim.n_walls = m["n_walls"]
    sim.integrator = m.get("integrator", "verlet")  # earlier checkpoints: velocity Verlet
    sim._cp = sim.model.pair_params()
    sim._wp = sim.model.wall_params()
    sim._wfriction = sim._wp[4] > 0
    sim._index_pairs()
    if missing or not complete:
        # an earlier version's checkpoint: complete the records and start a fresh pair
        # list (the forces do not depend on the list, so the run continues unchanged)
        sim.params["rods"] = bool(np.any(sim.half > 0))
        sim.params["dim2"] = state.dimension == 2
        sim.u_ref = state.u.copy() if sim.params["rods"][0] else np.zeros((0, 3))
        sim._rebuild()
        sim.rebuilds -= 1
    sim._new_scratch()
    return sim, meta["extra"]


def _record(path, saved: np.ndarray, name: str) -> np.ndarray:
    """The record ``name`` (``params`` or ``cache``) from its stored copy, field by field."""
    rec = _RECORDS[name]()
    lacks = [f for f in rec.dtype.names if f not in (saved.dtype.names or ())]
    if lacks:
        raise ValueError(f"{path}: the checkpoint's {name} record lacks the fields {lacks}")
    for f in rec.dtype.names:
        rec[f] = saved[f]
    return rec


def _from_slots(sys: np.ndarray) -> tuple[np.ndarray, np.ndarray, bool]:
    """The records from format 1's slots (:data:`FORMAT1_SLOTS`; fields past the slots
    given stay zero), and whether every slot was there."""
    recs = {name: make() for name, make in _RECORDS.items()}
    for value, (name, field, comp) in zip(np.asarray(sys, dtype=np.float64), FORMAT1_SLOTS):
        rec = recs[name]
        kind = rec.dtype.fields[field][0].base.kind
        value = bool(value != 0.0) if kind == "b" else int(value) if kind == "i" else value
        rec[field][(0,) if comp is None else (0, comp)] = value
    return recs["params"], recs["cache"], len(sys) >= len(FORMAT1_SLOTS)
