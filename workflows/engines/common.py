"""What every peer engine (LAMMPS, LIGGGHTS) shares: where the decks live, the error
type, a case's shape, glued-sphere rods, the compression's contact and stage variables,
and the limits every peer deck has (pysim's-only options)."""
from __future__ import annotations

import os
import shutil
import sys
from pathlib import Path

import numpy as np

PROJECT_ROOT = Path(__file__).resolve().parents[2]
#: where the decks live; RODPACK_INPUTS points elsewhere (tests use it to break a deck)
INPUTS = Path(os.environ.get("RODPACK_INPUTS", PROJECT_ROOT / "inputs"))
#: the shapes of the adapter table and of the capability matrix: 3-D spheres, 3-D rods
#: (spherocylinders), 2-D disks, 2-D rods (stadia)
SHAPES = ("spheres", "rods", "disks 2-D", "rods 2-D")


class EngineError(RuntimeError):
    """An engine run failed; the message names the engine's error line and log file."""


def shape(case: dict) -> str:
    """The case's shape (:data:`SHAPES`): spheres, rods, disks 2-D or rods 2-D."""
    rod = case["particles"].get("aspect_ratio", 0.0) > 0
    if case["particles"].get("dimension", 3) == 2:
        return "rods 2-D" if rod else "disks 2-D"
    return "rods" if rod else "spheres"


def as_vars(values: dict) -> dict[str, str]:
    """``-var`` strings of deck values: floats by ``repr`` (every digit), the rest by
    ``str``."""
    return {k: repr(float(x)) if isinstance(x, float) else str(x) for k, x in values.items()}


def glued_spheres(length: float, diameter: float, spacing: float) -> int:
    """Number of equal spheres that glue into a rod: end spheres at the spine ends, centre
    spacing at most ``spacing * D``."""
    if length <= 0:
        return 1
    return int(np.ceil(length / (spacing * diameter) - 1e-9)) + 1


def _rod_vars(case: dict) -> dict:
    """Spheres per glued rod and the ghost cutoff ``fix rigid/small`` needs (a body
    reaches as far as its length from its owner atom)."""
    from rodcase.case import size_extremes

    p = case["particles"]
    d = p["diameter"]["mean"]
    dmax = size_extremes(p["diameter"])[2]
    return {"spheres": glued_spheres(p["aspect_ratio"] * d, d, p.get("glued_spacing", 0.25)),
            "ghost_cut": (p["aspect_ratio"] + 1.0) * dmax + 0.2 * dmax}


def _insertion_seed(seed: int) -> int:
    """A prime above 10000 for LIGGGHTS' insertion (its seeds must be primes > 10000),
    one per case seed."""
    k = 10007 + 1000 * int(seed)
    while any(k % f == 0 for f in range(2, int(k**0.5) + 1)):
        k += 1
    return k


def compress_vars(case: dict) -> dict:
    """The compression decks' contact law, drag, time step, output cadence and stages
    (``phi_init`` -> ``phi_fast`` at ``rate_fast``, then -> ``phi_final`` at ``rate``;
    no fast stage: a zero-length one; ``p_final`` when the case stops at a pressure),
    unformatted: each engine adds its own (:func:`as_vars` formats them)."""
    c, pr = case["contact"], case["protocol"]
    out = case.get("output", {})
    v = {
        "k_n": c["k_n"], "gamma_n": c.get("gamma_n", 0.0), "mu": c.get("friction", 0.0),
        "k_t": c.get("k_t", 0.0), "gamma_bg": c.get("gamma_bg", 0.0), "dt": pr["dt"],
        "phi_init": pr["phi_init"], "rate": pr["rate"], "phi_final": pr["phi_final"],
        "thermo_every": out.get("thermo_every", 1000), "dump_every": out.get("dump_every", 4000),
    }
    if "phi_fast" in pr:
        v["phi_fast"], v["rate_fast"] = pr["phi_fast"], pr["rate_fast"]
    else:  # no fast stage: a zero-length one
        v["phi_fast"], v["rate_fast"] = pr["phi_init"], 1.0
    if "pressure_final" in pr:
        v["p_final"] = pr["pressure_final"]
    return v


# -- limits every peer deck has -------------------------------------------------------------
def closest_contacts_only(engine: str, case: dict) -> str | None:
    """The peers' rods touch at their closest points only (no end-bond contacts)."""
    if case["contact"].get("spine_contact", "closest") != "closest":
        return (f"{engine} has no end-bond rod contacts (contact.spine_contact = "
                f"{case['contact']['spine_contact']} is pysim's)")
    return None


def smooth_wall_cohesion(engine: str, case: dict) -> str | None:
    """The peers' walls do not attract the grains."""
    if case["contact"].get("wall_cohesion", False):
        return (f"{engine}'s walls have no cohesion; contact.wall_cohesion (walls that "
                "attract the grains) is pysim's only")
    return None


def reset_tangential_spring(engine: str, case: dict) -> str | None:
    """The peers cut the tangential spring back to the Coulomb limit when it slides."""
    if case["contact"].get("tangential_spring", "reset") != "reset":
        return (f"{engine}'s tangential history is cut back to the Coulomb limit when a contact "
                "slides; contact.tangential_spring = keep (the spring grows on) is pysim's only")
    return None


def capped_preparation(engine: str, case: dict) -> str | None:
    """The peers' tapping decks settle under the capping drag for a fixed time."""
    if case["protocol"].get("preparation", {}).get("mode", "capped") != "capped":
        return (f"the {engine} tapping deck settles under the capping drag for settle_time; "
                "protocol.preparation.mode = free (settle until the kinetic energy is gone) "
                "is pysim's only")
    return None


def verlet_steps(engine: str, case: dict) -> str | None:
    """The peers' inertial decks step with velocity Verlet (their own integrators)."""
    scheme = case["protocol"].get("integrator", "verlet")
    if scheme in ("euler", "semi_implicit_euler"):
        return (f"{engine} steps with velocity Verlet; protocol.integrator = {scheme} is "
                "pysim's only")
    return None


#: what every peer engine refuses, checked in this order before its deck is looked up
PEER_LIMITS = (closest_contacts_only, smooth_wall_cohesion, reset_tangential_spring,
               capped_preparation, verlet_steps)


def inertial_only(engine: str, case: dict) -> str | None:
    """The 3-D compression decks integrate Newton's equations (no overdamped integrator)."""
    if case["protocol"].get("integrator", "verlet") != "verlet":
        return f"{engine} integrates inertial dynamics only (no overdamped integrator)"
    return None


def venv_bin(name: str) -> str:
    """An executable of the Python environment running this code (``lmp``, ``mpiexec``)."""
    path = Path(sys.executable).parent / name
    if path.exists():
        return str(path)
    found = shutil.which(name)
    if found is None:
        raise EngineError(f"'{name}' not found next to {sys.executable} nor on PATH; "
                          "run 'make setup'")
    return found
