"""The feed file of LAMMPS' 2-D fed deposit (``inputs/lammps/in.2d.rods.deposit``): each
grain's entry draws (step, centre, spine angle, velocity) from pysim's own random stream
(:mod:`pysim.protocols.deposit`, ``protocol.feed``).

pysim draws grain ``k``'s entry when it enters, from its own stream
(``default_rng([seed, k])``), and draws again while the spot comes within reach (gap
``<= d_c``) of a grain already in (:func:`pysim.protocols.deposit.entry`). Redraws are not
rare: a grain stays within a grain length of the entry line for about 0.3 s while more
enter (20 per second in the paper's profile: 19 % of the grains are drawn again; 12 % in
a box 5 lengths wide at 5 per second), and which spots are blocked depends on where the
grains near the line are, which differs between engines once two of them have touched.
So the file lists, for every grain, the first draws of pysim's stream (at least
:data:`MIN_TRIES`; :func:`pysim.protocols.deposit.entry_draws`), and the deck applies pysim's rule to its own state: it takes the first
draw whose disks keep a gap above ``d_c`` from every disk in. Where the grains near the
line have flown freely, that is pysim's choice: :func:`entries` replays pysim's
:func:`~pysim.protocols.deposit.entry` with the earlier grains where free flight puts them
(``x_j + v_j t + g t^2 / 2``, which pysim's velocity Verlet integrates exactly up to
rounding), and ``tests/workflow/test_deposit_2d_engines.py`` checks that against a pysim
run.

File format (CSV, ``#`` lines are comments), the draws of each grain in feed order, then
an end row of zeros (id 0)::

    id,step,try,x,y,theta_deg,vx,vy

``id`` the grain's id in ``init.data``; ``step`` its entry step ``round(k / (rate dt))``;
``try`` the draw's number in pysim's stream (0 first); ``x``, ``y`` its centre in the
container's coordinates (m; base at ``y = 0``, walls at ``x = 0`` and ``W``);
``theta_deg`` the spine's angle from ``+x`` in ``[0, 180)`` (degrees); ``vx``, ``vy`` its
velocity (m/s); no spin. Floats are written with every digit.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from workflows.engines.common import EngineError

HEADER = "id,step,try,x,y,theta_deg,vx,vy"
#: draws listed per grain at least (and two past the replay's choice): with 40 % of the
#: first draws blocked (10 grains/s into 2.5 m), 16 leave one grain in 3 million without
#: a free one (the deck stops there)
MIN_TRIES = 16


@dataclass(frozen=True)
class Entries:
    """The entries of a fed case, in feed order (N grains): ``ids`` (N,), ``step`` (N,)
    entry steps, ``x`` (N, 2) centres in the container's coordinates (length), ``theta``
    (N,) spine angles from +x in ``[0, pi)`` (radians), ``v`` (N, 2) velocities
    (length/time), ``redrawn`` (N,) whether pysim's first draw was blocked."""

    ids: np.ndarray
    step: np.ndarray
    x: np.ndarray
    theta: np.ndarray
    v: np.ndarray
    redrawn: np.ndarray


def check_feed_case(case: dict) -> str | None:
    """``None`` when the writer can replay the case's feed, else why not: a 2-D deposit
    with ``protocol.feed`` and no background drag (the free flight of the grains near the
    entry line stands for pysim's state there)."""
    pr, p = case["protocol"], case["particles"]
    if pr["name"] != "deposit" or "feed" not in pr:
        return (f"the fed-deposit feed needs protocol 'deposit' with protocol.feed (got "
                f"protocol {pr['name']!r}{'' if 'feed' in pr else ' without feed'})")
    if p.get("dimension", 3) != 2:
        return f"protocol.feed is 2-D; got particles.dimension = {p.get('dimension', 3)}"
    if case["contact"].get("gamma_bg", 0.0) > 0:
        return (f"contact.gamma_bg = {case['contact']['gamma_bg']}: the feed replays pysim's "
                "entries with the grains in free flight; use gamma_bg 0")
    return None


def draws(case: dict, k: int, radius: float, length: float, lo, count: int):
    """The first ``count`` entry draws of fed grain ``k`` from pysim's stream
    (:func:`pysim.protocols.deposit.entry_draws`), in pysim's coordinates (the
    container's less ``lo``): ``(x (count, 3), u (count, 3), v (count, 3))``."""
    from itertools import islice

    from pysim.protocols.deposit import entry_draws

    x, u, v = zip(*islice(entry_draws(case, k, radius, length, lo), count))
    return np.array(x), np.array(u), np.array(v)


def entries(case: dict, init: dict) -> Entries:
    """pysim's entries of every grain of a fed 2-D deposit (``init``: the initial data of
    :func:`pysim.io.read_particle_data`, the grains in feed order), with the grains fed
    before each entry in free flight (module docstring)."""
    from pysim.protocols.deposit import entry, entry_step

    why = check_feed_case(case)
    if why:
        raise EngineError(why)
    pr = case["protocol"]
    dt = pr["dt"]
    lo = np.asarray(init["box_lo"], dtype=float)
    radius = np.asarray(init["radius"], dtype=float)
    length = np.asarray(init["length"], dtype=float)
    n = len(radius)
    steps = np.array([entry_step(k, pr) for k in range(n)], dtype=np.int64)
    g = np.array([0.0, -case["gravity"], 0.0])
    x0 = np.zeros((n, 3))  # entry centres, pysim's coordinates (the container's - lo)
    u = np.zeros((n, 3))
    v0 = np.zeros((n, 3))
    redrawn = np.zeros(n, dtype=bool)
    for k in range(n):
        t = (steps[k] - steps[:k]) * dt  # time each earlier grain has flown
        flown = x0[:k] + v0[:k] * t[:, None] + 0.5 * g * (t * t)[:, None]
        others = (flown, u[:k], radius[:k], 0.5 * length[:k])
        x0[k], u[k], v0[k] = entry(case, k, radius[k], length[k], lo, others)
        first = draws(case, k, radius[k], length[k], lo, 1)[0][0]
        redrawn[k] = not np.array_equal(first, x0[k])
    theta = np.mod(np.arctan2(u[:, 1], u[:, 0]), math.pi)
    return Entries(np.asarray(init["ids"], dtype=np.int64), steps, x0[:, :2] + lo[:2], theta,
                   v0[:, :2], redrawn)


def write_feed(init_path, out_path, case: dict) -> float:
    """Write the feed file of a fed 2-D deposit (module docstring) from its initial data
    file and return the grains' total area (``2 L R + pi R^2`` each, length^2): the
    adapter table's data writer for ``in.2d.rods.deposit``."""
    from pysim.io import read_particle_data
    from pysim.state import area
    from rodcase.files import atomic_write_text

    init = read_particle_data(init_path)
    e = entries(case, init)
    lo = np.asarray(init["box_lo"], dtype=float)
    fd = case["protocol"]["feed"]
    rows = []
    for k, (gid, step) in enumerate(zip(e.ids, e.step)):
        r, length = float(init["radius"][k]), float(init["length"][k])
        x, u, v = draws(case, k, r, length, lo, MIN_TRIES)
        pick = next((t for t in range(len(x)) if np.array_equal(x[t, :2] + lo[:2], e.x[k])),
                    None)
        if pick is None or pick + 3 > len(x):
            x, u, v = draws(case, k, r, length, lo, 200)
            pick = next(t for t in range(len(x)) if np.array_equal(x[t, :2] + lo[:2], e.x[k]))
            keep = max(MIN_TRIES, pick + 3)
            x, u, v = x[:keep], u[:keep], v[:keep]
        for t in range(len(x)):
            th = math.degrees(math.atan2(u[t, 1], u[t, 0]) % math.pi)
            c = (x[t, :2] + lo[:2]).tolist()
            vt = v[t].tolist()
            rows.append(f"{gid},{step},{t},{c[0]!r},{c[1]!r},{th!r},{vt[0]!r},{vt[1]!r}")
    head = [f"# rodpack feed: {len(e.ids)} grains of a 2-D fed deposit (seed {case.get('seed')}, "
            f"rate {fd['rate']:g}/time, entry line y = {fd['height']:g}, speed "
            f"{fd.get('speed', 0.0):g}): pysim's first draws of each grain; in free flight "
            f"{int(e.redrawn.sum())} grains take a later one", f"# {HEADER}"]
    atomic_write_text(out_path, "\n".join(head + rows + ["0,0,0,0,0,0,0,0"]) + "\n")
    return float(np.sum(area(init["radius"], init["length"])))


def read_feed(path) -> dict[str, np.ndarray]:
    """The columns of a feed file (:data:`HEADER`) as arrays, without the end row."""
    table = np.loadtxt(Path(path), delimiter=",", comments="#", ndmin=2)[:-1]
    return {name: table[:, k] for k, name in enumerate(HEADER.split(","))}
