"""Each of the waveguide's skips is bounded: the output with the skip against the output without
it (``tools.wg_skips`` prints the same on whole songs and the digest's scenes).

* steady runs (``kernel._steady``): dampers in contact and released junctions leaking away
  stepped in the plain runs: exact, not one sample differs;
* the damper bound (``kernel._reach``): the collision points beside a damper in contact bounded
  by the string's energy, not all tested every sample: exact;
* the decay stop between events (``kernel._may_sleep``, ``voice._sleep``): a still string sleeps
  until its next event, its state kept: the output differs by less than -140 dB of full scale
  after the fixed gain (``tools.wg_skips.TOLERANCE``), and a string at rest before its first note
  not at all;
* the damped rest (``kernel._settle``), a rule of the model that lets damped strings sleep: the
  stop around it is exact, and up to the string's next note it drops less than the stop's
  tolerance."""

from __future__ import annotations

import numpy as np
import pytest

import engine
from engine import models, waveguide
from engine.testing.scenes import fret, pluck, scene
from engine.waveguide import WaveguideOptions
from tools.song_scene import song_scene
from tools.wg_skips import CORPUS, TOLERANCE, render


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
    """With the damped rest and without it (the dampers then held to each string's next note)."""
    sc = _scene(MUSIC, 2.0)
    for rest in (WaveguideOptions.damped_velocity, 0.0):
        a, steps = render(sc, damped_velocity=rest)
        b, off = render(sc, steady_runs=False, damped_velocity=rest)
        assert np.array_equal(a, b)
        assert steps["general"] < 0.05 * steps["all"], steps
    # the damps, the palm, the touch and the dead note held most steps in the general step
    assert off["general"] > 0.3 * off["all"], off


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


def test_a_damped_string_comes_to_rest_and_sleeps_exactly():
    """A fretted note ended by a damp falls silent within tens of milliseconds, then creeps back
    to its rest line for seconds (the dampers' leak passes what is slower than
    ``pluck.LEAK_HZ``), its points a little faster than ``decay_velocity``, its pickup far
    slower: without the damped rest it runs to its next note.  With it the hand holds the string
    still once its pickup is below ``decay_velocity`` (``kernel._settle``), and it sleeps.  The
    rest is a rule of the model, there with the decay stop off too, so the stop around it is
    exact, even where the next note (a 2 N pluck on the fretted string: collisions) meets the
    string; up to the next note the rest drops less than the decay stop's tolerance."""
    events = [fret(3, 5), pluck(3, time=0.01, force=2.0), _damp(0.3, 3),
              fret(3, 5, time=1.5), pluck(3, time=1.5, force=2.0)]
    sc = _scene(events, 2.0)
    a, steps = render(sc)
    b, _ = render(sc, skip_decayed=False)
    c, creep = render(sc, damped_velocity=0.0)
    damp, note = int(0.3 * 44100), int(1.5 * 44100)
    d = float(np.max(np.abs(a[:note] - c[:note])))
    print(f"rests {steps['rests']}, slept {creep['slept'] / 44100:.2f} s -> "
          f"{steps['slept'] / 44100:.2f} s; max |diff| from the creep before the next note "
          f"{d:.2e} m/s")
    assert creep["slept"] == 0  # the creep keeps it above decay_velocity until its next note
    assert steps["rests"] >= 1
    assert steps["slept"] > 0.5 * 44100
    assert np.array_equal(a, b)
    assert np.array_equal(a[:damp], c[:damp])
    assert d < TOLERANCE


def test_the_damped_rest_waits_for_the_note_to_die():
    """The hand holds the string only once its pickups are below ``decay_velocity``: a damped
    note's last 20 ms before its rest are quieter than -140 dB of full scale, the note before
    the damp rang loud, and a palm resting on a ringing string (a mute at amount 0.3: the note
    goes on, muffled) never holds it before the scene's end."""
    sc = _scene([fret(3, 5), pluck(3, time=0.01, force=2.0), _damp(0.3, 3)], 1.5)
    inst = waveguide.prepare(sc, statics=models.PRESSED_STRING)
    out, rested = [], None
    for y in inst.blocks(256):
        out.append(y)
        if rested is None and int(inst.voices[0].st["rests"]) > 0:
            rested = inst.frame
    y = np.concatenate(out)
    assert rested is not None and rested > int(0.3 * 44100)
    tail = y[max(rested - 256 - int(0.02 * 44100), 0):rested - 256]
    print(f"rested at {rested / 44100:.3f} s; the 20 ms before: {np.max(np.abs(tail)):.2e} "
          f"(peak {np.max(np.abs(y)):.2f})")
    assert np.max(np.abs(tail)) < TOLERANCE < 1e-3 * np.max(np.abs(y))
    muted = _scene([{"type": "mute", "time": 0.0, "string": 4, "amount": 0.3},
                    pluck(4, time=0.01, force=2.0)], 2.0)
    _, steps = render(muted)
    assert steps["rests"] == 0


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
