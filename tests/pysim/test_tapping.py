"""Tapping (science.md section 4): the restitution/contact-time law, the step plan shared
with the LAMMPS deck, and a small run end to end through the CLI."""
import math

import numpy as np
import pytest

from analysis.io import RunData
from analysis.summary import analyse_tapping, late_window
from pysim.protocols.tapping import plan, settle_drag
from pysim.simulation import ContactModel
from tests.cases import TAP, TAP_D as D
from tests.pysim.helpers import collide, two_spheres
from tests.runs import assert_in_the_tapped_container, run_case
from rodcase.case import restitution_law, validate_case


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
    assert_in_the_tapped_container(frames, case, tp, D)
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
    # Pournin et al.'s density beside ours: a settled bed has no outliers
    assert curves.outliers.iloc[0] == 0
    assert 0.25 < v["phi_settled_enclosing"] < 0.6 and 0.25 < v["phi_late_enclosing"] < 0.6
    assert v["phi_settled_enclosing"] == pytest.approx(curves.phi_enclosing.iloc[0])
    assert v["outliers_late"] >= 0
    late = late_window(curves)
    assert v["height_late_enclosing"] == pytest.approx(late.height_enclosing.mean())
    # the layers' densities: the late means of the per-frame slab densities
    for k in (1, 2):
        assert v[f"phi_late_layer{k}"] == pytest.approx(late[f"phi_layer{k}"].mean())
    assert 0.1 < v["phi_late_layer1"] < 0.75  # a few alpha = 2 rods in a narrow layer


FREE = {"mode": "free", "ke_stop": 1e-8, "check_time": 0.005, "max_time": 1.0}


def free_case(**prep):
    from rodcase.case import deep_merge

    return validate_case(deep_merge(TAP, {"protocol": {"preparation": {**FREE, **prep}}}))


def test_plan_of_a_free_preparation_starts_where_the_bed_settled():
    case = free_case()
    with pytest.raises(ValueError, match="pass settled"):
        plan(case["protocol"], 9.81)
    tp = plan(case["protocol"], 9.81, settled=6250)
    assert tp.settle_steps == tp.start == tp.frame_steps[0] == 6250
    ref = plan(validate_case(TAP)["protocol"], 9.81)
    np.testing.assert_array_equal(tp.frame_steps - tp.start, ref.frame_steps - ref.start)
    assert settle_drag(case) == (0.0, 0.0)


def _run(case, out, resume=False, **kw):
    from pysim import io
    from pysim.initial import write_initial
    from pysim.protocols import tapping

    data = out.parent / "init.data"
    if not data.exists():
        write_initial(case, data)
    return tapping.run(case, io.read_particle_data(data), out, progress=False, resume=resume,
                       **kw)


@pytest.fixture(scope="module")
def free_run(tmp_path_factory):
    d = tmp_path_factory.mktemp("free")
    case = free_case()
    _run(case, d / "ref")
    return case, d


def test_free_preparation_taps_once_the_kinetic_energy_is_gone(free_run):
    """No drag; tapping starts at the first test (every check_time) that finds the kinetic
    energy per grain below ke_stop m g D after one that found it above; frame 0 is that
    packing and the taps follow as planned from there; the analysis finds the start from
    the first frame."""
    from pysim.protocols.tapping import ke_unit

    case, d = free_run
    out = d / "ref"
    run = RunData(out)
    steps = [f.step for f, _ in run.frames()]
    tp = plan(case["protocol"], case["gravity"], settled=steps[0])
    assert steps == list(tp.frame_steps)
    th = run.thermo.set_index("step")  # a row every 250 steps = check_time / dt
    e = th.ke / (ke_unit(case) * case["particles"]["n"])
    assert steps[0] % 250 == 0 and e[steps[0]] < 1e-8 <= e[steps[0] - 250]
    assert (e[e.index < steps[0] - 250] >= 1e-8).all()  # the first test below, after the fall
    assert 0.05 < steps[0] * tp.dt < 0.5
    assert e[e.index > steps[0]].max() > 1e6 * e[steps[0]]  # then the taps shake it
    rows, curves, _ = analyse_tapping(out, start_step=None, dt=tp.dt, period=tp.period,
                                      amplitude=tp.amplitude, frames_per_tap=tp.frames_per_tap,
                                      container_diameter=case["container"]["diameter"],
                                      layer_thickness=5 * D)
    np.testing.assert_allclose(curves.tap, tp.tap_of(tp.frame_steps))
    v = {name: value for name, value, _ in rows}
    assert v["taps"] == pytest.approx(2.0, abs=tp.dt / tp.period)
    assert 0.25 < v["phi_settled"] < 0.6


def test_free_preparation_that_does_not_settle_stops_and_resumes(free_run):
    """A max_time before the bed settles stops the run with a one-line SettleError and a
    checkpoint; resumed with a later max_time it writes the files of the run that was
    never stopped, byte for byte."""
    from pysim.protocols.tapping import SettleError

    case, d = free_run
    out = d / "short"
    with pytest.raises(SettleError, match=r"still above protocol\.preparation\.ke_stop = 1e-08 "
                                          r"at max_time = 0\.05; raise max_time") as exc:
        _run(free_case(max_time=0.05), out)
    assert "\n" not in str(exc.value) and (out / "checkpoint.npz").exists()
    _run(case, out, resume=True)
    for name in ("particles.dump", "contacts.dump", "thermo.dat"):
        assert (out / name).read_bytes() == (d / "ref" / name).read_bytes(), name


def test_free_preparation_resumes_mid_tapping(free_run, monkeypatch):
    """Killed after the bed settled (the checkpoint holds the settled step), the resumed
    run writes the uninterrupted run's files."""
    from pysim.protocols.output import RunFiles

    case, d = free_run
    out = d / "killed"
    dump = RunFiles.dump
    calls = []

    def dies_at_the_fifth_frame(self, sim):
        calls.append(sim.state.step)
        if len(calls) == 5:
            raise KeyboardInterrupt
        dump(self, sim)

    monkeypatch.setattr(RunFiles, "dump", dies_at_the_fifth_frame)
    with pytest.raises(KeyboardInterrupt):
        _run(case, out, checkpoint_every=0.0)
    monkeypatch.setattr(RunFiles, "dump", dump)
    _run(case, out, resume=True)
    for name in ("particles.dump", "contacts.dump", "thermo.dat"):
        assert (out / name).read_bytes() == (d / "ref" / name).read_bytes(), name


def test_kept_tangential_spring_reaches_the_tapping_kernels(tmp_path):
    """contact.tangential_spring: keep changes a tapping run (grains and walls), reset is
    the default's run bit for bit; friction 0 runs too, with no tangential force."""
    from pysim.protocols.tapping import simulation_from_case
    from rodcase.case import deep_merge

    from pysim import io
    from pysim.initial import write_initial
    from pysim.forces import KEEP_SPRING

    base = validate_case(TAP)
    write_initial(base, tmp_path / "init.data")
    init = io.read_particle_data(tmp_path / "init.data")
    keep = validate_case(deep_merge(TAP, {"contact": {"tangential_spring": "keep"}}))
    reset = validate_case(deep_merge(TAP, {"contact": {"tangential_spring": "reset"}}))
    smooth = validate_case(deep_merge(TAP, {"contact": {"friction": 0.0}}))
    sims = {k: simulation_from_case(c, init) for k, c in
            (("base", base), ("keep", keep), ("reset", reset), ("smooth", smooth))}
    assert sims["keep"].model.law_id & KEEP_SPRING and not sims["base"].model.law_id & KEEP_SPRING
    assert not sims["smooth"].model.friction and sims["smooth"].whist.shape == (0, 3)
    for sim in sims.values():
        sim.run(6000)  # the column lands: sliding contacts, on the base and the wall too
    s = {k: sim.state for k, sim in sims.items()}
    np.testing.assert_array_equal(s["reset"].x, s["base"].x)
    assert np.abs(s["keep"].x - s["base"].x).max() > 1e-3 * D
    assert np.abs(sims["keep"].whist).max() > np.abs(sims["base"].whist).max()
    iw, rec = sims["smooth"].wall_contact_table()
    assert len(iw) > 0
    normal = np.einsum("ij,ij->i", rec[:, 7:10], rec[:, 3:6])[:, None] * rec[:, 3:6]
    np.testing.assert_allclose(rec[:, 7:10], normal, atol=1e-12 * np.abs(rec[:, 7:10]).max())
