"""Write the format-1 checkpoint fixtures of tests/pysim/test_checkpoint.py.

Format 1 kept the kernels' scalars in one float array of 23 slots (``sim_sys``); these
files were written by the code of that format (rodpack commit ff7286e), so that the test
resumes real old checkpoints. Run from a checkout of that commit, writing here::

    PYTHONPATH=<old checkout> python tests/pysim/data/make_format1_checkpoints.py tests/pysim/data

For each scene: ``<scene>.npz``, the checkpoint after the first steps, and
``<scene>_continued.npz``, the state the old code reached from there (what a resumed run
must reproduce bit for bit).
"""
import sys
from pathlib import Path

import numpy as np

from pysim import State, checkpoint
from pysim.initial import random_spheres, random_spherocylinders
from pysim.jit import set_threads
from pysim.simulation import ContactModel, Simulation
from pysim.walls import cylinder, plane

#: scene: (steps before the checkpoint, steps after it, keyword arguments of each run call)
SCENES = {
    "rods_tapped": (56000, 8000, {}),
    "spheres_compressed": (1500, 1500, {"strain_rate": -2.0}),
    "rods_2d_growing": (600, 600, {"strain_rate": -1.0, "growth_rate": 2.0}),
}
CONTINUED = ("x", "v", "q", "u", "omega", "radius", "length", "mass", "inertia", "box")
SIM_CONTINUED = ("f", "torque", "virial", "hist", "whist", "wall_force")


def scene(name: str, amp: float = 0.003) -> Simulation:
    """The scene's simulation at step 0 (the same in old and new code); ``amp``: the
    base's vibration amplitude in ``rods_tapped``."""
    rng = np.random.default_rng(3)
    if name == "rods_tapped":  # walls, wall springs, gravity, drag, rods with friction
        g = np.array([3.7, 6.3])
        x = np.array([[a, b, 1.8 + 2.6 * k] for k in range(10) for a in g for b in g])
        ang = rng.normal(size=(len(x), 3))
        ang /= np.linalg.norm(ang, axis=1, keepdims=True)
        v = np.zeros((len(x), 3))
        v[:, 2] = -6.0
        st = State.create(x, 0.5, 1.5, np.array([10.0, 10.0, 40.0]), axis=ang, v=v,
                          periodic=(False, False, False))
        model = ContactModel("hooke", 1e5, 40.0, k_t=3e4, gamma_t=5.0, mu=0.5, gamma_bg=0.05)
        return Simulation(st, model, dt=5e-5, gravity=(0, 0, -10),
                          planes=[plane((0, 0, 1), (0, 0, 0), amp=amp, omega_w=2 * np.pi * 30)],
                          cylinders=[cylinder(5.0, 5.0, 4.5)])
    if name == "spheres_compressed":  # periodic spheres, friction, drags set after the start
        x, d, box = random_spheres(rng.choice([0.8, 1.0], 200), 0.33, seed=5)
        st = State.spheres(x, d / 2, box, v=rng.normal(0, 1, (200, 3)))
        model = ContactModel("hertz", 1e5, 40.0, k_t=3e4, gamma_t=5.0, mu=0.4,
                             tangential_spring="keep")
        return Simulation(st, model, dt=5e-5)
    if name == "rods_2d_growing":  # 2-D rods with friction, box strain and growth
        x, u, r, length, box = random_spherocylinders(rng.choice([0.5, 0.7], 80),
                                                      rng.uniform(0, 2.0, 80), 0.4, 2,
                                                      dimension=2)
        box[2] = 1.0
        v = np.column_stack([rng.normal(0, 1.0, (80, 2)), np.zeros(80)])
        st = State.create(x, r, length, box, axis=u, v=v, dimension=2,
                          periodic=(True, True, False))
        model = ContactModel("hooke", 1e5, 30.0, k_t=3e4, gamma_t=5.0, mu=0.4, limit_damping=True)
        return Simulation(st, model, dt=5e-5)
    raise ValueError(f"unknown scene {name!r}; valid: {sorted(SCENES)}")


def first_steps(name: str, sim: Simulation) -> None:
    """The steps before the checkpoint."""
    before, _, kw = SCENES[name]
    sim.run(before // 2, **kw)
    if name == "spheres_compressed":
        sim.set_drag(0.3, 0.1)  # a checkpoint keeps the drags of the moment
    sim.run(before - before // 2, **kw)


def last_steps(name: str, sim: Simulation) -> None:
    """The steps after the checkpoint."""
    _, after, kw = SCENES[name]
    sim.run(after, **kw)


def main(out: Path) -> None:
    set_threads(1)
    for name in SCENES:
        sim = scene(name)
        first_steps(name, sim)
        checkpoint.save(sim, out / f"{name}.npz", extra={"scene": name})
        print(name, "at the checkpoint: pair contacts", sim.thermo().n_contacts,
              "wall contacts", sim._nw, "springs", int(np.count_nonzero(sim.hist.any(axis=1))),
              "wall springs", int(np.count_nonzero(sim.whist.any(axis=1))))
        last_steps(name, sim)
        arrays = {k: getattr(sim.state, k) for k in CONTINUED}
        arrays.update({k: getattr(sim, k) for k in SIM_CONTINUED})
        arrays["clock"] = np.array([sim.state.step, sim.state.time])
        np.savez(out / f"{name}_continued.npz", **arrays)
        print(name, "continued: pair contacts", sim.thermo().n_contacts, "wall contacts",
              sim._nw, "springs", int(np.count_nonzero(sim.hist.any(axis=1))))


if __name__ == "__main__":
    main(Path(sys.argv[1]))
