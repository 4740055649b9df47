"""The readings of growth curves on synthetic ones with known answers: the onset of the
rods' jump of <C>(phi), the frame noise, and the packing fraction above which runs at
different rates agree."""
import numpy as np
import pandas as pd
import pytest

from analysis.growth import (growing_frames, jump_onset, noise_level, phi_rate_independent)

NOISE = 0.05  # frame-to-frame noise of <C>: a 2048-rod growth showed 0.02 per 0.001 in phi


def rod_curve(rng, width=0.003, step=0.004, noise=NOISE, phi0=0.40):
    """<C>(phi) of a growing rod packing: a start transient (0 to 2.9 and back, as a
    contraction that hands over to the growth leaves it), a base 1.8 + 30 (phi - 0.33)
    and a logistic rise of 6.5 contacts of ``width`` centred at ``phi0``; frames every
    ``step``. Returns ``(phi, c, answer)``, the answer the base at ``phi0 - 2 width``,
    where the steepest tangent of the rise meets a flat base."""
    phi = np.arange(0.31, phi0 + 0.03, step)
    c = 1.8 + 30.0 * np.clip(phi - 0.33, 0, None) + 6.5 / (1 + np.exp(-(phi - phi0) / width))
    c[:6] = [0.0, 1.5, 2.3, 2.9, 2.5, 2.0]
    return phi, c + noise * rng.normal(size=len(phi)), 1.8 + 30.0 * (phi0 - 2 * width - 0.33)


@pytest.mark.parametrize("seed", range(4))
@pytest.mark.parametrize("width,step,noise", [(0.001, 0.001, 0.02), (0.003, 0.001, 0.02),
                                              (0.001, 0.004, NOISE), (0.003, 0.004, NOISE)])
def test_onset_of_a_sharp_jump(seed, width, step, noise):
    """Sharp rises (over 0.01 in phi or less), frames dense or sparse: the base at the
    onset within 0.2 (the docstring's claim), and the onset just below the rise."""
    phi, c, answer = rod_curve(np.random.default_rng(seed), width, step, noise)
    phi_b, c_b = jump_onset(phi, c)
    assert c_b == pytest.approx(answer, abs=0.2)
    assert 0.40 - 5 * width - 0.004 < phi_b < 0.40


def test_a_wide_rise_is_read_higher_up_its_base(rng):
    """A rise of width 0.01 (spread over 0.04): no sharp foot, the value read lies 0.3
    to 0.7 above the base at phi0 - 2 width (frames every 0.001, noise 0.02)."""
    for _ in range(4):
        phi, c, answer = rod_curve(rng, width=0.01, step=0.001, noise=0.02)
        assert answer + 0.2 <= jump_onset(phi, c)[1] <= answer + 0.8


@pytest.mark.parametrize("step", [0.005, 0.001])
def test_onset_of_a_jump_between_two_frames(rng, step):
    """The jump of a growth that ends below phi_J: the last growth frame near 3.1, then
    the jammed packing alone at 9.5; the base is the growth's last frames (dense frames
    are binned, the jammed one keeps its own bin)."""
    phi = np.r_[np.arange(0.30, 0.40 + step / 2, step), 0.43]
    c = np.r_[1.0 + 21.0 * (phi[:-1] - 0.3), 9.5] + np.r_[NOISE * rng.normal(size=len(phi) - 1), 0]
    phi_b, c_b = jump_onset(phi, c)
    assert phi_b == pytest.approx(0.40, abs=0.003)
    assert c_b == pytest.approx(3.1, abs=0.1)


# <C> (rattlers included, P(C)'s mean) of the first 57 frames of a growth of 2048 rods of
# alpha = 11 (phi 0.05, the contraction to 0.31, then growth at rate 0.01): a start
# transient, then a base that curves up, frames every 0.001
REAL_PHI = np.array([
    0.05, 0.31, 0.3109, 0.3118, 0.3127, 0.3137, 0.3146, 0.3156, 0.3165, 0.3175, 0.3184, 0.3194,
    0.3203, 0.3213, 0.3223, 0.3232, 0.3242, 0.3252, 0.3261, 0.3271, 0.3281, 0.3291, 0.3301,
    0.3311, 0.3321, 0.3331, 0.3341, 0.3351, 0.3361, 0.3371, 0.3381, 0.3391, 0.3401, 0.3412,
    0.3422, 0.3432, 0.3442, 0.3453, 0.3463, 0.3474, 0.3484, 0.3494, 0.3505, 0.3516, 0.3526,
    0.3537, 0.3547, 0.3558, 0.3569, 0.3579, 0.359, 0.3601, 0.3612, 0.3623, 0.3633, 0.3644,
    0.3655])
REAL_C = np.array([
    0.0, 0.007, 1.465, 1.516, 1.939, 2.306, 2.679, 2.917, 2.892, 2.764, 2.515, 2.243, 1.968,
    1.93, 1.867, 1.785, 1.744, 1.784, 1.793, 1.782, 1.778, 1.764, 1.793, 1.804, 1.87, 1.866,
    1.89, 1.939, 1.906, 1.982, 1.979, 2.032, 2.104, 2.138, 2.104, 2.173, 2.271, 2.337, 2.369,
    2.388, 2.48, 2.54, 2.621, 2.608, 2.751, 2.81, 2.887, 2.957, 3.003, 3.096, 3.092, 3.194,
    3.209, 3.314, 3.416, 3.51, 3.567])


@pytest.mark.parametrize("phi_j", [0.37, 0.40, 0.45])
def test_a_measured_growth_ending_in_a_jammed_packing(phi_j):
    """The measured curve, ended by a jammed packing of <C> = 9.5 at phi_j: the value
    before the jump is where the growth's base ends, 3.4 to 3.6 over its last frames
    (binned by four: their mean phi is 0.3639), not the start transient (whose rise to
    2.9 is as steep but not towards the end), however far the jammed packing lies."""
    phi_b, c_b = jump_onset(np.r_[REAL_PHI, phi_j], np.r_[REAL_C, 9.5])
    assert 0.362 <= phi_b <= 0.3656
    assert 3.4 <= c_b <= 3.6
    assert np.isnan(jump_onset(REAL_PHI, REAL_C)[0])  # before the jump: none yet


def test_single_spikes(rng):
    """A spike of +-3 contacts in one frame (60 noise levels): away from the jump (the
    growth below the base, the plateau after the rise but its last point) the value does
    not move at all; inside the base (frames 14 to 17, 0.022 to 0.034 below the rise's
    centre) by less than 0.25, the running median putting a neighbour in its place."""
    phi, c, _answer = rod_curve(rng)
    ref = jump_onset(phi, c)[1]
    for k in range(len(phi) - 1):
        for d in (3.0, -3.0):
            spiked = c.copy()
            spiked[k] += d
            moved = abs(jump_onset(phi, spiked)[1] - ref)
            if k < 14 or k >= 25:
                assert moved == 0.0
            elif k < 18:
                assert moved < 0.25


def test_spheres_have_no_jump(rng):
    """<C> of spheres grows about linearly (6 over 0.15 in phi), with noise: no rise of
    two contacts at the steepest place."""
    phi = np.arange(0.49, 0.64, 0.003)
    c = 2.0 + 25.0 * (phi - 0.49) + NOISE * rng.normal(size=len(phi))
    assert np.isnan(jump_onset(phi, c)[1])
    assert np.isnan(jump_onset([0.3, 0.4], [1.0, 9.0])[0])


def test_noise_level_of_a_noisy_trend(rng):
    phi = np.linspace(0.4, 0.6, 400)
    y = 3 + 20 * (phi - 0.4) + 40 * (phi - 0.4) ** 2
    assert noise_level(phi, y + 0.05 * rng.normal(size=400)) == pytest.approx(0.05, rel=0.15)
    assert noise_level(phi, y) < 1e-6
    # a fraction pinned at 1 before it falls: the pinned frames say nothing about noise
    f = np.r_[np.ones(300), 1 - 0.002 * np.arange(1, 101) + 0.01 * rng.normal(size=100)]
    assert noise_level(np.arange(400.0), f) == pytest.approx(0.01, rel=0.3)
    assert np.isnan(noise_level([0.1, 0.2], [1, 2]))


def converging(rng, a, phi_c=0.60, noise=0.02, step=0.003, top=0.65):
    """A run's curve: a common trend plus a * (phi_c - phi) below phi_c, noise on top."""
    phi = np.arange(0.49, top, step) + rng.uniform(0, step)
    y = 3.0 + 20 * (phi - 0.49) - a * np.clip(phi_c - phi, 0, None)
    return pd.DataFrame({"phi": phi, "z": y + noise * rng.normal(size=len(phi))})


@pytest.mark.parametrize("seed", range(8))
def test_rate_independence_where_the_curves_meet(seed):
    """Three rates whose curves differ by 20 and 40 contacts per unit phi below 0.60 and
    agree above: the answer lies between where their difference falls to the
    tolerance (3 sqrt(2) x 0.02 = 0.085 -> 0.6 - 0.085 / 20 = 0.596) and a frame above
    0.60 (measured over 40 seeds: 0.5968 to 0.6024)."""
    rng = np.random.default_rng(seed)
    runs = [converging(rng, a) for a in (0.0, 20.0, 40.0)]
    phi = phi_rate_independent(runs, "z")
    assert 0.593 <= phi <= 0.606


def test_rate_independence_edge_cases(rng):
    same = [converging(rng, 0.0) for _ in range(2)]
    lo = max(r.phi.min() for r in same)
    assert phi_rate_independent(same, "z") == pytest.approx(lo)
    apart = [converging(rng, 0.0), converging(rng, 0.0).assign(z=lambda d: d.z + 1.0)]
    assert np.isnan(phi_rate_independent(apart, "z"))
    # an explicit tolerance replaces the noise estimate
    runs = [converging(rng, a, noise=0.0) for a in (0.0, 10.0)]
    assert phi_rate_independent(runs, "z", tol=0.1) == pytest.approx(0.59, abs=0.004)
    disjoint = [converging(rng, 0.0, top=0.55), converging(rng, 0.0).query("phi > 0.56")]
    assert np.isnan(phi_rate_independent(disjoint, "z"))
    with pytest.raises(ValueError, match="at least two runs"):
        phi_rate_independent(runs[:1], "z")
    with pytest.raises(ValueError, match="lacks"):
        phi_rate_independent(runs, "noncaged_fraction")


def test_growing_frames_keep_the_growth_and_the_jammed_end():
    cv = pd.DataFrame({"step": [0, 10, 20, 30, 40, 50], "phi": [0.3, 0.4, 0.5, 0.55, 0.53, 0.52],
                       "relaxed": [False, False, False, True, True, True],
                       "jammed": [False, False, False, True, True, False]})
    assert growing_frames(cv).step.tolist() == [0, 10, 20, 40]
    assert growing_frames(cv.drop(columns=["relaxed", "jammed"])).step.tolist() == \
        [0, 10, 20, 50, 40, 30]


def test_growth_figure_writes_a_png(tmp_path, rng):
    """Fig. 2, 6 and 3 of the paper in one figure, for two rates and three densities."""
    from analysis.plots import growth_curves

    runs = []
    for k, width in enumerate((0.002, 0.006)):
        phi, c, _answer = rod_curve(rng, width=width)
        cv = pd.DataFrame({"phi": phi, "z": c, "noncaged_fraction": np.clip(1 - c / 10, 0, 1)})
        phi_b, c_b = jump_onset(phi, c)
        runs.append({"label": f"rate {k}", "curves": cv, "phi_before_jump": phi_b,
                     "c_mean_before_jump": c_b, "phi_j": 0.43})
    pc = pd.concat([pd.DataFrame({"step": s, "phi": f, "c": np.arange(12),
                                  "fraction": np.exp(-0.5 * (np.arange(12) - m) ** 2) / 2.5})
                    for s, f, m in ((0, 0.35, 3), (1, 0.40, 6), (2, 0.43, 9.5))])
    out = tmp_path / "figs" / "growth.png"
    growth_curves(runs, out, pc=pc, title="alpha = 11")
    assert out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    growth_curves(runs[:1], tmp_path / "two_panels.png")
    assert (tmp_path / "two_panels.png").stat().st_size > 1000
