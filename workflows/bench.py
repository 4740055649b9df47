"""``make bench``: pysim against LAMMPS and LIGGGHTS on the same dense packings, in one run.

Cases (each state is made dense once by a frictionless pysim compression, written as a
data file, and then every engine runs the same number of steps at fixed box with the
same contact model and time step; :data:`MODEL`):

* ``spheres_friction``: spheres at ``phi = 0.64``, linear spring-dashpot with tangential
  history and Coulomb friction (LAMMPS ``gran/hooke/history`` = ``lammps-legacy`` and
  ``pair granular`` = ``lammps-granular``, LIGGGHTS ``hooke/stiffness``).
* ``spheres_frictionless``: the same with ``mu = 0``.
* ``rods_a4``: spherocylinders ``L/D = 4`` at ``phi = 0.5`` with friction; LAMMPS runs them
  as rigid glued-sphere rods (9 spheres, spacing ``D/2``, :mod:`workflows.glued`).
* ``scaling``: pysim alone, spheres and rods tiled from the dense states to ``N`` up to
  10^6 and sorted by cell (:func:`pysim.neighbors.spatial_order`: row-major, the longest
  box axis slowest; LAMMPS sorts its atoms likewise): the same 20 steps of the same
  trajectory at every size (small sizes repeat them from the tiled state, :func:`run`),
  seconds per step and peak memory, on 1 and on 2 threads, each point timed three times
  in rounds over all points; printed as the time per particle-step (the fastest timing)
  relative to ``N = 10^4`` (:func:`scaling_spread`).

Every timing is the engine's own loop time (LAMMPS/LIGGGHTS ``Loop time``; pysim the
wall time of ``Simulation.run``), in a fresh process, engines alternating within each
repeat. 1 core: one MPI rank / one Numba thread; 2 cores: two ranks / two threads.
Writes ``results/bench.csv`` (``case, engine, cores, n, steps, seconds, throughput``;
throughput in particle-steps, for rods rod-steps, per second), ``results/bench.png`` and
prints the pysim/peer ratios (median, min-max over repeats).
"""
from __future__ import annotations

import argparse
import csv
import gc
import json
import os
import re
import shutil
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

PROJECT_ROOT = Path(__file__).resolve().parents[1]
DECKS = PROJECT_ROOT / "inputs"
#: the contact model and time step of every case (D = 1, rho = 1): t_c ~ 50 dt
MODEL = dict(k_n=1e5, gamma_n=50.0, k_t=2e4, gamma_t=10.0, mu=0.5, dt=1e-4)
#: untimed steps of pysim before a timing (the compiled kernels load, the thread pool
#: starts); a scaling point's timed steps are the ones after these
WARM_STEPS = 20
FIELDS = ["case", "engine", "cores", "n", "steps", "seconds", "throughput"]


# -- dense states ------------------------------------------------------------------------------
def dense_spheres(n: int, phi: float, seed: int = 1):
    """Equal spheres (D = 1) compressed without friction from RSA at 0.3 to ``phi``;
    particles sorted by cell. Returns ``(x, radius, box)``."""
    from pysim import State
    from pysim.initial import random_spheres
    from pysim.neighbors import spatial_order
    from pysim.simulation import ContactModel, Simulation

    x, d, box = random_spheres(np.ones(n), 0.3, seed=seed)
    x = x[spatial_order(x, box)]
    st = State.spheres(x, d / 2, box)
    sim = Simulation(st, ContactModel("hooke", 1e5, 300.0, gamma_bg=5.0), dt=1e-4)
    rate = 1.0
    sim.run(int(round(np.log(phi / 0.3) / (3 * rate * 1e-4))), strain_rate=-rate)
    sim.run(2000)  # relax at the final box
    return st.x.copy(), st.radius.copy(), st.box.copy()


def dense_rods(n: int, alpha: float, phi: float, seed: int = 1):
    """Spherocylinders (D = 1, ``L = alpha``) compressed without friction from RSA to
    ``phi``. Returns ``(x, u, radius, length, box)``."""
    from pysim import State
    from pysim.initial import random_spherocylinders
    from pysim.neighbors import spatial_order
    from pysim.simulation import ContactModel, Simulation

    phi0 = 0.15
    x, u, r, length, box = random_spherocylinders(np.full(n, 0.5), np.full(n, float(alpha)),
                                                  phi0, seed)
    order = spatial_order(x, box, 2.0)
    st = State.create(x[order], r[order], length[order], box, axis=u[order])
    sim = Simulation(st, ContactModel("hooke", 1e5, 300.0, gamma_bg=5.0, gamma_rot=5.0),
                     dt=1e-4)
    rate = 1.0
    sim.run(int(round(np.log(phi / phi0) / (3 * rate * 1e-4))), strain_rate=-rate)
    sim.run(2000)
    return st.x.copy(), st.u.copy(), st.radius.copy(), st.length.copy(), st.box.copy()


def tile(arrays, box, reps):
    """Periodic images: ``reps = (kx, ky, kz)`` copies of a periodic state; positions are
    shifted, every other per-particle array repeated, then all sorted by cells of edge 1
    (:func:`pysim.neighbors.spatial_order`), as pysim's large starts are: copy after
    copy, neighbours across the faces of a copy would lie far apart in memory.
    Returns ``(arrays, box)``."""
    from pysim.neighbors import spatial_order

    x = arrays[0]
    shifts = np.array([[a, b, c] for a in range(reps[0]) for b in range(reps[1])
                       for c in range(reps[2])], dtype=np.float64) * box
    xs = (x[None, :, :] + shifts[:, None, :]).reshape(-1, 3)
    rest = [np.concatenate([a] * len(shifts)) for a in arrays[1:]]
    box = box * np.asarray(reps)
    order = spatial_order(xs, box)
    return [xs[order]] + [a[order] for a in rest], box


def reps_for(n_base: int, n_target: int):
    """Tiling ``(kx, ky, kz)`` whose particle count is closest to ``n_target``."""
    best = (1, 1, 1)
    for kx in range(1, 12):
        for ky in range(kx, 12):
            for kz in range(ky, 12):
                if abs(n_base * kx * ky * kz - n_target) < abs(n_base * np.prod(best) - n_target):
                    best = (kx, ky, kz)
    return best


# -- engines ----------------------------------------------------------------------------------
def _loop_time(log: str) -> float:
    m = re.findall(r"Loop time of ([0-9.eE+-]+) on", log)
    if not m:
        raise RuntimeError("no 'Loop time' in the engine output:\n" + log[-2000:])
    return float(m[-1])


def _env(threads: int) -> dict:
    return dict(os.environ, OMP_NUM_THREADS="1", NUMBA_NUM_THREADS=str(threads))


def run_lammps(deck: str, data: Path, cores: int, steps: int, extra: dict, work: Path) -> float:
    """Loop seconds of a LAMMPS bench deck on ``cores`` MPI ranks."""
    exe = str(Path(sys.executable).parent / "lmp")
    cmd = [exe, "-in", str(DECKS / "lammps" / deck), "-log", "none", "-var", "data", str(data),
           "-var", "nsteps", str(steps)]
    for k, v in extra.items():
        cmd += ["-var", k, str(v)]
    if cores > 1:
        cmd = [str(Path(sys.executable).parent / "mpiexec"), "-n", str(cores)] + cmd
    p = subprocess.run(cmd, capture_output=True, text=True, cwd=work, env=_env(1), timeout=3600)
    if p.returncode != 0:
        raise RuntimeError(f"LAMMPS failed: {p.stdout[-1500:]} {p.stderr[-1500:]}")
    return _loop_time(p.stdout)


def run_liggghts(data: Path, cores: int, steps: int, extra: dict, work: Path) -> float:
    """Loop seconds of the LIGGGHTS bench deck on ``cores`` MPI ranks."""
    cmd = [shutil.which("liggghts"), "-in", str(DECKS / "liggghts" / "in.bench.spheres"),
           "-log", str(work / "log.liggghts"), "-var", "data", str(data), "-var", "nsteps",
           str(steps)]
    for k, v in extra.items():
        cmd += ["-var", k, str(v)]
    if cores > 1:
        cmd = [shutil.which("mpirun") or "mpirun", "--allow-run-as-root", "-np", str(cores)] + cmd
    p = subprocess.run(cmd, capture_output=True, text=True, cwd=work, env=_env(1), timeout=3600)
    if p.returncode != 0:
        raise RuntimeError(f"LIGGGHTS failed: {p.stdout[-1500:]} {p.stderr[-1500:]}")
    return _loop_time(p.stdout)


def run_pysim(state: Path, cores: int, steps: int, friction: bool, segments: int = 1) -> dict:
    """``{"seconds", "peak_rss", "base_rss", ...}`` of ``steps`` pysim steps on ``cores``
    Numba threads (``segments`` times from the same state, summed), in a fresh process
    (:func:`_pysim_child`)."""
    cmd = [sys.executable, "-m", "workflows.bench", "_pysim", str(state), str(steps),
           "1" if friction else "0", str(int(segments))]
    p = subprocess.run(cmd, capture_output=True, text=True, env=_env(cores), cwd=PROJECT_ROOT,
                       timeout=7200)
    if p.returncode != 0:
        raise RuntimeError(f"pysim failed: {p.stderr[-3000:]}")
    return json.loads(p.stdout.strip().splitlines()[-1])


def _memory(key: str) -> int:
    """``VmRSS`` (resident now) or ``VmHWM`` (peak) of this process in bytes, from
    ``/proc/self/status``. Not ``getrusage``: its peak survives ``exec`` on Linux, so a
    child would report the peak of the benchmark process that started it."""
    with open("/proc/self/status") as fh:
        for line in fh:
            if line.startswith(key + ":"):
                return int(line.split()[1]) * 1024
    raise KeyError(f"{key} not in /proc/self/status")


def _pysim_child(state: str, steps: int, friction: bool, segments: int = 1):
    """Print, as JSON, the wall time of ``steps`` steps of the state in ``state`` after
    :data:`WARM_STEPS` untimed ones, summed over ``segments`` runs each from the state as
    loaded (so each times the same steps of the same trajectory), with the peak and base
    resident memory, the list rebuilds in the timed steps and each segment's contacts at
    its end."""
    import pysim.simulation as ps
    from pysim import State

    from pysim.initial import random_spherocylinders, random_spheres

    m = MODEL
    model = ps.ContactModel("hooke", m["k_n"], m["gamma_n"], k_t=m["k_t"], gamma_t=m["gamma_t"],
                            mu=m["mu"] if friction else 0.0)
    d = np.load(state)
    # load the compiled kernels on 100 particles of the same kind first, so that the
    # memory per particle counts the particles' arrays and not the machine code
    if "u" in d.files:
        x, u, r, length, box = random_spherocylinders(np.full(100, 0.5), np.full(100, 4.0),
                                                      0.2, 1)
        tiny = State.create(x, r, length, box, axis=u)
    else:
        x, dia, box = random_spheres(np.ones(100), 0.3, seed=1)
        tiny = State.spheres(x, dia / 2, box)
    ps.Simulation(tiny, model, dt=m["dt"]).run(WARM_STEPS)
    del tiny
    base = _memory("VmRSS")
    sec = 0.0
    rebuilds = 0
    contacts = []
    for _ in range(max(1, segments)):
        if "u" in d.files:
            st = State.create(d["x"], d["radius"], d["length"], d["box"], axis=d["u"])
        else:
            st = State.spheres(d["x"], d["radius"], d["box"])
        sim = ps.Simulation(st, model, dt=m["dt"])
        sim.run(WARM_STEPS)  # loads the compiled kernels, starts the thread pool
        before = sim.rebuilds
        t0 = time.perf_counter()
        sim.run(steps)
        sec += time.perf_counter() - t0
        rebuilds += sim.rebuilds - before
        contacts.append(sim.thermo().n_contacts)
        del sim, st  # the next segment's arrays replace these, not join them
        gc.collect()
    peak = _memory("VmHWM")
    print(json.dumps({"seconds": sec, "peak_rss": peak, "base_rss": base,
                      "segment_contacts": contacts,
                      "rebuilds": rebuilds}))


# -- the benchmark ----------------------------------------------------------------------------
def _save_spheres(path, x, r, box, rho=1.0):
    from pysim.io import write_sphere_data

    np.savez(path.with_suffix(".npz"), x=x, radius=r, box=box)
    write_sphere_data(path.with_suffix(".data"), x, 2 * r, box, rho)


def prepare(work: Path, n_spheres: int, n_rods: int, log=print) -> dict:
    """Make (or reuse) the dense states and their data files under ``work``."""
    from workflows.glued import write_glued_rods_data

    work.mkdir(parents=True, exist_ok=True)
    sph = work / f"spheres{n_spheres}"
    if not sph.with_suffix(".npz").exists():
        log(f"compressing {n_spheres} spheres to phi 0.64 ...")
        _save_spheres(sph, *dense_spheres(n_spheres, 0.64))
    rods = work / f"rods{n_rods}"
    if not rods.with_suffix(".npz").exists():
        log(f"compressing {n_rods} rods L/D = 4 to phi 0.5 ...")
        x, u, r, length, box = dense_rods(n_rods, 4.0, 0.5)
        np.savez(rods.with_suffix(".npz"), x=x, u=u, radius=r, length=length, box=box)
        write_glued_rods_data(rods.with_suffix(".data"), x, u, r, length, box, 9, 1.0)
    return {"spheres": sph, "rods": rods}


def busy_cores(seconds: float = 1.0) -> float:
    """Cores kept busy by the whole machine over ``seconds`` (from ``/proc/stat``: the
    non-idle share of all CPU time, times the number of CPUs); called while this process
    sleeps, it is what other processes use."""
    def sample():
        with open("/proc/stat") as fh:
            vals = [int(v) for v in fh.readline().split()[1:]]
        idle = vals[3] + (vals[4] if len(vals) > 4 else 0)  # idle + iowait
        return sum(vals), idle

    t0, i0 = sample()
    time.sleep(seconds)
    t1, i1 = sample()
    total = t1 - t0
    return (1.0 - (i1 - i0) / total) * (os.cpu_count() or 1) if total > 0 else 0.0


#: other processes using more than this many cores make the timings unreliable
BUSY_WARN = 0.1


def _throughput(n, steps, sec):
    return n * steps / sec if sec > 0 else float("nan")


def run(out: Path, n_spheres=10_000, n_rods=2000, steps=1000, rod_steps=500, repeats=3,
        cores=(1, 2), engines=("pysim", "lammps-legacy", "lammps-granular", "liggghts"),
        scaling=(1_000, 10_000, 100_000, 1_000_000), scaling_steps=20, scaling_work=2e7,
        scaling_repeats=3, log=print):
    """The whole benchmark; returns the rows written to ``out``.

    Each scaling point times the same steps of the same trajectory at every ``N``: the
    ``scaling_steps`` steps after :data:`WARM_STEPS`, from the tiled state as written. A
    small system repeats that segment, each time from the state as written, until it
    has run about ``scaling_work`` particle-steps (``segments``, in the row's ``steps``
    as ``scaling_steps * segments``), so that it is timed over as long as the large ones
    (a single short segment is too short to time reliably). Not more steps of one run
    instead: the bench's rods at phi 0.5 unjam as they run and a step costs less with
    fewer contacts, so a small system timed over many steps and the largest over few
    compared different states, not sizes (``docs/performance.md``). Every point is timed
    ``scaling_repeats`` times on each core count, in rounds over all points
    (:func:`scaling_spread` takes the fastest: single timings scatter, and the machine's
    speed drifts over minutes)."""
    out = Path(out).resolve()  # the peers run in the work folder: paths must be absolute
    work = out.parent / "bench"
    busy = busy_cores()
    if busy > BUSY_WARN:
        log(f"warning: other processes keep {busy:.2f} cores busy; the timings and the "
            "ratios are unreliable unless the benchmark runs alone (pause a pipeline with "
            "'make stop')")
    st = prepare(work, n_spheres, n_rods, log)
    engines = [e for e in engines if e != "liggghts" or shutil.which("liggghts")]
    m = MODEL
    meff = 0.5 * np.pi / 6  # equal spheres D = 1, rho = 1
    rows = []

    def add(case, engine, c, n, nsteps, sec, **extra):
        row = dict(case=case, engine=engine, cores=c, n=n, steps=nsteps, seconds=round(sec, 4),
                   throughput=round(_throughput(n, nsteps, sec)))
        rows.append(row)
        log(f"{case:22s} {engine:16s} {c} core(s) n={n:<8d} {nsteps:6d} steps "
            f"{sec:8.3f} s {row['throughput'] / 1e6:7.3f} M/s" +
            "".join(f" {k}={v}" for k, v in extra.items()))

    for rep in range(repeats):
        for c in cores:
            for case, mu in (("spheres_friction", m["mu"]), ("spheres_frictionless", 0.0)):
                data = st["spheres"].with_suffix(".data")
                lvars = dict(k_n=m["k_n"], gamma_n=m["gamma_n"], k_t=m["k_t"],
                             gamma_t=m["gamma_t"], mu=mu, dt=m["dt"], meff=meff)
                for e in engines:
                    if e == "pysim":
                        r = run_pysim(st["spheres"].with_suffix(".npz"), c, steps, mu > 0)
                        add(case, e, c, n_spheres, steps, r["seconds"])
                    elif e.startswith("lammps"):
                        sec = run_lammps("in.bench.spheres", data, c, steps,
                                         dict(lvars, style=e.split("-")[1]), work)
                        add(case, e, c, n_spheres, steps, sec)
                    elif e == "liggghts":
                        lv = {k: v for k, v in lvars.items() if k != "meff"}
                        add(case, e, c, n_spheres, steps, run_liggghts(data, c, steps, lv, work))
            if "pysim" in engines:
                r = run_pysim(st["rods"].with_suffix(".npz"), c, rod_steps, True)
                add("rods_a4", "pysim", c, n_rods, rod_steps, r["seconds"])
            if any(e.startswith("lammps") for e in engines):
                m_rod = np.pi * 4 / 4 + np.pi / 6
                sec = run_lammps("in.bench.rods", st["rods"].with_suffix(".data"), c, rod_steps,
                                 dict(k_n=m["k_n"], gamma_n=m["gamma_n"], k_t=m["k_t"],
                                      gamma_t=m["gamma_t"], mu=m["mu"], dt=m["dt"],
                                      meff=m_rod / 2), work)
                add("rods_a4", "lammps-rigid", c, n_rods, rod_steps, sec)
    if "pysim" in engines:
        points = []
        for kind in ("spheres", "rods"):
            d = np.load(st[kind].with_suffix(".npz"))
            names = ["x", "radius"] + (["u", "length"] if kind == "rods" else [])
            for target in scaling:
                reps = reps_for(len(d["x"]), target)
                n = len(d["x"]) * int(np.prod(reps))
                # the name changes with the order, so that older states are not reused
                path = work / f"scaling_{kind}_{n}_longest_slowest.npz"
                if any(path == q[1] for q in points):
                    continue  # a target that tiles to a size already listed (10^3 -> 10^4)
                if not path.exists():  # tile and sort only once (10^6: seconds)
                    arrays, box = tile([d[k] for k in names], d["box"], reps)
                    np.savez(path, box=box, **dict(zip(names, arrays)))
                segments = max(1, int(round(scaling_work / (n * scaling_steps))))
                points.append((kind, path, n, scaling_steps, segments))
        # every point once per round, so that a slow spell of the machine slows one
        # timing of every size rather than both timings of one size
        for _ in range(scaling_repeats):
            for kind, path, n, nsteps, segments in points:
                for c in cores:
                    r = run_pysim(path, c, nsteps, True, segments)
                    add(f"scaling_{kind}", "pysim", c, n, nsteps * segments, r["seconds"],
                        segments=segments,
                        bytes_per_particle=round((r["peak_rss"] - r["base_rss"]) / n),
                        peak_mib=round(r["peak_rss"] / 2**20), list_rebuilds=r["rebuilds"])
    out.parent.mkdir(parents=True, exist_ok=True)
    with open(out, "w", newline="") as fh:
        w = csv.DictWriter(fh, FIELDS, extrasaction="ignore")
        w.writeheader()
        w.writerows(rows)
    return rows


def ratios(rows) -> list[tuple]:
    """``(case, cores, peer, median, min, max)`` of pysim/peer throughput, repeat by
    repeat (repeats pair up in order)."""
    out = []
    keys = sorted({(r["case"], r["cores"]) for r in rows if not r["case"].startswith("scaling")})
    for case, c in keys:
        sel = [r for r in rows if r["case"] == case and r["cores"] == c]
        mine = [r["throughput"] for r in sel if r["engine"] == "pysim"]
        for peer in sorted({r["engine"] for r in sel} - {"pysim"}):
            theirs = [r["throughput"] for r in sel if r["engine"] == peer]
            q = np.array(mine[:len(theirs)]) / np.array(theirs[:len(mine)])
            if len(q):
                out.append((case, c, peer, float(np.median(q)), float(q.min()), float(q.max())))
    return out


def scaling_spread(rows, base: int = 10_000) -> list[tuple]:
    """``(case, cores, n, ratio)``: the time per particle-step at each scaling point
    ``n`` over that of the point nearest ``base`` particles, for each case and core
    count (the target: within 1.3 from 10^4 to 10^6). Each size counts with the fastest
    of its ``scaling_repeats`` timings (:func:`run` times a size once per round even when
    two targets tile to it, as 10^3 and 10^4 spheres do: the reference size was timed
    twice as often before, and its fastest time then came from twice the draws)."""
    out = []
    for case, c in sorted({(r["case"], r["cores"]) for r in rows
                           if r["case"].startswith("scaling")}):
        per = fastest_per_n(rows, case, c)
        ref = min(per, key=lambda n: abs(np.log(n / base)))
        out += [(case, c, n, per[n] / per[ref]) for n in per if n >= ref]
    return out


def fastest_per_n(rows, case: str, cores: int) -> dict:
    """``{n: seconds per particle-step}`` of ``case`` on ``cores``, the fastest of the
    timings of each ``n``, in increasing ``n``."""
    per = {}
    for r in rows:
        if r["case"] == case and r["cores"] == cores:
            t = r["seconds"] / (r["steps"] * r["n"])
            per[r["n"]] = min(t, per.get(r["n"], t))
    return dict(sorted(per.items()))


def plot(rows, path: Path):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, (a, b) = plt.subplots(1, 2, figsize=(12, 4.5))
    sel = [r for r in rows if not r["case"].startswith("scaling")]
    groups = sorted({(r["case"], r["cores"]) for r in sel})
    engines = sorted({r["engine"] for r in sel}) or ["none"]  # --repeats 0: scaling only
    for k, e in enumerate(engines):
        med = [np.median([r["throughput"] for r in sel if (r["case"], r["cores"]) == g
                          and r["engine"] == e] or [np.nan]) / 1e6 for g in groups]
        a.bar(np.arange(len(groups)) + k * 0.8 / len(engines), med, 0.8 / len(engines), label=e)
    a.set_xticks(np.arange(len(groups)) + 0.4 - 0.4 / len(engines))
    a.set_xticklabels([f"{c}\n{n} core" for c, n in groups], fontsize=7)
    a.set_ylabel("million particle-steps (rods: rod-steps) / s")
    a.legend(fontsize=7)
    for kind in ("spheres", "rods"):
        for c in sorted({r["cores"] for r in rows if r["case"] == f"scaling_{kind}"}):
            per = fastest_per_n(rows, f"scaling_{kind}", c)
            b.loglog(list(per), [t * 1e9 for t in per.values()],
                     "o-" if c == 1 else "s--", label=f"{kind}, {c} core(s)")
    b.set_xlabel("N")
    b.set_ylabel("ns per particle-step (pysim)")
    b.legend()
    fig.tight_layout()
    fig.savefig(path, dpi=110)


def main(argv=None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    if argv and argv[0] == "_pysim":
        _pysim_child(argv[1], int(argv[2]), argv[3] == "1", int(argv[4]) if len(argv) > 4 else 1)
        return 0
    ap = argparse.ArgumentParser(prog="python -m workflows.bench", description=__doc__.split("\n\n")[0])
    ap.add_argument("--out", type=Path, default=PROJECT_ROOT / "results" / "bench.csv")
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--steps", type=int, default=1000)
    ap.add_argument("--rod-steps", type=int, default=500)
    ap.add_argument("--n-spheres", type=int, default=10_000)
    ap.add_argument("--n-rods", type=int, default=2000)
    ap.add_argument("--engines", default="pysim,lammps-legacy,lammps-granular,liggghts")
    ap.add_argument("--scaling", default="1000,10000,100000,1000000")
    ap.add_argument("--scaling-steps", type=int, default=20,
                    help="timed steps of a scaling segment, the same at every size")
    ap.add_argument("--scaling-work", type=float, default=2e7,
                    help="particle-steps per scaling point (segments = work / (N steps))")
    ap.add_argument("--scaling-repeats", type=int, default=3,
                    help="timings of each scaling point on each core count (the fastest counts)")
    ap.add_argument("--cores", default="1,2")
    a = ap.parse_args(argv)
    rows = run(a.out, a.n_spheres, a.n_rods, a.steps, a.rod_steps, a.repeats,
               tuple(int(c) for c in a.cores.split(",")), tuple(a.engines.split(",")),
               tuple(int(s) for s in a.scaling.split(",") if s), a.scaling_steps,
               a.scaling_work, a.scaling_repeats)
    plot(rows, a.out.with_suffix(".png"))
    print("\npysim / peer throughput (median, min-max over repeats):")
    for case, c, peer, med, lo, hi in ratios(rows):
        print(f"  {case:22s} {c} core(s)  vs {peer:16s} {med:6.2f}x  ({lo:.2f}-{hi:.2f})")
    spread = scaling_spread(rows)
    if spread:
        print("\npysim time per particle-step relative to the point nearest 10^4 particles:")
        for case, c, n, q in spread:
            print(f"  {case:22s} {c} core(s)  n={n:<8d} {q:5.2f}")
    print(f"wrote {a.out} and {a.out.with_suffix('.png')}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
