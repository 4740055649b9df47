"""Two-rod collisions with LAMMPS' true spherocylinder bodies, checked against physics.

LAMMPS can model a spherocylinder exactly as a 2-vertex ``body rounded/polyhedron``
(a rounded segment). ``shared/engines.md`` records that this release misbehaves:
parallel rods gain energy, nearly parallel rods pass through each other, head-on
contacts give NaN. Before any packing made with the body style is compared with the
other engines, this check collides two rods without damping or friction in a few
geometries and records, for each, the kinetic energy before and after (an elastic
collision must conserve it), whether the run stayed finite, and whether the rods ended
up on the far side of each other (passed through). The same collisions run on pysim's
exact spherocylinders as the reference.

Geometries (rods of aspect ratio ``alpha``, centres ``1.2 D`` apart along ``y`` unless
noted, approaching each other at relative speed 1):

* ``parallel``      both spines along x (side by side)
* ``parallel_3deg`` rod b turned by 3 degrees in the x-y plane
* ``crossed``       rod b along z, spines crossing at their centres
* ``crossed_offset`` rod b along z, shifted by 0.3 D along x
* ``tee``           rod b along y, its tip towards the side of rod a
* ``tip_tip``       both along y, tip to tip (head-on)

In 2-D (``dimension=2``) the rods are 2-vertex ``body rounded/polygon`` bodies (exact
2-D spherocylinders, what a 2-D LAMMPS packing with the body style uses) in the
geometries that stay in the x-y plane (:data:`GEOMETRIES_2D`). The neighbour cutoff of
the polygon pair style in this release leaves out the rounded radii (see
``inputs/lammps/in.2d.body.compress``), so the 2-D deck adds ``D`` to the skin: the check
tests the contact forces, not that pitfall.
"""
from __future__ import annotations

import math
import subprocess
from pathlib import Path

import numpy as np
import pandas as pd

from workflows.engines import EngineError, venv_bin

GEOMETRIES = ("parallel", "parallel_3deg", "crossed", "crossed_offset", "tee", "tip_tip")
#: the geometries that stay in the x-y plane
GEOMETRIES_2D = ("parallel", "parallel_3deg", "tee", "tip_tip")


def geometry(name: str, alpha: float, d: float = 1.0):
    """Centres (2, 3) and unit axes (2, 3) of the two rods before the collision; they
    approach along y."""
    length = alpha * d
    gap = 0.2 * d
    ua = np.array([1.0, 0.0, 0.0])
    if name == "parallel":
        ub = ua.copy()
        sep = d + gap
    elif name == "parallel_3deg":
        a = math.radians(3.0)
        ub = np.array([math.cos(a), math.sin(a), 0.0])
        sep = d + gap + 0.5 * length * math.sin(a)
    elif name in ("crossed", "crossed_offset"):
        ub = np.array([0.0, 0.0, 1.0])
        sep = d + gap
    elif name == "tee":
        ub = np.array([0.0, 1.0, 0.0])
        sep = d + gap + 0.5 * length
    elif name == "tip_tip":
        ua = np.array([0.0, 1.0, 0.0])
        ub = ua.copy()
        sep = d + gap + length
    else:
        raise ValueError(f"unknown geometry {name!r}; valid: {', '.join(GEOMETRIES)}")
    x = np.array([[0.0, -sep / 2, 0.0], [0.0, sep / 2, 0.0]])
    if name == "crossed_offset":
        x[1, 0] = 0.3 * d
    return x, np.array([ua, ub])


def _body_data(path: Path, x, u, alpha, d, density):
    """LAMMPS data file of two 2-vertex rounded-polyhedron bodies (spherocylinders)."""
    from pysim.state import inertia_3d, volume

    length = alpha * d
    m = density * float(volume(d / 2, length))
    ip, ia = (float(v) for v in inertia_3d(d / 2, length, density))
    lines = ["rodpack two-rod check: spherocylinders as 2-vertex rounded polyhedra", "",
             "2 atoms", "2 bodies", "1 atom types",
             "-20 20 xlo xhi", "-20 20 ylo yhi", "-20 20 zlo zhi", "", "Atoms", ""]
    lines += [f"{k + 1} 1 1 {m:.16g} {x[k, 0]:.16g} {x[k, 1]:.16g} {x[k, 2]:.16g}" for k in range(2)]
    lines += ["", "Bodies", ""]
    for k in range(2):
        # body frame: spine along the lab axis u[k], given by its two vertices; the
        # inertia tensor is in the lab frame at t = 0 (LAMMPS diagonalises it)
        tensor = ip * np.eye(3) + (ia - ip) * np.outer(u[k], u[k])
        a = 0.5 * length * u[k]
        lines += [f"{k + 1} 3 13", "2 1 0",
                  " ".join(f"{v:.16g}" for v in (tensor[0, 0], tensor[1, 1], tensor[2, 2],
                                                   tensor[0, 1], tensor[0, 2], tensor[1, 2])),
                  " ".join(f"{v:.16g}" for v in -a), " ".join(f"{v:.16g}" for v in a),
                  f"{d:.16g}"]
    path.write_text("\n".join(lines) + "\n")
    return m


DECK = """\
# two-rod collision, LAMMPS body rounded/polyhedron (written by workflows/body_check.py)
units lj
dimension 3
atom_style body rounded/polyhedron 1 10
atom_modify map array
boundary f f f
read_data {data}
pair_style body/rounded/polyhedron 0.0 0.0 0.0 0.0 {cut_inner}
pair_coeff * * {k_n} 0.0
comm_modify vel yes
neighbor {skin} bin
neigh_modify every 1 delay 0 check yes
timestep {dt}
group a id 1
group b id 2
velocity a set 0 {v} 0
velocity b set 0 -{v} 0
fix integrate all nve/body
compute tb all temp/body
compute_modify tb extra/dof 0
variable ke equal c_tb*3*count(all)
variable ya equal y[1]
variable yb equal y[2]
fix out all print {every} "$(step) ${{ke}} ${{ya}} ${{yb}}" file {table} screen no title "# step ke ya yb"
thermo {every}
run {steps}
"""


def _polygon_data(path: Path, x, u, alpha, d, density):
    """LAMMPS data file of two 2-vertex rounded-polygon bodies (2-D spherocylinders of
    areal density ``density``) in the plane z = 0."""
    from pysim.state import area, inertia_2d

    length = alpha * d
    r = d / 2
    m = density * float(area(r, length))
    i_z = float(inertia_2d(r, length, density))
    i_u = density * (4.0 * (length / 2) * r**3 / 3 + math.pi * r**4 / 4)
    lines = ["rodpack two-rod check: 2-D spherocylinders as 2-vertex rounded polygons", "",
             "2 atoms", "2 bodies", "1 atom types",
             "-20 20 xlo xhi", "-20 20 ylo yhi", "-0.5 0.5 zlo zhi", "", "Atoms # body", ""]
    lines += [f"{k + 1} 1 1 {m:.16g} {x[k, 0]:.16g} {x[k, 1]:.16g} 0" for k in range(2)]
    lines += ["", "Bodies", ""]
    for k in range(2):
        w = np.array([-u[k, 1], u[k, 0], 0.0])
        tensor = i_u * np.outer(u[k], u[k]) + (i_z - i_u) * np.outer(w, w)
        tensor[2, 2] = i_z
        a = 0.5 * length * u[k]
        lines += [f"{k + 1} 1 13", "2",
                  " ".join(f"{v:.16g}" for v in (tensor[0, 0], tensor[1, 1], tensor[2, 2],
                                                   tensor[0, 1], tensor[0, 2], tensor[1, 2])),
                  " ".join(f"{v:.16g}" for v in np.concatenate([-a, a])), f"{d:.16g}"]
    path.write_text("\n".join(lines) + "\n")
    return m


DECK_2D = """\
# two-rod collision, LAMMPS body rounded/polygon (written by workflows/body_check.py)
units lj
dimension 2
atom_style body rounded/polygon 1 6
atom_modify map array
boundary f f p
read_data {data}
pair_style body/rounded/polygon 0.0 0.0 0.0 1.0 {cut_inner}
pair_coeff * * {k_n} 0.0
comm_modify vel yes
neighbor {skin} bin
neigh_modify every 1 delay 0 check yes
timestep {dt}
group a id 1
group b id 2
velocity a set 0 {v} 0
velocity b set 0 -{v} 0
fix integrate all nve/body
fix flat all enforce2d
compute tb all temp/body
compute_modify tb extra/dof 0
variable ke equal c_tb*1.5*count(all)
variable ya equal y[1]
variable yb equal y[2]
fix out all print {every} "$(step) ${{ke}} ${{ya}} ${{yb}}" file {table} screen no title "# step ke ya yb"
thermo {every}
run {steps}
"""


def run_lammps(name: str, alpha: float, work: Path, k_n=1e5, dt=1e-4, steps=20000,
               speed=0.5, density=1.0, dimension: int = 3, skin: float | None = None,
               label: str = "lammps-body") -> dict:
    """Collide two LAMMPS body rods in one geometry (``rounded/polyhedron`` in 3-D,
    ``rounded/polygon`` in 2-D); returns the energy record (engine ``label``).

    ``skin`` is the neighbour skin (default 0.5 D in 3-D, 1.5 D in 2-D: 0.5 D plus the
    rounded diameter the polygon style leaves out of its cutoff). A run that LAMMPS stops
    with ``Lost atoms`` (the rods flew out of the box) is a non-finite result, not an
    error of the check."""
    work = Path(work) / label
    work.mkdir(parents=True, exist_ok=True)
    x, u = geometry(name, alpha)
    if dimension == 2:
        if name not in GEOMETRIES_2D:
            raise ValueError(f"geometry {name!r} leaves the plane; 2-D: {', '.join(GEOMETRIES_2D)}")
        _polygon_data(work / f"{name}.data", x, u, alpha, 1.0, density)
        template, default_skin = DECK_2D, 0.5 + 1.0
    else:
        _body_data(work / f"{name}.data", x, u, alpha, 1.0, density)
        template, default_skin = DECK, 0.5
    skin = default_skin if skin is None else skin
    deck = work / f"in.{name}"
    table = work / f"{name}.dat"
    deck.write_text(template.format(data=work / f"{name}.data", cut_inner=0.5, k_n=k_n,
                                    skin=skin, dt=dt, v=speed, every=100, table=table,
                                    steps=steps))
    proc = subprocess.run([venv_bin("lmp"), "-in", str(deck), "-log", str(work / f"log.{name}")],
                          capture_output=True, text=True, timeout=600)
    err = next((ln for ln in (proc.stdout + proc.stderr).splitlines() if ln.startswith("ERROR")),
               None)
    lost = err is not None and "Lost atoms" in err
    if (proc.returncode != 0 or err) and not lost:
        raise EngineError(f"LAMMPS body check '{name}' failed: {err or proc.returncode}; "
                          f"log: {work / f'log.{name}'}")
    df = pd.read_csv(table, sep=r"\s+", comment="#", header=None,
                     names=["step", "ke", "ya", "yb"], na_values=["nan", "-nan", "inf", "-inf"])
    if lost:  # the rods left the box: record the run as non-finite
        df = pd.concat([df, pd.DataFrame([{"step": steps, "ke": np.nan, "ya": np.nan,
                                           "yb": np.nan}])], ignore_index=True)
    return {"dimension": dimension, "skin": skin, **_summarise(label, name, alpha, df),
            "error": err or ""}


def run_pysim(name: str, alpha: float, k_n=1e5, dt=1e-4, steps=20000, speed=0.5,
              density=1.0, dimension: int = 3) -> dict:
    """The same collision with pysim's exact spherocylinders."""
    from pysim.simulation import ContactModel, Simulation
    from pysim.state import State

    x, u = geometry(name, alpha)
    v = np.array([[0.0, speed, 0.0], [0.0, -speed, 0.0]])
    shift = np.array([20.0, 20.0, 20.0 if dimension == 3 else 0.0])
    box = np.array([40.0, 40.0, 40.0 if dimension == 3 else 0.0])  # 2-D states: box z 0
    st = State.create(x + shift, 0.5, alpha, box, axis=u, v=v, density=density,
                      periodic=(False, False, False), dimension=dimension)
    sim = Simulation(st, ContactModel("hooke", k_n), dt=dt)
    rows = []
    for step in range(0, steps + 1, 100):
        if step:
            sim.run(100)
        rows.append({"step": step, "ke": st.kinetic_energy(), "ya": st.x[0, 1] - 20.0,
                     "yb": st.x[1, 1] - 20.0})
    return {"dimension": dimension, **_summarise("pysim", name, alpha, pd.DataFrame(rows))}


def _summarise(engine, name, alpha, df) -> dict:
    ke0 = float(df.ke.iloc[0])
    finite = bool(np.all(np.isfinite(df[["ke", "ya", "yb"]].to_numpy())))
    ke1 = float(df.ke.iloc[-1]) if finite else float("nan")
    # rod a starts below rod b moving up; an elastic collision sends it down again. A
    # finite run in which it keeps moving up felt no contact: the rods passed through
    bounced = finite and bool(df.ya.iloc[-1] < df.ya.iloc[len(df) // 4])
    passed = finite and not bounced
    ratio = ke1 / ke0 if finite else float("nan")
    ok = finite and bounced and not passed and abs(ratio - 1.0) < 0.01
    return {"engine": engine, "geometry": name, "alpha": alpha, "ke_before": ke0,
            "ke_after": ke1, "ke_ratio": ratio, "ke_max": float(np.nanmax(df.ke)),
            "finite": finite, "bounced": bounced, "passed_through": passed,
            "verdict": "ok" if ok else "WRONG"}


#: the 2-D check also runs LAMMPS with this plain skin (no room for the rounded radii)
BARE_SKIN = 0.5


def check(alpha: float, work: Path, engines=("lammps-body", "pysim"),
          dimensions=(3, 2)) -> pd.DataFrame:
    """Every geometry on every engine, in 3-D (rounded/polyhedron) and 2-D
    (rounded/polygon): one row each (see :func:`_summarise`). In 2-D, LAMMPS runs twice:
    ``lammps-body`` with the skin the packing deck uses and ``lammps-body-bare-skin``
    with :data:`BARE_SKIN`, which shows the neighbour-cutoff pitfall."""
    rows = []
    for dim in dimensions:
        for name in GEOMETRIES if dim == 3 else GEOMETRIES_2D:
            if "lammps-body" in engines:
                rows.append(run_lammps(name, alpha, Path(work) / f"{dim}d", dimension=dim))
                if dim == 2:
                    rows.append(run_lammps(name, alpha, Path(work) / f"{dim}d", dimension=dim,
                                           skin=BARE_SKIN, label="lammps-body-bare-skin"))
            if "pysim" in engines:
                rows.append(run_pysim(name, alpha, dimension=dim))
    return pd.DataFrame(rows)
