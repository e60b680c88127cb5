"""Kirchhoff-Carrier tension modulation: hard plucks glide down in pitch, soft ones do not."""

import pytest

import engine
from engine.analysis import cents, spectrum_peak
from engine.testing.scenes import SR, pluck, scene


def _glide(steel, string, force):
    audio = engine.render(scene([pluck(string, force=force)], duration=0.7))
    f = steel.strings[string - 1].frequency_hz
    early = spectrum_peak(audio[int(0.01 * SR):int(0.11 * SR)], SR, f, 0.05)
    late = spectrum_peak(audio[int(0.5 * SR):int(0.6 * SR)], SR, f, 0.05)
    return float(cents(early, late))


@pytest.mark.parametrize("string", [5, 6])
def test_hard_pluck_glides_down(steel, string):
    """8 N: the fundamental in the first 0.1 s is several cents above its pitch at 0.5 s."""
    assert _glide(steel, string, 8.0) > 5.0


@pytest.mark.parametrize("string", [1, 5, 6])
def test_soft_pluck_does_not_glide(steel, string):
    """0.2 N: below a cent (the estimator itself reads up to ~0.5 c on E2's 8 periods)."""
    assert abs(_glide(steel, string, 0.2)) < 1.0


def test_glide_vanishes_without_kirchhoff_carrier(steel):
    """The glide is the tension modulation's (frets and fretboard off: no buzz either)."""
    from engine.options import RenderOptions

    off = RenderOptions(kirchhoff_carrier=False, frets=False, fretboard=False)
    audio = engine.render(scene([pluck(6, force=8.0)], duration=0.7), options=off)
    f = steel.strings[5].frequency_hz
    early = spectrum_peak(audio[int(0.01 * SR):int(0.11 * SR)], SR, f, 0.05)
    late = spectrum_peak(audio[int(0.5 * SR):int(0.6 * SR)], SR, f, 0.05)
    assert abs(cents(early, late)) < 0.5
