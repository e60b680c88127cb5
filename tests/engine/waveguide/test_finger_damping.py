"""The finger's damping of a held note on the waveguide (``engine.waveguide.fingering``): the fingering
termination loses per period what the finite-difference model's finger takes from the held mode
(its own linear analysis, ``engine.fd.intonation.held_note`` on the converged grid)."""

from __future__ import annotations

import engine
from engine import waveguide
from engine.analysis import decay_db_per_s
from engine.models import PRESSED_STRING
from engine.testing.scenes import SR, fret, pluck, scene
from engine.waveguide import WaveguideOptions
from engine.waveguide.fingering import finger_decay_db_s

STEEL = engine.get_preset("steel-acoustic")


def test_a_held_note_decays_faster_by_the_fingers_rate():
    """String 2 at fret 12, where the finite-difference finger damps most of the steel set's
    frets 1, 5 and 12: the fundamental decays D dB/s faster with the finger's damping than
    without it, D the finite-difference analysis' rate, to 0.2 dB/s."""
    s, q = 2, 12
    f = STEEL.strings[s - 1].frequency_hz * 2 ** (q / 12)
    sc = engine.parse_scene({**scene([fret(s, q), pluck(s, time=0.05)], 1.2),
                             "model": "waveguide"})
    with_finger = decay_db_per_s(waveguide.render(sc, statics=PRESSED_STRING), SR, f)
    without = decay_db_per_s(waveguide.render(sc, WaveguideOptions(finger_damping=False),
                                              statics=PRESSED_STRING), SR, f)
    d = finger_decay_db_s(PRESSED_STRING, STEEL, s, float(SR), q)
    print(f"finger {d:+.2f} dB/s; held note {with_finger:+.2f}, without the finger {without:+.2f}")
    assert d < -1.0  # the case is one where the finger matters
    assert abs((with_finger - without) - d) < 0.2


def test_the_frets_a_slide_crosses_are_not_damped():
    """A slide from fret 3 to 9 over 0.2 s (the finger lands on fret 3 as it starts): the frets
    it passes are stopped for a few milliseconds each; the note is held (damped) only from the
    step the finger comes to rest on its goal."""
    sc = engine.parse_scene({**scene([{"type": "slide", "time": 0.3, "string": 3, "from_fret": 3,
                                       "to_fret": 9, "duration": 0.2},
                                      pluck(3, time=0.32)], 1.0), "model": "waveguide"})
    v = waveguide.prepare(sc, statics=PRESSED_STRING).voices[0]
    held = [(at, fr) for at, fr, _, h in v.changes if h]
    passed = {fr for _, fr, _, h in v.changes if not h and fr is not None}
    assert held == [(round(0.5 * SR), 9)], v.changes
    assert passed == {3, 4, 5, 6, 7, 8, 9}, v.changes


def test_a_short_note_is_damped_from_the_step_its_finger_lands():
    """A finger on fret 5 for 20 ms, then on fret 7: both notes damped from their finger's
    landing (whether a finger rests is its own event's to say, not the events after it, so a
    live session, which learns of fret 7 only when it comes, damps fret 5 as a render does)."""
    sc = engine.parse_scene({**scene([fret(2, 5, time=0.1), pluck(2, time=0.1),
                                      fret(2, 7, time=0.12)], 0.3), "model": "waveguide"})
    v = waveguide.prepare(sc, statics=PRESSED_STRING).voices[0]
    assert [(at, fr, h) for at, fr, _, h in v.changes] == [
        (0, None, False), (round(0.1 * SR), 5, True), (round(0.12 * SR), 7, True)]
