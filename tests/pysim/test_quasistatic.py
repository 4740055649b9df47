"""The quasistatic compression (``protocol: quasistatic``): affine steps, each relaxed."""
import numpy as np
import pandas as pd
import pytest

from analysis.io import RunData
from analysis.jamming import JammingPoint
from rodcase.case import ConfigError, validate_case
from tests.runs import analyse, run_case

DISKS = {
    "particles": {"n": 64, "dimension": 2,
                  "diameter": {"distribution": "bidisperse", "mean": 1.0, "ratio": 1.4}},
    "contact": {"law": "harmonic", "k_n": 1.0},
    "protocol": {"name": "quasistatic", "phi_init": 0.4, "dphi": 1e-3, "dphi_coarse": 0.02,
                 "dt": 0.01},
    "seed": 5,
}


pytestmark = pytest.mark.slow


@pytest.fixture(scope="module")
def disks(tmp_path_factory):
    return run_case(tmp_path_factory.mktemp("qs"), DISKS)


def test_steps_zero_below_jamming_and_linear_above(disks):
    """Coarse steps of 0.02 relax to zero energy until one jams; that one is undone and
    the fine steps of 1e-3 go on from the last unjammed packing. Below jamming every
    relaxed packing is free of stress; above it the pressure of harmonic disks rises
    linearly (its slope between rows within a factor 2 of the mean), and the fit of the
    first rise puts phi_J within a fine step of where the stress appears (64 disks bend a
    little above it: the finite-size tail Marschall and Teitel also see)."""
    th = RunData(disks).thermo
    phi, p, pe = th.phi.to_numpy(), th.pressure.to_numpy(), th.pe.to_numpy()
    assert np.all(np.diff(phi) > 0)
    steps = np.round(np.diff(phi), 6)
    assert set(steps) <= {0.02, 0.001}
    fine_from = int(np.flatnonzero(steps == 0.001)[0])
    # every coarse row relaxed to zero energy (the jammed coarse step is not a row)
    assert np.all(pe[:fine_from + 1] < 1e-12)
    assert p[-1] >= 1e-2  # pressure_final's default ends the run
    free = np.flatnonzero(p < 1e-8)
    stressed = np.flatnonzero(p > 1e-4)
    assert free[-1] < stressed[0]
    above = slice(stressed[0], None)
    slopes = np.diff(p[above]) / np.diff(phi[above])
    assert slopes.min() > 0.5 * slopes.mean() and slopes.max() < 2 * slopes.mean()
    jp = JammingPoint((1e-3, 5e-3)).compute(phi, p)
    assert phi[free[-1]] <= jp.phi_j <= phi[stressed[0]] + 1e-3
    assert 0.80 < jp.phi_j < 0.87  # 64 bidisperse disks (paper's N = 1024: 0.8412)


def test_one_frame_per_row_and_the_pipeline_fits_phi_j(disks, tmp_path):
    """Each relaxation is a thermo row and a frame with the same step; the pipeline's
    analysis fits phi_J from the rows as for a compression, with the contact number
    of the frames near it."""
    th = RunData(disks).thermo
    frames = RunData(disks).frames()
    assert [f.step for f, _ in frames] == list(th.step)
    case_path = disks.parent / "case.yaml"
    analyse(disks, case_path)
    obs = pd.read_csv(disks / "observables.csv").set_index("observable")
    assert 0.80 < obs.loc["phi_j", "value"] < 0.87
    assert 3.5 < obs.loc["z_j", "value"] < 4.5  # isostatic disks: 4


def test_resume_from_the_last_relaxation(tmp_path, monkeypatch):
    """A run stopped inside a relaxation and resumed from its checkpoint ends with the
    same rows, bit for bit, as the run straight through."""
    from pysim import io
    from pysim.initial import write_initial
    from pysim.protocols import quasistatic

    case = validate_case(dict(DISKS, particles=dict(DISKS["particles"], n=32),
                              protocol=dict(DISKS["protocol"], pressure_final=3e-3)))
    write_initial(case, tmp_path / "init.data")
    init = io.read_particle_data(tmp_path / "init.data")
    quasistatic.run(case, init, tmp_path / "whole", progress=False)

    real, calls = quasistatic.step, []

    def stop_in_fine_steps(sim, *args):
        calls.append(1)
        if len(calls) == 26:  # past the coarse steps of 32 disks from 0.4
            raise KeyboardInterrupt
        return real(sim, *args)

    monkeypatch.setattr(quasistatic, "step", stop_in_fine_steps)
    with pytest.raises(KeyboardInterrupt):
        quasistatic.run(case, init, tmp_path / "cut", progress=False)
    monkeypatch.setattr(quasistatic, "step", real)
    quasistatic.run(case, init, tmp_path / "cut", progress=False, resume=True)
    for name in ("thermo.dat", "particles.dump"):
        assert (tmp_path / "cut" / name).read_text() == (tmp_path / "whole" / name).read_text()


def test_schema_refuses_a_step_of_zero():
    """``dphi`` must be positive: the schema names the key."""
    bad = dict(DISKS, protocol=dict(DISKS["protocol"], dphi=0.0))
    with pytest.raises(ConfigError, match="dphi"):
        validate_case(bad)


def test_overdamped_relaxation_unjams_below_and_settles_above(tmp_path):
    """The paper's dynamics at a fixed box (overdamped Heun, kappa = 0) as the
    relaxation: 32 disks squeezed affinely to 0.5 relax to zero energy; squeezed to 0.9
    (far above jamming) they settle at a stressed minimum whose pressure is the
    minimisers' from the same squeeze within 5 %."""
    from pysim import io
    from pysim.initial import write_initial
    from pysim.protocols import quasistatic
    from pysim.protocols.compress import simulation_from_case
    from pysim.protocols.jammed import energy_density

    case = validate_case(dict(DISKS, particles=dict(DISKS["particles"], n=32),
                              protocol=dict(DISKS["protocol"], relaxation="overdamped")))
    write_initial(case, tmp_path / "init.data")
    init = io.read_particle_data(tmp_path / "init.data")
    pr = case["protocol"]

    def squeezed(goal, relaxation):
        sim = simulation_from_case(case, init, check_dt=False)
        e = quasistatic.step(sim, goal, dict(pr, relaxation=relaxation), 1e-13, 1.0)
        return sim, e

    sim, e = squeezed(0.5, "overdamped")
    assert e < pr["energy_zero"] and sim.state.step > 0
    dense, e = squeezed(0.9, "overdamped")
    assert e > 1e-6 and dense.thermo().pressure > 1e-2
    assert quasistatic.relax_overdamped(dense, 1.0, pr["energy_zero"], 1.0, 1000, 1e-5, 10**6)
    assert energy_density(dense, 1.0) == pytest.approx(e, rel=1e-4)  # it had settled
    fire, _ = squeezed(0.9, "minimise")
    assert dense.thermo().pressure == pytest.approx(fire.thermo().pressure, rel=0.05)


def test_minimisers_refused_for_rods_under_the_closest_point_law():
    """FIRE and L-BFGS stall on the kink of the closest-point law: the case check sends
    rods under it to the overdamped relaxation or a smooth law."""
    rods = dict(DISKS, particles=dict(DISKS["particles"], aspect_ratio=1.0, n=256),
                contact=dict(DISKS["contact"], spine_contact="closest"))
    with pytest.raises(ConfigError, match="relaxation: overdamped"):
        validate_case(rods)
    validate_case(dict(rods, protocol=dict(rods["protocol"], relaxation="overdamped")))
    validate_case(dict(rods, contact=dict(rods["contact"], spine_contact="end_bonds")))
