"""Time-step check of a tapped bed (pysim): settle a tapping case once per time step at the
case's own ``dt``, then tap it at each given ``dt`` from that same settled bed, and record
the kinetic energy per grain (in ``m g D`` of the mean grain) and the contacts per grain
50 times per tap.

Two questions it answers: do the first taps converge with the time step (they should: the
same bed, the same base motion), and how far apart do two trajectories drift over many
taps when they differ only by round-off (``--dt 2e-5 2.0000001e-5``)? Over tens of taps a
tapped bed is chaotic, so a single run's window average scatters between trajectories;
compare sets (e.g. e_n 0.1 against 0.4) only against that scatter.

    python -m workflows.scripts.tap_trajectories results/tapping_damping/an6/seed1/case.yaml \\
        results/tapping_damping/an6/seed1/init.data --taps 100 --dt 2e-5 2.0000001e-5 1e-5 \\
        --out an6_dt.csv

Writes ``--out`` (CSV: ``dt, tap, phase, ke_mgd, contacts``, one row per sample) and
prints the mean ``ke_mgd`` over windows of taps and the contacts left at the most
airborne phase over those at the most compressed one (``contacts_flight``).
"""
from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

import numpy as np
import pandas as pd

SAMPLES = 50  # per tap
WINDOWS = ((0, 6), (6, 25), (25, 50), (50, 100), (100, 200), (200, 400))


def trajectories(case: dict, init: dict, dts, taps: int, log=print) -> pd.DataFrame:
    """Rows ``dt, tap, phase, ke_mgd, contacts`` of ``taps`` taps at each time step in
    ``dts``, each from the bed settled and relaxed at the case's ``protocol.dt``."""
    from pysim.protocols import tapping as tap
    from pysim.protocols.deposit import grain_mass

    if taps < 1:
        raise ValueError(f"taps must be >= 1, got {taps}")
    tp = tap.plan(case["protocol"], case["gravity"])
    mgd = grain_mass(case) * case["gravity"] * case["particles"]["diameter"]["mean"]
    frames = []
    for dt in dts:
        if not 0 < dt <= tp.period / SAMPLES:
            raise ValueError(f"dt must be in (0, {tp.period / SAMPLES:g}] (T/{SAMPLES}), got {dt}")
        sim = tap.simulation_from_case(case, init)
        drag = tap.settle_drag(case)
        for stop in (tp.settle_steps, tp.start):
            tap.set_stage(sim, tp, drag)
            sim.run(stop - sim.state.step)
        tap.set_stage(sim, tp, drag)
        sim.dt = dt  # the base moves with the time, so it continues at its phase
        sub = int(round(tp.period / dt)) // SAMPLES
        rows = []
        for k in range(taps * SAMPLES):
            sim.run(sub)
            th = sim.thermo()
            t = (th.time - tp.t0) / tp.period
            rows.append((dt, k // SAMPLES, t - math.floor(t), th.ke / (sim.state.n * mgd),
                         th.n_contacts / sim.state.n))
        df = pd.DataFrame(rows, columns=["dt", "tap", "phase", "ke_mgd", "contacts"])
        frames.append(df)
        log(summary_line(df))
    return pd.concat(frames, ignore_index=True)


def summary_line(df: pd.DataFrame) -> str:
    """Window means of ``ke_mgd`` and ``contacts_flight`` of one time step's rows."""
    out = [f"dt {float(df.dt.iloc[0])!r}:"]
    taps = df.tap.max() + 1
    for a, b in WINDOWS:
        if a >= taps:
            break
        w = df[(df.tap >= a) & (df.tap < b)]
        profile = w.groupby(w.index % SAMPLES).contacts.mean()
        flight = profile.min() / profile.max() if profile.max() > 0 else float("nan")
        out.append(f"taps {a}-{min(b, taps)} ke {w.ke_mgd.mean():.3f} flight {flight:.2f}")
    return " | ".join(out)


def main(argv=None) -> int:
    from pysim.io import read_particle_data
    from rodcase.files import atomic_write_text
    from workflows.scripts import case_or_none

    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("case", type=Path,
                    help="a tapping case (results/<study>/<variant>/seed<k>/case.yaml)")
    ap.add_argument("data", type=Path, help="its initial configuration (init.data)")
    ap.add_argument("--dt", type=float, nargs="+", required=True, help="time steps (s)")
    ap.add_argument("--taps", type=int, default=10)
    ap.add_argument("--out", type=Path, required=True, help="samples (CSV)")
    a = ap.parse_args(argv)
    case = case_or_none(a.case)
    if case is None:
        return 2
    if case["protocol"]["name"] != "tapping":
        print(f"error: {a.case} runs protocol {case['protocol']['name']!r}, not 'tapping'",
              file=sys.stderr)
        return 2
    try:
        df = trajectories(case, read_particle_data(a.data), a.dt, a.taps)
    except ValueError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    atomic_write_text(a.out, df.to_csv(index=False))
    return 0


if __name__ == "__main__":
    sys.exit(main())
