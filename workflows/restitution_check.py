"""Two-rod collisions with the tapping study's linear spring-dashpot law: the normal
restitution of pysim's exact spherocylinders against LAMMPS' rigid glued-sphere rods.

An exact spherocylinder touches another at one point, with one law. A glued rod touches
through every sphere pair that overlaps: side by side, ``n`` pairs act as ``n`` springs and
dashpots in parallel, ``n k_n`` and ``n gamma_n``, whose damping ratio is ``sqrt(n)`` times
the law's. With the tapping laws such a contact is overdamped and does not rebound. This
check collides two rods of the tapping case (no gravity, no walls), in

* ``parallel``  side by side, spines parallel (touching along the shaft)
* ``tip_tip``   coaxial, tip to tip
* ``tee``       the tip of rod b on the middle of rod a's side (T)
* ``crossed``   spines perpendicular, crossing at their middles

(the geometries of :func:`workflows.body_check.geometry`: centres along y, a gap of
0.2 D, approaching along y at relative speed ``v_rel``). Every geometry is a central
impact with normal y, so each should give the single-contact restitution of the law for
``m_eff = m/2``, unless several contacts act at once. It measures the restitution
``e = (v_b - v_a)_y after / v_rel`` of the centres of mass and the number of contacts
(sphere pairs for LAMMPS) at the deepest point of the collision.
"""
from __future__ import annotations

import math
import subprocess
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from workflows.body_check import geometry
from workflows.engines import EngineError, glued_spheres, venv_bin
from workflows.glued import write_glued_rods_data

GEOMETRIES = ("parallel", "tip_tip", "tee", "crossed")
LABELS = {"parallel": "side by side", "tip_tip": "tip to tip", "tee": "tip on side (T)",
          "crossed": "crossed"}
#: glued-sphere spacings (fractions of D) the check runs on LAMMPS
SPACINGS = (0.5, 0.25)
#: relative approach speed (m/s) of the two rods
V_REL = 0.1
#: |e - e_pysim| below which an engine agrees with pysim
AGREE = 0.1
#: the run lasts the approach over the gap plus this many contact times
CONTACT_TIMES = 5
DECK = Path(__file__).resolve().parents[1] / "inputs" / "lammps" / "in.rods.collide"


@dataclass(frozen=True)
class Law:
    """Rods and contact law of the check, SI: ``alpha = L/D``, ``diameter`` D (m),
    ``density`` (kg/m^3), normal ``k_n`` (N/m) and ``gamma_n`` (N s/m), tangential
    ``k_t``, ``gamma_t``, friction ``mu``, time step ``dt`` (s); ``limit_damping``: the
    normal force is clipped at zero (the case's ``contact.limit_damping``)."""

    alpha: float
    diameter: float
    density: float
    k_n: float
    gamma_n: float
    k_t: float
    gamma_t: float
    mu: float
    dt: float
    limit_damping: bool = False

    @property
    def mass(self) -> float:
        """Rod mass ``m = rho (pi D^2 L / 4 + pi D^3 / 6)`` (kg)."""
        d = self.diameter
        return self.density * (math.pi * d * d * self.alpha * d / 4 + math.pi * d**3 / 6)


def law_from_case(case: dict) -> Law:
    """The law of a validated tapping case (:func:`rodcase.case.validate_case` derives
    ``k_n``, ``gamma_n`` from ``restitution`` and ``contact_time`` with
    :func:`rodcase.case.restitution_law`, and ``k_t``, ``gamma_t`` from them)."""
    p, c = case["particles"], case["contact"]
    if c["law"] != "hooke":
        raise ValueError(f"the restitution check needs the linear law (contact.law hooke), "
                         f"got {c['law']!r}")
    if p.get("dimension", 3) != 3 or not p["aspect_ratio"] > 0:
        raise ValueError(f"the restitution check needs 3-D rods, got dimension "
                         f"{p.get('dimension', 3)}, aspect_ratio {p['aspect_ratio']}")
    return Law(alpha=p["aspect_ratio"], diameter=p["diameter"]["mean"], density=p["density"],
               k_n=c["k_n"], gamma_n=c.get("gamma_n", 0.0), k_t=c.get("k_t", 0.0),
               gamma_t=c.get("gamma_t", 0.0), mu=c.get("friction", 0.0),
               dt=case["protocol"]["dt"], limit_damping=bool(c.get("limit_damping", False)))


def linear_restitution(k_n: float, gamma_n: float, m_eff: float,
                       clipped: bool = False) -> float:
    """Restitution of the linear spring-dashpot (science.md section 3):
    ``e = exp(-pi zeta / sqrt(1 - zeta^2))``, ``zeta = gamma_n / (2 sqrt(m_eff k_n))``;
    0 when overdamped (``zeta >= 1``: no rebound). SI or any consistent units.

    ``clipped``: the normal force ``max(0, k_n delta + gamma_n d(delta)/dt)`` (LAMMPS'
    ``limit_damping``). The grains part when the force reaches zero, at the phase
    ``pi - 2 asin(zeta)`` of the damped oscillation, where the overlap's rate is
    ``-v0 exp(-zeta theta / sqrt(1 - zeta^2))``: ``e = exp(-2 zeta acos(zeta) /
    sqrt(1 - zeta^2))`` for ``zeta < 1``, ``exp(-2)`` at 1 and ``exp(-2 zeta
    acosh(zeta) / sqrt(zeta^2 - 1))`` above (the same expression continued)."""
    if not k_n > 0 or not m_eff > 0 or gamma_n < 0:
        raise ValueError(f"need k_n > 0, m_eff > 0, gamma_n >= 0; got k_n = {k_n}, "
                         f"m_eff = {m_eff}, gamma_n = {gamma_n}")
    zeta = gamma_n / (2.0 * math.sqrt(m_eff * k_n))
    if not clipped:
        return 0.0 if zeta >= 1.0 else math.exp(-math.pi * zeta / math.sqrt(1.0 - zeta**2))
    if zeta < 1.0:
        return math.exp(-2.0 * zeta * math.acos(zeta) / math.sqrt(1.0 - zeta**2))
    if zeta == 1.0:
        return math.exp(-2.0)
    return math.exp(-2.0 * zeta * math.acosh(zeta) / math.sqrt(zeta**2 - 1.0))


def expected_restitution(law: Law, contacts: int = 1) -> float:
    """Restitution of a head-on rod-rod impact (``m_eff = m/2``) through ``contacts``
    equal contacts in parallel: :func:`linear_restitution` of ``contacts k_n`` and
    ``contacts gamma_n`` (the damping ratio grows as ``sqrt(contacts)``)."""
    if contacts < 1:
        raise ValueError(f"contacts must be >= 1, got {contacts}")
    return linear_restitution(contacts * law.k_n, contacts * law.gamma_n, 0.5 * law.mass,
                              clipped=law.limit_damping)


def _steps(law: Law, v_rel: float) -> int:
    """Steps for the approach over the 0.2 D gap plus :data:`CONTACT_TIMES` contact times."""
    from rodcase.case import contact_time

    t = 0.2 * law.diameter / v_rel + CONTACT_TIMES * contact_time(law.k_n, law.gamma_n,
                                                                  0.5 * law.mass)
    return int(math.ceil(t / law.dt))


def _summarise(engine: str, name: str, spacing: float, dy, dvy, contacts, v_rel) -> dict:
    """Restitution from the last relative velocity; contacts at the smallest separation."""
    dvy = np.asarray(dvy, dtype=float)
    deepest = int(np.argmin(dy))
    return {"geometry": name, "engine": engine, "spacing": spacing,
            "e": float(dvy[-1] / v_rel), "contacts": int(np.asarray(contacts)[deepest])}


def run_pysim(name: str, law: Law, v_rel: float = V_REL) -> dict:
    """Collide two exact spherocylinders (pysim) in geometry ``name``; returns ``geometry,
    engine, spacing (nan), e, contacts``."""
    from pysim.simulation import ContactModel, Simulation
    from pysim.state import State

    d = law.diameter
    x, u = geometry(name, law.alpha, d)
    box = np.full(3, 8.0 * (law.alpha + 1.0) * d)
    v = np.array([[0.0, 0.5 * v_rel, 0.0], [0.0, -0.5 * v_rel, 0.0]])
    st = State.create(x + box / 2, d / 2, law.alpha * d, box, axis=u, v=v,
                      density=law.density, periodic=(False, False, False))
    model = ContactModel("hooke", law.k_n, law.gamma_n, k_t=law.k_t, gamma_t=law.gamma_t,
                         mu=law.mu, limit_damping=law.limit_damping)
    sim = Simulation(st, model, dt=law.dt)
    dy, dvy, nc = [], [], []
    for _ in range(_steps(law, v_rel)):
        sim.run(1)
        dy.append(st.x[1, 1] - st.x[0, 1])
        dvy.append(st.v[1, 1] - st.v[0, 1])
        nc.append(sim.thermo().n_contacts)
    return _summarise("pysim", name, float("nan"), dy, dvy, nc, v_rel)


def run_lammps(name: str, law: Law, spacing: float, work: Path, v_rel: float = V_REL) -> dict:
    """Collide two rigid glued-sphere rods (LAMMPS, ``inputs/lammps/in.rods.collide``) of
    spheres at centre spacing at most ``spacing`` D; returns ``geometry, engine (lammps),
    spacing, e, contacts`` (sphere pairs)."""
    if not 0 < spacing <= 1:
        raise ValueError(f"spacing must be in (0, 1] (a fraction of D), got {spacing}")
    d = law.diameter
    work = Path(work) / f"lammps_s{spacing:g}"
    work.mkdir(parents=True, exist_ok=True)
    x, u = geometry(name, law.alpha, d)
    n = glued_spheres(law.alpha * d, d, spacing)
    half = 2.0 * (law.alpha + 1.0) * d
    write_glued_rods_data(work / f"{name}.data", x, u, d / 2, law.alpha * d, np.full(3, 2 * half),
                          n_spheres=n, density=law.density, box_lo=(-half, -half, -half))
    table = work / f"{name}.dat"
    log = work / f"log.{name}"
    vars_ = {"data": work / f"{name}.data", "table": table, "k_n": law.k_n,
             "gamma_n": law.gamma_n, "k_t": law.k_t,
             "x_gamma_t": law.gamma_t / law.gamma_n if law.gamma_n > 0 else 0.0,
             "mu": law.mu, "v_rel": v_rel, "dt": law.dt, "steps": _steps(law, v_rel),
             "skin": 0.2 * d, "ghost_cut": (law.alpha + 1.4) * d,
             "limit_damping": int(law.limit_damping)}
    cmd = [venv_bin("lmp"), "-in", str(DECK), "-log", str(log), "-screen", "none"]
    for key, val in vars_.items():
        cmd += ["-var", key, repr(val) if isinstance(val, float) else str(val)]
    proc = subprocess.run(cmd, capture_output=True, text=True, timeout=600)
    text = proc.stdout + proc.stderr + (log.read_text() if log.exists() else "")
    err = next((ln for ln in text.splitlines() if ln.startswith("ERROR")), None)
    if proc.returncode != 0 or err:
        raise EngineError(f"LAMMPS restitution check '{name}' at spacing {spacing:g} D failed: "
                          f"{err or f'exit status {proc.returncode}'}; log: {log}")
    df = pd.read_csv(table, sep=r"\s+", comment="#", header=None,
                     names=["step", "time", "dy", "dvy", "contacts"])
    return _summarise("lammps", name, spacing, df.dy, df.dvy, df.contacts, v_rel)


def check(law: Law, work: Path, geometries=GEOMETRIES, spacings=SPACINGS,
          lammps: bool = True, v_rel: float = V_REL) -> pd.DataFrame:
    """Every geometry on pysim and (``lammps``) on LAMMPS at every spacing: rows of
    ``geometry, engine, spacing, e, expected_e`` (single contact), ``contacts``,
    ``expected_e_contacts`` (that many contacts in parallel) and ``verdict`` ("agree"
    when ``|e - e_pysim|`` < :data:`AGREE`, else "DIFFER")."""
    bad = [g for g in geometries if g not in GEOMETRIES]
    if bad:
        raise ValueError(f"unknown geometry {bad[0]!r}; valid: {', '.join(GEOMETRIES)}")
    rows = []
    for name in geometries:
        rows.append(run_pysim(name, law, v_rel))
        if lammps:
            rows += [run_lammps(name, law, s, work, v_rel) for s in spacings]
    df = pd.DataFrame(rows)
    df["expected_e"] = expected_restitution(law)
    df["expected_e_contacts"] = [expected_restitution(law, max(int(c), 1)) for c in df.contacts]
    ref = df[df.engine == "pysim"].set_index("geometry").e
    df["verdict"] = np.where((df.e - df.geometry.map(ref)).abs() < AGREE, "agree", "DIFFER")
    return df[["geometry", "engine", "spacing", "e", "expected_e", "contacts",
               "expected_e_contacts", "verdict"]]
