"""Checkpoints: the complete state of a :class:`~pysim.simulation.Simulation`.

Everything the next step depends on is stored — positions, velocities, orientations,
forces and torques of the last evaluation (the next half kick uses them), the pair list
with its tangential springs, wall springs, the clock segment and the driver's own
progress (``extra``, any JSON-serialisable dict) — so that a run resumed from a
checkpoint reproduces the uninterrupted run bit for bit. Files are written to a
temporary name, flushed and renamed: a checkpoint on disk is always complete.
"""
from __future__ import annotations

import json
import os
from dataclasses import asdict
from pathlib import Path

import numpy as np

from pysim.integrators import DIM2, RODS, SYS_SIZE
from pysim.simulation import ContactModel, Simulation
from pysim.state import State

FORMAT = 1
_STATE_ARRAYS = ("x", "v", "q", "u", "omega", "radius", "length", "mass", "inertia", "box",
                 "periodic")
_SIM_ARRAYS = ("half", "r_int", "f", "torque", "virial", "pi", "pj", "hist", "x_ref",
               "u_ref", "box_ref", "whist", "wall_force", "sys", "planes", "cyls")
#: arrays that checkpoints of earlier versions may lack (rebuilt on load)
_OPTIONAL = ("u_ref",)


def save(sim: Simulation, path, extra: dict | None = None) -> Path:
    """Write a checkpoint of ``sim`` (and the driver's ``extra``) atomically."""
    path = Path(path)
    s = sim.state
    arrays = {f"state_{k}": getattr(s, k) for k in _STATE_ARRAYS}
    arrays.update({f"sim_{k}": getattr(sim, k) for k in _SIM_ARRAYS})
    meta = {
        "format": FORMAT,
        "state": {"dimension": s.dimension, "density": s.density, "step": s.step, "time": s.time},
        "sim": {"dt": sim._dt, "t_seg": sim._t_seg, "s_seg": sim._s_seg, "skin": sim.skin,
                "max_overlap": sim.max_overlap, "pe": sim._pe, "nc": sim._nc, "nw": sim._nw,
                "rebuilds": sim.rebuilds, "n_walls": sim.n_walls},
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
    """Restore a :class:`Simulation` and the driver's ``extra`` from a checkpoint."""
    path = Path(path)
    try:
        data = np.load(path)
    except (OSError, ValueError) as exc:
        raise ValueError(f"{path}: not a readable checkpoint ({exc})") from None
    with data:
        meta = json.loads(bytes(data["meta"]).decode())
        if meta.get("format") != FORMAT:
            raise ValueError(f"{path}: checkpoint format {meta.get('format')} is not {FORMAT}")
        st = meta["state"]
        state = State(**{k: data[f"state_{k}"].copy() for k in _STATE_ARRAYS},
                      dimension=st["dimension"], density=st["density"], step=st["step"],
                      time=st["time"])
        sim = Simulation.__new__(Simulation)
        sim.state = state
        sim.model = ContactModel(**meta["model"])
        missing = [k for k in _SIM_ARRAYS if f"sim_{k}" not in data.files]
        if set(missing) - set(_OPTIONAL):
            raise ValueError(f"{path}: checkpoint lacks {missing}")
        for k in _SIM_ARRAYS:
            if k not in missing:
                setattr(sim, k, data[f"sim_{k}"].copy())
    m = meta["sim"]
    sim._dt, sim._t_seg, sim._s_seg = m["dt"], m["t_seg"], m["s_seg"]
    sim.skin, sim.max_overlap = m["skin"], m["max_overlap"]
    sim._pe, sim._nc, sim._nw, sim.rebuilds = m["pe"], m["nc"], m["nw"], m["rebuilds"]
    sim.n_walls = m["n_walls"]
    sim._cp = sim.model.pair_params()
    sim._wp = sim.model.wall_params()
    sim._wfriction = sim._wp[4] > 0
    sim._index_pairs()
    if missing or len(sim.sys) < SYS_SIZE:
        # an earlier version's checkpoint: complete sys and start a fresh pair list (the
        # forces do not depend on the list, so the run continues unchanged)
        sys = np.zeros(SYS_SIZE)
        sys[:len(sim.sys)] = sim.sys
        sys[RODS] = 1.0 if np.any(sim.half > 0) else 0.0
        sys[DIM2] = 1.0 if state.dimension == 2 else 0.0
        sim.sys = sys
        sim.u_ref = state.u.copy() if sys[RODS] else np.zeros((0, 3))
        sim._rebuild()
        sim.rebuilds -= 1
    sim._new_scratch()
    return sim, meta["extra"]
