"""Tapping (science.md section 4): the restitution/contact-time law, the step plan shared
with the LAMMPS deck, and a small run end to end through the CLI."""
import math

import numpy as np
import pytest

from analysis.io import RunData
from analysis.summary import analyse_tapping
from pysim.protocols.tapping import plan, settle_drag
from pysim.simulation import ContactModel
from tests.pysim.test_physics import collide, two_spheres
from tests.pysim.test_protocols import run_case
from workflows.case import restitution_law, validate_case

D = 0.523e-3
TAP = {
    "particles": {"n": 30, "aspect_ratio": 2.0, "diameter": {"distribution": "mono", "mean": D},
                  "density": 2500.0, "glued_spacing": 0.5},
    "contact": {"law": "hooke", "restitution": 0.4, "contact_time": 6e-4, "friction": 0.5},
    "container": {"shape": "cylinder", "diameter": 8 * D},
    "gravity": 9.81,
    "protocol": {"name": "tapping", "dt": 2e-5, "phi_init": 0.15, "settle_time": 0.1,
                 "relax_time": 0.05, "frequency": 30.0, "intensity": 2.0, "taps": 2,
                 "frames_per_tap": 4},
    "output": {"thermo_every": 250},
    "seed": 3,
}


@pytest.mark.parametrize("e_n", [0.1, 0.4, 0.9])
def test_restitution_law_gives_the_restitution_and_contact_time(e_n):
    """Two equal spheres (m_eff = m/2) with k_n, gamma_n from (e_n, t_c) bounce apart with
    relative speed e_n times the approach speed after a contact of duration t_c."""
    m_eff = math.pi / 12  # D = 1, rho = 1
    t_c = 1e-2
    k, gamma = restitution_law(e_n, t_c, m_eff)
    sim = two_spheres(0.5, ContactModel("hooke", k, gamma), dt=t_c / 2000)
    tc, v_after = collide(sim, 10000)
    assert v_after / 1.0 == pytest.approx(e_n, rel=0.01)
    assert tc == pytest.approx(t_c, rel=0.01)


def test_case_derives_the_contact_law_from_restitution():
    case = validate_case(TAP)
    c = case["contact"]
    rod = math.pi * D**2 * 2 * D / 4 + math.pi * D**3 / 6
    k, gamma = restitution_law(0.4, 6e-4, 0.5 * 2500.0 * rod)
    assert (c["k_n"], c["gamma_n"]) == pytest.approx((k, gamma))
    assert c["k_t"] == pytest.approx(2 / 7 * k) and c["gamma_t"] == pytest.approx(gamma / 2)


def test_plan_puts_frames_at_fixed_phases_of_each_tap():
    pr = validate_case(TAP)["protocol"]
    tp = plan(pr, 9.81)
    dt, fpt = pr["dt"], pr["frames_per_tap"]
    assert tp.settle_steps == 5000 and tp.start == 7500
    assert tp.amplitude == pytest.approx(2.0 * 9.81 / (2 * math.pi * 30.0) ** 2)
    assert len(tp.frame_steps) == pr["taps"] * fpt + 1
    assert tp.frame_steps[0] == tp.start and tp.end == tp.frame_steps[-1]
    # frame k sits at phase 2 pi k / f, to within half a step
    k = np.arange(len(tp.frame_steps))
    phase = (tp.frame_steps - tp.start) * dt / tp.period * fpt
    np.testing.assert_allclose(phase, k, atol=0.5 * dt / tp.period * fpt + 1e-12)
    # base at rest before tapping, at +a a quarter period in, back at 0 after whole taps
    z = tp.base_height(tp.frame_steps)
    assert tp.base_height(tp.start - 1) == 0.0
    np.testing.assert_allclose(z[1::fpt], tp.amplitude, rtol=1e-3)
    np.testing.assert_allclose(z[3::fpt], -tp.amplitude, rtol=1e-3)
    np.testing.assert_allclose(z[fpt::fpt], 0.0, atol=2e-3 * tp.amplitude)
    np.testing.assert_allclose(tp.tap_of(tp.frame_steps[::fpt]), np.arange(pr["taps"] + 1),
                               atol=dt / tp.period)


def test_settling_drag_gives_the_terminal_speed():
    case = validate_case(TAP)
    gamma, gamma_rot = settle_drag(case)
    m = 2500.0 * (math.pi * D**2 * 2 * D / 4 + math.pi * D**3 / 6)
    assert m * 9.81 / gamma == pytest.approx(case["protocol"]["settle_speed"])
    assert gamma_rot == pytest.approx(gamma * (2 * D) ** 2 / 12)


@pytest.fixture(scope="module")
def tapped(tmp_path_factory):
    d = tmp_path_factory.mktemp("tap")
    return validate_case(TAP), run_case(d, TAP)


def test_tapping_run_keeps_grains_in_the_container(tapped):
    case, out = tapped
    tp = plan(case["protocol"], case["gravity"])
    run = RunData(out)
    frames = run.frames()
    assert [f.step for f, _ in frames] == list(tp.frame_steps)
    rc = 0.5 * case["container"]["diameter"]
    for f, contacts in frames:
        assert f.n == case["particles"]["n"]
        ends = np.concatenate([f.x + 0.5 * f.length[:, None] * f.axis,
                               f.x - 0.5 * f.length[:, None] * f.axis])
        r = np.tile(f.radius, 2)
        # every spine end inside the cylinder and above the base, up to a small overlap
        assert np.all(np.hypot(ends[:, 0], ends[:, 1]) + r < rc + 0.05 * D)
        assert np.all(ends[:, 2] - r > tp.base_height(f.step) - 0.05 * D)
        assert np.all(contacts.overlap < 0.05 * D)
    th = run.thermo
    assert th.phi.isna().all() and np.isfinite(th.ke).all()
    settled = th[(th.step > tp.settle_steps) & (th.step <= tp.start)]
    m = 2500.0 * (math.pi * D**2 * 2 * D / 4 + math.pi * D**3 / 6)
    # at rest after relaxing: mean speed far below the base's peak speed a omega
    v_mean = np.sqrt(2 * settled.ke.iloc[-1] / (case["particles"]["n"] * m))
    assert v_mean < 0.05 * tp.amplitude * tp.omega
    # the taps shake the packing: kinetic energy while tapping well above the settled one
    assert th[th.step > tp.start].ke.max() > 100 * settled.ke.iloc[-1]


def test_tapping_analysis_of_a_run(tapped):
    case, out = tapped
    tp = plan(case["protocol"], case["gravity"])
    rows, curves, _ = analyse_tapping(out, start_step=tp.start, dt=tp.dt, period=tp.period,
                                  amplitude=tp.amplitude, frames_per_tap=tp.frames_per_tap,
                                  container_diameter=case["container"]["diameter"],
                                  layer_thickness=5 * D)
    v = {name: value for name, value, _ in rows}
    assert v["taps"] == pytest.approx(2.0, abs=tp.dt / tp.period)  # frames on whole steps
    # a loose random packing of alpha = 2 rods against the walls of a narrow cylinder
    assert 0.25 < v["phi_settled"] < 0.6 and 0.25 < v["phi_tapped"] < 0.6
    # settled rods lie flat-ish; angles are in [0, 90] and isotropic would be 32.7 deg
    assert 0 < v["angle_settled"] < 45 and 0 < v["angle_tapped"] < 90
    assert len(curves) == len(tp.frame_steps)
    np.testing.assert_allclose(curves.tap, tp.tap_of(tp.frame_steps))
