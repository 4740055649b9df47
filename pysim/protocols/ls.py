"""The Lubachevsky-Stillinger protocol (``protocol: {name: ls}``, Baranau & Tallarek
2014): compress the case's Poisson start at the compression rate ``rate`` until the
reduced pressure reaches ``pressure_max`` (:mod:`pysim.hard.ls`); ``phi`` is the LS
density. With a ``closest_jamming`` block, the MLS search (:mod:`pysim.hard.mls`) then
runs from that packing and ``phi_j`` is its closest jamming density: the pair
``(phi, phi_j)`` of one packing of the paper's Fig. 2a,b. Output: :mod:`pysim.protocols.hard`.
"""
from __future__ import annotations

from pysim.hard.ls import LS
from pysim.hard.mls import MLS
from pysim.protocols.hard import drive, mls_params, summary


def run(case: dict, init: dict, out_dir, progress: bool = True, resume: bool = False,
        checkpoint_every: float = 300.0) -> dict:
    """Run the LS protocol; returns a summary with ``phi`` (and ``phi_j`` after MLS)."""
    p = case["protocol"]
    cj = p.get("closest_jamming")

    def make_stages(states):
        ls = LS(p["rate"], p["temperature"], p["pressure_max"], p["collisions_per_particle"])
        stages, names = [ls], ["ls"]
        if cj is not None:
            stages.append(MLS(**mls_params(cj, p)))
            names.append("mls")
        if states is not None:
            stages = [type(st)(**state) for st, state in zip(stages, states)]
        return stages, names

    s, drv, wall = drive(case, init, out_dir, make_stages, progress, resume, checkpoint_every)
    out = summary(s, drv, wall, resume)
    out["phi"] = drv["phi"]["ls"]
    if cj is not None:
        mls = drv["states"][1]
        out.update(phi_j=drv["phi"]["mls"], mls_reason=mls["reason"],
                   mls_rate_decreases=mls["decreases"])
    return out
