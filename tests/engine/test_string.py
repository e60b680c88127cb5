"""One string: tuning, partial frequencies against the stiff-string formula, losses, grid bound."""

import math

import numpy as np
import pytest

import engine
from engine.analysis import cents, partials, spectrum_peak
from engine.fd.instrument import prepare
from engine.fd.string import h_min, tune
from engine.presets import PRESETS
from engine.scene import Scene
from engine.testing.scenes import SR, pluck, scene

CASES = [(p, s) for p in sorted(PRESETS) for s in range(1, PRESETS[p].n_strings + 1)]


def _open_pluck(preset, string, force=0.2, duration=2.0):
    # pluck and pickup away from the nodes of partials 1-10 (0.83 n, 0.913 n not integers)
    sc = Scene.model_validate(scene([pluck(string, force=force, position=0.83)],
                                    duration=duration, guitar={"preset": preset},
                                    output={"body": "none", "pickup_position": 0.913}))
    model = prepare(sc).voices[0].model
    return engine.render(sc), model


@pytest.mark.parametrize("preset,string", CASES)
def test_open_string_partials_follow_the_stiff_string_formula(preset, string):
    """Soft pluck: f_1 within 1 cent of nominal, partials 1-10 within 1 cent of
    f_n = n f0 sqrt(1 + B n^2) with f0 = sqrt(T / rho A) / 2L and B = pi^2 E I / (T L^2)."""
    audio, m = _open_pluck(preset, string)
    x = audio[int(0.05 * SR):]
    nominal = m.spec.frequency_hz
    assert abs(cents(spectrum_peak(x, SR, nominal), nominal)) < 1.0
    b = m.inharmonicity()
    f0 = math.sqrt(m.tension_n / m.rho_a) / (2 * m.length_m)
    n = np.arange(1, 11)
    expected = n * f0 * np.sqrt(1 + b * n**2)
    measured = partials(x, SR, nominal, 10, b)
    assert np.max(np.abs(cents(measured, expected))) < 1.0


@pytest.mark.parametrize("preset,string", CASES)
def test_tuned_scheme_sits_on_the_nominal_pitch_and_the_stability_bound(preset, string):
    p = PRESETS[preset]
    spec = p.strings[string - 1]
    for rate in (22050, 44100, 96000):
        m = tune(spec, p.string_length_m(string), rate)
        assert abs(cents(m.frequency(1), spec.frequency_hz)) < 1e-6
        assert m.h >= h_min(m.k, m.tension_n, m.rho_a, m.ei, m.sigma1)  # eq. (47)
        assert m.n == int(m.length_m / h_min(m.k, m.tension_n, m.rho_a, m.ei, m.sigma1))


def test_decay_follows_the_t60_at_the_fundamental(steel):
    """Level of the fundamental falls 60 dB in about T60 (sigma_0, sigma_1 calibration)."""
    audio, m = _open_pluck("steel-acoustic", 1, duration=2.5)
    f = m.spec.frequency_hz
    win = int(0.25 * SR)

    def level(t):
        seg = audio[int(t * SR):int(t * SR) + win]
        spec = np.abs(np.fft.rfft(seg * np.hanning(win)))
        i = int(round(f * win / SR))
        return 20 * np.log10(spec[i - 3:i + 4].max())

    slope = (level(2.0) - level(0.5)) / 1.5  # dB per second
    t60 = -60.0 / slope
    assert t60 == pytest.approx(m.spec.t60_fundamental_s, rel=0.1)


