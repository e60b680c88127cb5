"""Each of the waveguide's skips is bounded: the output with the skip against the output without
it (``tools.wg_skips`` prints the same on whole songs and the digest's scenes).

* steady runs (``kernel._steady``): dampers in contact and released junctions leaking away
  stepped in the plain runs: exact, not one sample differs;
* the damper bound (``kernel._reach``): the collision points beside a damper in contact bounded
  by the string's energy, not all tested every sample: exact;
* the decay stop between events (``kernel._may_sleep``, ``voice._sleep``): a still string sleeps
  until its next event, its state kept: the output differs by less than -140 dB of full scale
  after the fixed gain (``tools.wg_skips.TOLERANCE``), and a string at rest before its first note
  not at all."""

from __future__ import annotations

import numpy as np
import pytest

import engine
from engine import models, waveguide
from engine.testing.scenes import fret, pluck, scene
from tools.wg_skips import CORPUS, TOLERANCE, render, song_scene


def _scene(events: list, duration: float, **extra):
    return engine.parse_scene({**scene(events, duration), "model": "waveguide", **extra})


def _damp(time: float, string: int) -> dict:
    return {"type": "damp", "time": time, "string": string}


# notes ended by damps, palm mutes, a harmonic touch and a dead note, with rests between them:
# every kind of steady junction, and strings that fall still between their notes
MUSIC = [fret(3, 5), pluck(3, time=0.01, force=2.0), _damp(0.25, 3),
         pluck(3, time=1.2, force=1.0), _damp(1.4, 3),
         pluck(1, time=0.0, force=2.0), _damp(0.15, 1), pluck(1, time=0.9, force=2.0),
         {"type": "mute", "time": 0.3, "string": 5, "amount": 0.8, "release": 0.8},
         pluck(5, time=0.35, force=2.0),
         {"type": "harmonic", "time": 0.5, "string": 6, "fret": 12, "release": 0.6},
         pluck(6, time=0.5, force=2.0),
         {"type": "fret", "time": 1.0, "string": 2, "fret": 7, "force": 0.05},
         pluck(2, time=1.0, force=2.0)]


def test_steady_junctions_run_in_plain_runs_to_the_bit():
    sc = _scene(MUSIC, 2.0)
    a, steps = render(sc)
    b, off = render(sc, steady_runs=False)
    assert np.array_equal(a, b)
    # the damps, the palm, the touch and the dead note held most steps in the general step
    assert off["general"] > 0.3 * off["all"], off
    assert steps["general"] < 0.05 * steps["all"], steps


def test_a_damper_leaves_its_neighbours_to_the_energy_bound_to_the_bit():
    """The music above, and a string rattling on the frets while a palm rests on it (a 15 N slap
    at fret 12, the palm down from 2 ms later: the collisions act during the contact, the render
    without them differs there): the same samples as with every collision point beside a damper
    tested at every step, for far fewer point-steps tested."""
    rattle = [fret(6, 12, force=5.0), pluck(6, time=0.0, force=15.0, style="slap"),
              {"type": "mute", "time": 0.002, "string": 6, "amount": 0.3, "release": 0.4}]
    for events, duration in ((MUSIC, 2.0), (rattle, 0.5)):
        sc = _scene(events, duration)
        a, steps = render(sc)
        b, wide = render(sc, damper_bound=False)
        print(f"collision point-steps tested {steps['tested']} / {wide['tested']}")
        assert np.array_equal(a, b)
        assert steps["tested"] < 0.5 * wide["tested"], (steps, wide)
    # the collisions act during the palm's contact: with the obstacles taken away from 10 ms on
    # (the slap's pulse long over, the palm down), the string sounds otherwise from there
    sc = _scene(rattle, 0.5)
    outs = []
    for obstacles in (True, False):
        inst = waveguide.prepare(sc, statics=models.PRESSED_STRING)
        first = inst.render_frames(441)
        for v in inst.voices:
            if not obstacles:
                v.col_ref[:] = -1.0  # a metre below the string
        outs.append(np.concatenate([first, *inst.blocks(4096)]))
    assert np.array_equal(outs[0][:441], outs[1][:441])
    assert not np.array_equal(outs[0], outs[1])


def test_a_still_string_sleeps_until_its_next_note_within_the_tolerance():
    """Two short-lived strings (T60 0.5 s), plucked at 0 and again at 3 s: each falls still by
    about 1.2 s and sleeps until its next pluck, which meets the frozen decay (and, string 3
    fretted, the frets: 2 N pluck, collisions on); the output stays within the tolerance of the
    render without the stop."""
    short = {"guitar": {"strings": [{"string": s, "t60_fundamental_s": 0.5, "t60_2khz_s": 0.2}
                                    for s in (1, 3)]}}
    events = [pluck(1, force=2.0), pluck(1, time=3.0, force=2.0), fret(3, 5),
              pluck(3, time=0.01, force=2.0), pluck(3, time=3.0, force=2.0)]
    sc = _scene(events, 3.5, **short)
    a, steps = render(sc)
    b, _ = render(sc, skip_decayed=False)
    d = float(np.max(np.abs(a - b)))
    print(f"slept {steps['slept'] / steps['all']:.1%} of the string-steps, max |diff| {d:.2e} "
          f"m/s, peak {np.max(np.abs(b)):.2f}")
    assert steps["slept"] > 2 * 44100  # both strings, most of the rest
    assert 0.0 < d < TOLERANCE


def test_a_damped_string_sleeps_once_silent_with_the_damped_bound():
    """A fretted note ended by a damp creeps back to its rest line for seconds (the dampers' leak
    passes what is slower than ``pluck.LEAK_HZ``), its points a little faster than
    ``decay_velocity``, the pickup far slower.  With the default bound it runs to its next note;
    with ``damped_velocity`` = 1e-6 m/s it sleeps once silent.  A light next pluck (nothing
    collides after the wake) stays within the decay stop's tolerance of the render without any
    stop."""
    events = [fret(3, 5), pluck(3, time=0.01, force=2.0), _damp(0.3, 3),
              pluck(3, time=1.5, force=0.5)]
    sc = _scene(events, 2.0)
    a, steps = render(sc, damped_velocity=1e-6)
    b, old = render(sc)
    c, _ = render(sc, skip_decayed=False)
    d = float(np.max(np.abs(a - c)))
    print(f"slept {old['slept'] / 44100:.2f} s -> {steps['slept'] / 44100:.2f} s, max |diff| "
          f"{d:.2e} m/s against no stop")
    assert old["slept"] == 0  # the creep keeps it above decay_velocity until its next note
    assert steps["slept"] > 0.5 * 44100
    assert d < TOLERANCE
    assert np.array_equal(b[:int(0.3 * 44100)], a[:int(0.3 * 44100)])


def test_a_string_at_rest_before_its_first_note_sleeps_exactly():
    """Nothing has moved it: it sleeps from the first test of the decay stop to its pluck and
    wakes with the kernel's schedules on the global grid, as if it had run (a hard slap against
    the frets: the collisions see the same steps)."""
    events = [pluck(5, time=0.0, force=15.0, style="slap", position=0.85),
              fret(6, 12, force=5.0), pluck(6, time=0.3, force=15.0, style="slap")]
    sc = _scene(events, 0.6)
    a, steps = render(sc)
    b, _ = render(sc, skip_decayed=False)
    assert steps["slept"] > 0.2 * 44100
    assert np.array_equal(a, b)


@pytest.mark.parametrize("song", ["gp/Demo v5.gp5", "gp/001_Funky_Guy.gp5"])
def test_corpus_songs_stay_within_the_tolerances(song):
    path = CORPUS / song
    if not path.exists():
        pytest.skip("the score corpus is missing (make test-data)")
    sc = song_scene(path, 6.0)
    a, steps = render(sc)
    b, _ = render(sc, steady_runs=False)
    c, _ = render(sc, skip_decayed=False)
    e, _ = render(sc, damper_bound=False)
    assert np.array_equal(a, b)
    assert np.array_equal(a, e)
    assert float(np.max(np.abs(a - c))) < TOLERANCE
    assert steps["general"] < 0.05 * steps["all"], steps
