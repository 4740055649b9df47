"""Per-run summaries of :mod:`analysis.summary` that need no engine run."""
import numpy as np
import pandas as pd
import pytest

from analysis.summary import cycle_rows, late_window, tap_cycle, tap_mark_rows


def curves(taps: int, frames_per_tap: int) -> pd.DataFrame:
    """Frame 0 (the settled packing, tap 0), then ``frames_per_tap`` frames per tap; the
    angle counts the frames so that a window's mean tells which frames it holds."""
    tap = np.concatenate([[0.0], np.arange(1, taps * frames_per_tap + 1) / frames_per_tap])
    return pd.DataFrame({"tap": tap, "angle": np.arange(len(tap), dtype=float)})


@pytest.mark.parametrize("taps, per_tap, first, n", [
    (400, 1, 351, 50),    # the last 50 of 400 taps, one frame per tap
    (100, 4, 87.75, 50),  # 12.5 taps of 4 frames: after tap 87.5
    (50, 4, 44.0, 25),    # 6.25 taps: after tap 43.75
    (4, 4, 3.25, 4),      # an eighth is less than a tap: the last tap
])
def test_late_window_holds_the_last_eighth_of_the_taps(taps, per_tap, first, n):
    late = late_window(curves(taps, per_tap))
    assert len(late) == n
    assert late.tap.min() == pytest.approx(first) and late.tap.max() == taps
    assert np.all(np.diff(late.angle) == 1)  # consecutive frames, up to the last


def test_late_window_of_a_run_without_taps_is_its_last_frame():
    settled = pd.DataFrame({"tap": [0.0], "angle": [20.0]})
    assert late_window(settled).angle.tolist() == [20.0]


def test_tap_marks_average_the_last_eighth_before_each_mark():
    c = curves(300, 1)
    c["phi"] = c.angle / 1000
    c["phi_enclosing"] = c.angle / 2000
    c["angle_layer1"] = c.angle + 1
    rows = {name: v for name, v, _ in tap_mark_rows(c)}
    # tap 100: the frames of taps 88-100 (12.5 taps: after 87.5); tap 900 is not reached
    assert rows["angle_tap100"] == pytest.approx(94.0)
    assert rows["phi_tap100"] == pytest.approx(0.094)
    assert rows["phi_tap100_enclosing"] == pytest.approx(0.047)
    assert rows["angle_tap100_layer1"] == pytest.approx(95.0)
    # tap 10: 1.25 taps, after tap 8.75: the frames of taps 9 and 10
    assert rows["angle_tap10"] == 9.5
    assert "angle_tap300" in rows and not any("tap900" in k for k in rows)
    # curves without the enclosing density give no enclosing rows
    assert not any(k.endswith("_enclosing")
                   for k, _, _ in tap_mark_rows(c.drop(columns="phi_enclosing")))


def thermo(every: int, steps: int, start: int, dt: float, period: float) -> pd.DataFrame:
    """Thermo rows every ``every`` steps of a bed whose kinetic energy is ``2 + cos(2 pi
    phase)`` J and which keeps ``100`` contacts, ``40`` in the half period after phase 0.5."""
    step = np.arange(0, steps + 1, every)
    phase = np.mod((step - start) * dt / period, 1.0)
    return pd.DataFrame({"step": step, "ke": 2.0 + np.cos(2 * np.pi * phase),
                         "n_contacts": np.where((phase > 0.45) & (phase < 0.95), 40, 100)})


def test_tap_cycle_bins_the_thermo_rows_by_their_phase():
    # 1000 steps of 2e-5 s every period of 1/30 s: rows visit phases 0, 0.6, 0.2, 0.8, 0.4
    th = thermo(1000, 200_000, 25_000, 2e-5, 1 / 30)
    cyc = tap_cycle(th, 25_000, 2e-5, 1 / 30, first_tap=10.0)
    assert cyc.phase.tolist() == pytest.approx([0.0, 0.2, 0.4, 0.6, 0.8])
    assert cyc.ke.to_numpy() == pytest.approx(2 + np.cos(2 * np.pi * cyc.phase.to_numpy()))
    assert cyc.n_contacts.tolist() == [100, 100, 100, 40, 40]
    # only rows from tap 10 on: (200000 - 25000 - 10 * 1666.67) / 1000 rows, all counted
    assert cyc.rows.sum() == np.sum((th.step - 25_000) * 2e-5 * 30 >= 10.0)
    rows = dict((name, value) for name, value, _ in cycle_rows(cyc, n_grains=4))
    assert rows["ke_cycle"] == pytest.approx(cyc.ke.mean() / 4)
    assert rows["ke_cycle_peak"] == pytest.approx(3.0 / 4)
    assert rows["contacts_flight"] == pytest.approx(0.4)
    assert rows["cycle_bins"] == 5


def test_cycle_observables_need_several_phases():
    # rows every 5000 steps of 2e-5 s: every third period, always at the same phase
    th = thermo(5000, 200_000, 25_000, 2e-5, 1 / 30)
    cyc = tap_cycle(th, 25_000, 2e-5, 1 / 30)
    assert len(cyc) == 1
    rows = dict((name, value) for name, value, _ in cycle_rows(cyc, n_grains=4))
    assert rows["cycle_bins"] == 1
    assert np.isnan(rows["ke_cycle"]) and np.isnan(rows["contacts_flight"])


def jamming_rows(**values):
    from analysis.summary import JAMMED_NAMES

    rows = [("phi_j", 0.56, 1e-3), ("jamming_slope", 20.0, np.nan)]
    rows += [(name, values.get(name, 4.5), np.nan) for name in JAMMED_NAMES]
    return rows + [("phi_final", 0.6, np.nan)]


def frames(n_rattlers, phi=(0.55, 0.57, 0.59), s_nematic=np.nan, n=200):
    c = pd.DataFrame({"phi": phi, "n_rattlers": n_rattlers, "n": n, "s_nematic": s_nematic})
    c.attrs["rattler_rule"] = "fewer than 6 contacts"
    return c


def test_problems_name_nan_observables_and_emptied_packings():
    """Every NaN observable is named (the nematic order of spheres, which have none,
    aside); frames at or above phi_J that the rattler rule empties are counted, with the
    rule and what to do about it; frames below jamming may be empty."""
    from analysis.summary import problems

    assert problems(jamming_rows(s_nematic_j=np.nan), frames([200, 10, 5])) == []
    got = problems(jamming_rows(z_j=np.nan, z_j_bonds=np.nan, s_nematic_j=np.nan),
                   frames([200, 200, 200]))
    assert got == [
        "observables z_j, z_j_bonds are NaN",
        "every grain is a rattler (fewer than 6 contacts) in 2 of the 2 frames at or above "
        "phi_j = 0.56 (phi 0.57 to 0.59); set analysis.c_min in the study's configuration if "
        "the rule does not fit these grains"]
    # rods: a NaN nematic order at jamming is a problem too
    assert problems(jamming_rows(s_nematic_j=np.nan), frames([200, 10, 5], s_nematic=0.2)) == [
        "observable s_nematic_j is NaN"]
    # without a jamming point every frame counts
    rows = [("phi_j", np.nan, np.nan), ("z_j", 5.0, np.nan)]
    assert problems(rows, frames([200, 10, 5]))[1].startswith(
        "every grain is a rattler (fewer than 6 contacts) in 1 of the 3 frames of the run")
    assert problems([("k_ratio", np.nan, np.nan), ("phi_deposit", 0.6, np.nan)]) == [
        "observable k_ratio is NaN"]


def test_analyse_run_passes_the_rattler_rule_and_warns_on_stderr(tmp_path, monkeypatch,
                                                                 capsys):
    """workflows.scripts.analyse_run: the case's friction and --c-min reach the analysis,
    and its problems are 'warning:' lines on stderr (the pipeline's analysis.log)."""
    import json

    import yaml

    from rodcase.case import validate_case
    from workflows.scripts import analyse_run

    case = validate_case({
        "particles": {"n": 500, "diameter": {"mean": 1.0}},
        "contact": {"law": "hooke", "k_n": 1e5, "gamma_n": 300.0, "friction": 0.5,
                    "k_t": 2e4},
        "protocol": {"name": "compress", "phi_init": 0.3, "rate": 0.005, "phi_final": 0.7,
                     "dt": 1e-4},
        "seed": 1})
    (tmp_path / "case.yaml").write_text(yaml.safe_dump(case))
    run = tmp_path / "pysim"
    run.mkdir()
    (run / "run.json").write_text(json.dumps({"status": "ok"}))
    seen = {}

    def fake(run_dir, window, p_scale, **kw):
        seen.update(kw)
        return jamming_rows(z_j=np.nan), frames([200, 200, 10]), None

    monkeypatch.setattr(analyse_run, "analyse_compression", fake)
    args = ["--case", tmp_path / "case.yaml", "--run", run, "--study", "s", "--variant", "v",
            "--seed", "1", "--engine", "pysim", "--observables", run / "observables.csv",
            "--curves", run / "curves.csv"]
    assert analyse_run.main([str(a) for a in args] + ["--c-min", "2"]) == 0
    assert seen == {"fit_from": None, "c_min": 2, "friction": 0.5}
    err = capsys.readouterr().err.splitlines()
    assert err == [f"warning: {run}: observable z_j is NaN",
                   f"warning: {run}: every grain is a rattler (fewer than 6 contacts) in 1 of "
                   "the 2 frames at or above phi_j = 0.56 (phi 0.57 to 0.57); set "
                   "analysis.c_min in the study's configuration if the rule does not fit these "
                   "grains"]
    assert analyse_run.main([str(a) for a in args]) == 0
    assert seen["c_min"] is None


def growth_dir(tmp_path, phi_growth, phi_cycles, jammed):
    """thermo.dat and cycles.dat of a growth run: growth frames at ``phi_growth``, then
    relaxed packings at ``phi_cycles`` (``jammed`` flags); steps 0, 1, ..."""
    from pysim import io

    with open(tmp_path / "thermo.dat", "w") as fh:
        fh.write(io.thermo_header())
        for k, f in enumerate(np.r_[phi_growth, phi_cycles]):
            io.write_thermo_row(fh, (k, k, f, 0.0, 0.0, 0.0, 0))
    start = len(phi_growth)
    (tmp_path / "cycles.dat").write_text("# step phi pe_per_particle pressure n_contacts jammed "
                                         "iterations residual settled\n" + "".join(
        f"{start + k} {f} 0 0 0 {int(j)} 10 0 1\n"
        for k, (f, j) in enumerate(zip(phi_cycles, jammed))))
    return tmp_path


def test_analyse_growth_reads_the_jump_and_the_cages_of_the_jammed_packing(tmp_path,
                                                                            monkeypatch):
    """Rods: growth frames on a base 2 + 30 (phi - 0.30) up to 0.40 (5 by then), the
    unjammed relaxed packing at 0.42 (no contacts left) and the jammed one at 0.43 with
    <C> 9.5: the value before the jump is the base where the growth ends, the relaxed
    unjammed frame no point of the curve; noncaged_fraction_j is that of the frame at
    phi_j. Spheres get NaN for the jump and no warning about it."""
    from analysis import summary

    phi_g = np.arange(0.30, 0.4001, 0.005)
    run = growth_dir(tmp_path, phi_g, [0.42, 0.44, 0.43], [False, True, True])
    z = np.r_[2.0 + 30.0 * (phi_g - 0.30), 0.0, 9.8, 9.5]
    curves = pd.DataFrame({"step": np.arange(len(z)), "phi": np.r_[phi_g, 0.42, 0.44, 0.43],
                           "z": z, "z_rattler_free": z, "z_bonds": z, "n_rattlers": 0, "n": 100,
                           "s_nematic": 0.05, "noncaged_fraction": np.r_[np.ones(21), 1.0, 0.0,
                                                                          0.02]})
    seen = {}

    def fake(run_dir, c_min, friction, caging=False):
        seen["caging"] = caging
        out = curves.copy()
        out.attrs["rods"] = rods
        return out

    monkeypatch.setattr(summary, "frame_curves", fake)
    rods = True
    rows, cv, _thermo = summary.analyse_growth(run)
    got = {name: v for name, v, _e in rows}
    assert seen["caging"] and got["phi_j"] == 0.43
    assert got["noncaged_fraction_j"] == 0.02
    assert got["phi_before_jump"] == pytest.approx(0.40)
    assert got["c_mean_before_jump"] == pytest.approx(5.0, abs=1e-9)
    rods = False
    rows, cv, _thermo = summary.analyse_growth(run)
    got = {name: v for name, v, _e in rows}
    assert np.isnan(got["c_mean_before_jump"]) and np.isnan(got["phi_before_jump"])
    assert summary.problems(rows, cv) == []


def test_pc_table_of_chosen_frames():
    """P(C) rows of the frames nearest to the packing fractions asked for, each once."""
    from analysis.contacts import contact_number_distribution
    from analysis.frame import Contacts, Frame
    from analysis.packing import packing_fraction
    from analysis.summary import pc_table

    frames = []
    for step, box in ((0, 10.0), (5, 6.0), (9, 4.0)):
        fr = Frame.from_arrays(np.arange(12.0).reshape(4, 3) % box, 0.5, [box] * 3, step=step)
        z = np.zeros((3, 3))
        frames.append((fr, Contacts(step, np.array([1, 2, 3]), np.array([2, 3, 4]), z, z,
                                    np.array([1e-3, 1e-3, -1.0 if step == 0 else 1e-3]), z)))

    class Run:
        def frames(self):
            return frames

    every = pc_table(Run())
    assert every.columns.tolist() == ["step", "phi", "c", "fraction"]
    assert every.step.unique().tolist() == [0, 5, 9]
    first = every[every.step == 0]
    np.testing.assert_allclose(first.fraction, contact_number_distribution(*frames[0]))
    assert first.phi.iloc[0] == packing_fraction(frames[0][0])
    phis = [packing_fraction(f) for f, _c in frames]
    chosen = pc_table(Run(), [phis[2] + 0.01, phis[0], phis[2]])
    assert chosen.step.unique().tolist() == [9, 0]
