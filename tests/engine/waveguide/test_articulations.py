"""The articulations on the waveguide, measured as the finite-difference model's tests measure
them (tests/engine/test_articulations.py, benchmarks/articulations.py): harmonics, palm mute,
dead notes, slides, hammer-ons, pull-offs, taps, strums, pluck styles; every event type maps."""

import numpy as np
import pytest

import engine
from engine.analysis import band_level_db, level_db
from engine.models import PRESSED_STRING
from engine.waveguide import prepare
from engine.waveguide.controls import timeline

from .conftest import SR, fret, pitch_cents, pluck, render

STEEL = engine.get_preset("steel-acoustic")


def note(string: int, q: float) -> float:
    return STEEL.strings[string - 1].frequency_hz * 2 ** (q / 12)


@pytest.mark.parametrize("q,partial", [(12, 2), (7, 3), (5, 4)])
def test_natural_harmonics(q, partial):
    """A light touch over fret q of string 1, plucked near the bridge, released at 0.3 s: the
    partial with a node there is the loudest afterwards; at fret 12 the fundamental is at least
    20 dB below the octave."""
    a = render([{"type": "harmonic", "time": 0.0, "string": 1, "fret": q, "release": 0.3},
                pluck(1, time=0.02, force=2.0, position=0.85)], 1.2)
    a = a[int(0.4 * SR):]
    levels = {n: band_level_db(a, SR, n * note(1, 0)) for n in range(1, 6)}
    assert max(levels, key=levels.get) == partial, levels
    if q == 12:
        assert levels[1] <= levels[2] - 20.0, levels


def _late(a):
    return level_db(a[int(0.5 * SR):int(0.6 * SR)])


def test_palm_mute_shortens_the_decay():
    open_ = render([pluck(1, force=2.0)], 1.0)
    muted = render([{"type": "mute", "time": 0.0, "string": 1}, pluck(1, force=2.0)], 1.0)
    assert _late(open_) - _late(muted) >= 20.0


def test_dead_note_is_short():
    """A finger resting without pressing (0.05 N, below the seating force): the note dies fast."""
    fretted = render([fret(3, 5), pluck(3, time=0.05)], 0.8)
    dead = render([fret(3, 5, force=0.05), pluck(3, time=0.05)], 0.8)
    assert _late(fretted) - _late(dead) >= 20.0


def test_a_light_finger_is_warned_about():
    sc = engine.parse_scene({"duration": 0.2, "model": "waveguide",
                             "events": [fret(3, 5, force=0.05), pluck(3, time=0.05)]})
    w = prepare(sc, statics=PRESSED_STRING).warnings()
    assert len(w) == 1 and "string 3" in w[0] and "dead" in w[0]


def test_slide_hammer_on_pull_off_and_tap_land_on_their_frets():
    a = render([fret(3, 5), pluck(3, time=0.05), {"type": "slide", "time": 0.4, "string": 3,
                                                   "from_fret": 5, "to_fret": 7,
                                                   "duration": 0.15}], 1.5)
    assert abs(pitch_cents(a, note(3, 5), 0.2, 0.4)) <= 3.0
    assert abs(pitch_cents(a, note(3, 7), 0.7, 1.5)) <= 3.0
    a = render([fret(3, 5), pluck(3, time=0.05),
                {"type": "hammer_on", "time": 0.4, "string": 3, "fret": 7}], 1.5)
    assert abs(pitch_cents(a, note(3, 7), 0.6, 1.5)) <= 3.0
    a = render([fret(3, 5), {"type": "hammer_on", "time": 0.0, "string": 3, "fret": 7},
                pluck(3, time=0.05), {"type": "pull_off", "time": 0.4, "string": 3, "fret": 7}],
               1.5)
    assert abs(pitch_cents(a, note(3, 7), 0.15, 0.4)) <= 3.0
    assert abs(pitch_cents(a, note(3, 5), 0.6, 1.5)) <= 3.0
    for string, q in [(1, 5), (3, 7), (5, 12), (6, 3)]:
        a = render([{"type": "tap", "time": 0.0, "string": string, "fret": q, "force": 3.0,
                     "velocity": 1.5}], 1.2)
        assert np.abs(a).max() > 0
        assert abs(pitch_cents(a, note(string, q), 0.1)) <= 3.0


def test_fret_zero_and_release_return_to_the_open_string():
    for evs in ([fret(1, 5), fret(1, 0, time=0.1), pluck(1, time=0.3)],
                [fret(1, 5, release=0.1), pluck(1, time=0.3)]):
        a = render(evs, 1.3)
        assert abs(pitch_cents(a, note(1, 0), 0.4)) < 1.0


def test_strum_down_plucks_low_to_high_and_styles_differ():
    sc = engine.parse_scene({"duration": 0.1, "model": "waveguide",
                             "events": [{"type": "strum", "time": 0.0, "spread": 0.05}]})
    inst = prepare(sc, statics=PRESSED_STRING)
    starts = {v.index: v.timeline.slots[0].on for v in inst.voices}
    assert sorted(starts, key=starts.get) == [6, 5, 4, 3, 2, 1]
    slots = {}
    for style in ("finger", "pick", "slap", "pop"):
        sc = engine.parse_scene({"duration": 0.05, "events": [pluck(1, style=style)]})
        p = sc.preset()
        slots[style] = timeline(sc, p, 1, 44100.0, 0.3, lambda q, f: True).slots[0]
    assert slots["pick"].length < slots["finger"].length < slots["pop"].length
    assert slots["slap"].force < 0 < slots["finger"].force
    assert slots["pick"].window == "triangle" and slots["finger"].window == "bell"


def test_bass_slap_rattles_against_the_frets():
    """Slap and pop drive the string into the frets: without the collision junctions the sound is
    a different one."""
    from engine.waveguide import WaveguideOptions

    evs = [pluck(4, force=10.0, style="slap", position=0.85),
           pluck(1, time=0.2, force=10.0, style="pop", position=0.85)]
    with_frets = render(evs, 0.5, guitar={"preset": "bass"})
    without = render(evs, 0.5, WaveguideOptions(collisions=False), guitar={"preset": "bass"})
    err = np.linalg.norm(with_frets - without) / np.linalg.norm(without)
    assert err > 0.1


EVERY_EVENT = [
    {"type": "pluck", "time": 0.0, "string": 1},
    {"type": "fret", "time": 0.0, "string": 2, "fret": 3, "release": 0.1},
    {"type": "tap", "time": 0.01, "string": 3, "fret": 5},
    {"type": "hammer_on", "time": 0.02, "string": 3, "fret": 7},
    {"type": "pull_off", "time": 0.05, "string": 3, "fret": 7},
    {"type": "slide", "time": 0.0, "string": 4, "from_fret": 2, "to_fret": 5, "duration": 0.05},
    {"type": "bend", "time": 0.0, "string": 1, "semitones": 1.5, "duration": 0.05,
     "release": 0.1},
    {"type": "vibrato", "time": 0.0, "string": 2, "duration": 0.1},
    {"type": "harmonic", "time": 0.0, "string": 5, "fret": 12, "release": 0.05},
    {"type": "mute", "time": 0.0, "amount": 0.5},
    {"type": "strum", "time": 0.05, "direction": "up", "style": "pick"},
]


def test_every_event_type_maps():
    a = render(EVERY_EVENT, 0.2)
    assert np.isfinite(a).all() and np.abs(a).max() > 0


def test_damp_stops_the_note_within_tens_of_milliseconds():
    """``damp`` on an open and on a fretted string: 60 dB down within 50 ms."""
    for evs in ([pluck(1, force=2.0), {"type": "damp", "time": 0.3, "string": 1}],
                [fret(3, 5), pluck(3, force=2.0), {"type": "damp", "time": 0.3}]):
        a = render(evs, 0.5)
        before = level_db(a[int(0.28 * SR):int(0.29 * SR)])
        after = level_db(a[int(0.35 * SR):int(0.36 * SR)])
        assert after <= before - 60.0, (before, after)
