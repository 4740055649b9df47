"""Stress from contacts, checked against pysim's own virial."""
import numpy as np
import pytest

from analysis.frame import Contacts, Frame
from analysis.stress import particle_stress, pressure, stress_tensor
from pysim import State
from pysim.initial import random_spheres
from pysim.simulation import ContactModel, Simulation


def test_two_spheres_pressed_together():
    """Two spheres along x pushed by a force f: sigma_xx = -2 R' f / V on the pair."""
    x = np.array([[1.0, 1.0, 1.0], [1.9, 1.0, 1.0]])
    fr = Frame(0, np.array([1, 2]), np.ones(2, np.int64), x, np.full(2, 0.5),
               np.tile([0, 0, 1.0], (2, 1)), np.zeros(2), np.zeros(3), np.full(3, 4.0),
               np.ones(3, bool))
    f = 3.0
    c = Contacts(0, np.array([1]), np.array([2]), np.array([[1.45, 1.0, 1.0]]),
                 np.array([[1.0, 0, 0]]), np.array([0.1]), np.array([[-f, 0, 0]]))
    s = stress_tensor(fr, c)
    assert s[0, 0] == pytest.approx(-0.9 * f / 64.0)
    assert np.count_nonzero(np.abs(s) > 1e-15) == 1
    assert pressure(fr, c) == pytest.approx(0.9 * f / 64.0 / 3)
    ps = particle_stress(fr, c)
    assert ps[0, 0, 0] == pytest.approx(-0.45 * f) and ps[1, 0, 0] == pytest.approx(-0.45 * f)


def test_stress_from_contact_table_equals_engine_virial():
    x, d, box = random_spheres(np.ones(300), 0.3, seed=2)
    st = State.spheres(x, d / 2, box)
    sim = Simulation(st, ContactModel("hooke", 1e5, 50.0, gamma_bg=1.0), dt=1e-4)
    sim.run(30_000, strain_rate=-0.1)
    ij, rec = sim.contact_table()
    ids = np.arange(1, st.n + 1)
    fr = Frame(st.step, ids, np.ones(st.n, np.int64), st.x.copy(), st.radius.copy(),
               np.tile([0, 0, 1.0], (st.n, 1)), np.zeros(st.n), np.zeros(3), st.box.copy(),
               np.ones(3, bool))
    c = Contacts(st.step, ids[ij[:, 0]], ids[ij[:, 1]], rec[:, 0:3], rec[:, 3:6], rec[:, 6],
                 rec[:, 7:10])
    assert c.n > 100
    sim.compute_forces()  # virial of the current state (velocities at the end of the step)
    np.testing.assert_allclose(stress_tensor(fr, c), sim.stress(), rtol=1e-9, atol=1e-12)
