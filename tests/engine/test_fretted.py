"""Fretted and tapped notes land on 12-TET (the contacts hold the string on the fret)."""

import pytest

import engine
from engine.analysis import cents, spectrum_peak
from engine.testing.scenes import SR, fret, pluck, scene, tap

FRETS = range(1, 13)


def _pitch_cents(audio, target, start=0.2):
    return cents(spectrum_peak(audio[int(start * SR):], SR, target, 0.08), target)


@pytest.mark.parametrize("string", range(1, 7))
def test_fretted_notes_within_5_cents(steel, string):
    """Frets 1-12, finger pressed with 3 N behind the fret, plucked: within +-5 cents."""
    errors = {}
    for q in FRETS:
        audio = engine.render(scene([fret(string, q), pluck(string, time=0.05)], duration=1.2))
        target = steel.strings[string - 1].frequency_hz * 2 ** (q / 12)
        errors[q] = round(float(_pitch_cents(audio, target)), 2)
    assert max(abs(e) for e in errors.values()) <= 5.0, errors


@pytest.mark.parametrize("string,q", [(1, 5), (3, 7), (5, 12), (6, 3)])
def test_tap_sounds_the_fretted_pitch(steel, string, q):
    """No pluck: the finger strikes the string onto the fret (paper Fig. 3c)."""
    audio = engine.render(scene([tap(string, q, force=3.0, velocity=1.5)], duration=1.2))
    assert abs(audio).max() > 0
    target = steel.strings[string - 1].frequency_hz * 2 ** (q / 12)
    assert abs(_pitch_cents(audio, target, start=0.1)) <= 5.0


def test_fret_zero_and_release_return_to_the_open_string(steel):
    f_open = steel.strings[0].frequency_hz
    audio = engine.render(scene([fret(1, 5), fret(1, 0, time=0.1), pluck(1, time=0.3)],
                                duration=1.3))
    assert abs(_pitch_cents(audio, f_open, start=0.4)) < 2.0
    audio = engine.render(scene([fret(1, 5, release=0.1), pluck(1, time=0.3)], duration=1.3))
    assert abs(_pitch_cents(audio, f_open, start=0.4)) < 2.0
