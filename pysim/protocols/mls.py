"""The closest-jamming search alone (``protocol: {name: mls}``, Baranau & Tallarek 2014,
Sec. III.B): the MLS search (:mod:`pysim.hard.mls`) from the start, the case's Poisson
points or a packing given as the data file (``python -m pysim run --data``); ``phi_j``
(= ``phi``) is the closest jamming density of that start. Output:
:mod:`pysim.protocols.hard`.
"""
from __future__ import annotations

from pysim.hard.mls import MLS
from pysim.protocols.hard import drive, mls_params, summary


def run(case: dict, init: dict, out_dir, progress: bool = True, resume: bool = False,
        checkpoint_every: float = 300.0) -> dict:
    """Run the MLS search; returns a summary with ``phi_j`` (and ``phi``, the same)."""
    p = case["protocol"]

    def make_stages(states):
        mls = MLS(**(states[0] if states is not None else mls_params(p, p)))
        return [mls], ["mls"]

    s, drv, wall = drive(case, init, out_dir, make_stages, progress, resume, checkpoint_every)
    out = summary(s, drv, wall, resume)
    mls = drv["states"][0]
    out.update(phi=drv["phi"]["mls"], phi_j=drv["phi"]["mls"], mls_reason=mls["reason"],
               mls_rate_decreases=mls["decreases"])
    return out
