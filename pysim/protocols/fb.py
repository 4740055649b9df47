"""The force-biased protocol (``protocol: {name: fb}``, Baranau & Tallarek 2014, refs.
38-40): the FB algorithm (:mod:`pysim.hard.fb`) from the case's Poisson start at the FB
compression rate ``rate``; ``phi`` is the FB density. With a ``closest_jamming`` block
the MLS search (:mod:`pysim.hard.mls`) then runs from that packing and ``phi_j`` is its
closest jamming density: the pair ``(phi, phi_j)`` of one packing of the paper's Fig.
2c,d. Output as :mod:`pysim.protocols.hard`, except that FB has no time, velocities or
pressure: its rows (one per ``iterations`` FB iterations, stage ``fb``) have ``step`` =
iterations so far, ``phi`` the inner spheres' packing fraction, ``rate`` gamma and
``nan`` for time, pressure, kinetic energy and temperature; the MLS rows that follow
count their steps on from the last FB iteration (plus the collisions).
"""
from __future__ import annotations

import math
import time

import numpy as np
from tqdm import tqdm

from pysim.hard.edmd import EDMD, thermal_velocities
from pysim.hard.fb import FB
from pysim.hard.mls import MLS
from pysim.hard.start import velocity_rng
from pysim.protocols.hard import (HardFiles, StartError, clock, mls_params, run_stages,
                                  start_system, summary)


def _system(a: dict) -> EDMD:
    """The packing of the FB positions at rest (only its geometry matters): the
    spheres at the ratio where the closest pair touches."""
    s = EDMD(a["x"], np.zeros((len(a["dn"]), 3)), a["dn"], float(a["side"]), 0.0)
    s.r = s.closest_ratio()
    return s


def _fb_rows(files: HardFiles, fb: FB, a: dict, dump: bool):
    s = _system(a)
    nan = math.nan
    files.rows(fb.done_iterations, nan, s.packing_fraction(), nan, nan, nan,
               len(s.near_contacts(files.contact_gap)[2]), fb.rate, nan, nan, "fb")
    if dump:
        files.dump(s, fb.done_iterations)


def run(case: dict, init: dict, out_dir, progress: bool = True, resume: bool = False,
        checkpoint_every: float = 300.0) -> dict:
    """Run the FB protocol; returns a summary with ``phi`` (and ``phi_j`` after MLS)."""
    p = case["protocol"]
    cj = p.get("closest_jamming")
    files = HardFiles(out_dir, init["ids"], p["contact_gap"])
    dump_every = int(case.get("output", {}).get("dump_every", 4000))
    t0 = time.perf_counter()
    if resume:
        arrays, drv = files.load()
    else:
        s0 = start_system(case, init)  # checks the start; its geometry only
        fb = FB(p["rate"], s0.packing_fraction() / s0.r**3, p["iterations"])
        try:
            arrays = fb.start(s0.x, s0.dn, s0.side)
        except ValueError as exc:
            raise StartError(str(exc)) from None
        files.start()
        files.dump(s0, 0)
        drv = {"stage": 0, "blocks": 0, "states": [fb.to_dict(), None], "phi": {},
               "phi_start": s0.packing_fraction()}
    try:
        if drv["stage"] == 0:
            fb = FB(**drv["states"][0])
            a = {k: arrays[k] for k in ("x", "dn", "f")}
            a["side"] = float(arrays["side"])
            last_ckpt = time.perf_counter()
            t_stage, c_stage = time.perf_counter(), time.process_time()
            bar = tqdm(disable=not progress, unit="step", mininterval=1.0, dynamic_ncols=True,
                       initial=drv["blocks"], desc="pysim fb")
            with bar:
                while not fb.done:
                    fb.step(a)
                    drv["blocks"] += 1
                    drv["states"][0] = fb.to_dict()
                    _fb_rows(files, fb, a, drv["blocks"] % dump_every == 0 or fb.done)
                    bar.update(1)
                    bar.set_postfix(phi=f"{fb.phi():.6f}", rho_out=f"{fb.rho_out:.6f}",
                                    refresh=False)
                    if not fb.done and time.perf_counter() - last_ckpt > checkpoint_every:
                        clock(drv, "fb", t_stage, c_stage)
                        t_stage, c_stage = time.perf_counter(), time.process_time()
                        files.save({k: v for k, v in a.items() if not k.startswith("_")}, drv)
                        last_ckpt = time.perf_counter()
            s = _system(a)
            s.v = thermal_velocities(s.n, p["temperature"], velocity_rng(case["seed"]))
            drv["phi"]["fb"] = s.packing_fraction()
            clock(drv, "fb", t_stage, c_stage)
            drv["stage"] = 1
            drv["step0"] = fb.done_iterations
            files.save(s.arrays(), drv)
        else:
            s = EDMD.from_arrays(arrays)
        if cj is not None:
            if drv["states"][1] is None:
                drv["states"][1] = MLS(**mls_params(cj, p)).to_dict()
            run_stages(s, [MLS(**drv["states"][1])], ["mls"], files, drv, dump_every,
                       progress, checkpoint_every, first=1)
    finally:
        files.close()
    files.finalize()
    out = summary(s, drv, time.perf_counter() - t0, resume)
    out.update(phi=drv["phi"]["fb"], fb_iterations=drv["states"][0]["done_iterations"])
    if cj is not None:
        mls = drv["states"][1]
        out.update(phi_j=drv["phi"]["mls"], mls_reason=mls["reason"],
                   mls_rate_decreases=mls["decreases"])
    return out
