"""Calibrated fret interpolants (engine/fd/intonation.py): the held-note model against rendered
notes, and fretted notes in tune on a coarse grid."""

import math
import subprocess
import sys

import numpy as np
import pytest

import engine
from engine.analysis import cents, decay_db_per_s, spectrum_peak
from engine.fd.controls import stopped_frets, string_controls
from engine.fd.intonation import (
    DECAY_TOLERANCE_DB_S,
    REFERENCE_H_M,
    SEAT_MARGIN,
    TOLERANCE_CENTS,
    fret_calibration,
    fret_shift,
    held_note,
    press_force,
    reference_model,
    seating_force,
)
from engine.fd.string import geometry, tune
from engine.fd.voice import string_model
from engine.options import QUALITY, Quality, RenderOptions
from engine.performance import events_on, finger_x_m
from engine.scene import Fret, Scene
from engine.testing.measure import holds, resting_share
from engine.testing.scenes import SR, fret, pluck, scene


def _string(preset, s, rate=SR):
    return tune(preset.strings[s - 1], preset.string_length_m(s), rate)


def _standard_string(preset, s):
    """String s as the default quality ('standard') grids it when a finger touches it."""
    return string_model(preset, s, [Fret(time=0.0, string=s, fret=1)], SR, QUALITY["standard"],
                        RenderOptions())[1]


def _note(s, q, steel, **opts):
    """Fret q on string s, plucked (benchmarks.intonation's scene): cents from 12-TET, and the
    decay of the fundamental in dB/s."""
    sc = {**scene([fret(s, q), pluck(s, time=0.05, force=1.0)], duration=1.2),
          "output": {"body": "none"}}
    audio = engine.render(sc, options=RenderOptions(**opts))
    target = steel.strings[s - 1].frequency_hz * 2 ** (q / 12)
    f = spectrum_peak(audio[int(0.2 * SR):], SR, target, 0.08)
    return float(cents(f, target)), decay_db_per_s(audio, SR, f)


def _pitch(s, q, steel, **opts):
    return _note(s, q, steel, **opts)[0]


@pytest.mark.parametrize("q", [1, 7, 11])
def test_the_model_predicts_how_the_grid_moves_a_fretted_note(steel, q):
    """String 1 at 1x (h = 10 mm) and at 2x, frets left where they are: the rendered pitch
    difference between the two grids is the model's, to half a cent (several cents apart)."""
    target = steel.strings[0].frequency_hz * 2 ** (q / 12)
    coarse = held_note(_string(steel, 1), steel, q, target)
    fine = held_note(_string(steel, 1, 2 * SR), steel, q, target)
    model = 1200 * math.log2(coarse.frequency_hz / fine.frequency_hz)
    rendered = (_pitch(1, q, steel, oversample=1, calibrate_frets=False)
                - _pitch(1, q, steel, oversample=2, calibrate_frets=False))
    assert abs(model - rendered) <= 0.5, (model, rendered)


@pytest.mark.parametrize("q", [7, 11])
def test_the_model_predicts_how_the_grid_shortens_a_fretted_note(steel, q):
    """The same notes' decay: on the coarse grid more of the sounding string reaches the finger's
    contact damping.  The rendered difference (tens of dB/s) is the model's to half a dB/s."""
    target = steel.strings[0].frequency_hz * 2 ** (q / 12)
    model = (held_note(_string(steel, 1), steel, q, target).decay_db_s
             - held_note(_string(steel, 1, 2 * SR), steel, q, target).decay_db_s)
    rendered = (_note(1, q, steel, oversample=1, calibrate_frets=False)[1]
                - _note(1, q, steel, oversample=2, calibrate_frets=False)[1])
    assert model < -10.0 and abs(model - rendered) <= 0.5, (model, rendered)


@pytest.mark.parametrize("q", [1, 7, 11])
def test_calibrated_frets_put_a_coarse_grid_in_tune(steel, q):
    """At the sample rate (the draft level's grid) string 1's fretted notes are off by more than
    the engine's 5 cents; with the frets calibrated they are within it."""
    draft = QUALITY["draft"]
    raw = _pitch(1, q, steel, quality=draft, calibrate_frets=False)
    calibrated = _pitch(1, q, steel, quality=draft)
    assert abs(raw) > 5.0 and abs(calibrated) <= 5.0, (raw, calibrated)


def test_a_calibrated_fret_gives_the_fine_grids_note_in_the_model(steel):
    m = _string(steel, 2)
    fine = reference_model(m)
    assert fine.h <= 1.5e-3 < m.h
    for q in (2, 5, 12):
        target = steel.strings[1].frequency_hz * 2 ** (q / 12)
        d = fret_shift(m, steel, q)
        assert 0.0 < abs(d) <= 0.5 * m.h
        got = held_note(m, steel, q, target, fret_x=float(steel.fret_x_m(q, m.spec)) + d,
                        finger_x=finger_x_m(steel, q, m.spec) + d).frequency_hz
        want = held_note(fine, steel, q, target).frequency_hz
        assert abs(1200 * math.log2(got / want)) <= TOLERANCE_CENTS


@pytest.mark.parametrize("s, q", [(1, 10), (4, 10)])
def test_a_calibrated_finger_gives_the_fine_grids_decay_in_the_model(steel, s, q):
    """On the standard grid string 1's fret 10 and string 4's die 6-15 dB/s faster than on the
    fine grid in the model; with the finger's damping calibrated, within the tolerance.  Above the
    finger's resonance (318 Hz, string 1) less damping drains the note less; near it (string 4,
    262 Hz) the finger rides the string and more damping holds it still: the calibration goes
    both ways."""
    m = _standard_string(steel, s)
    target = steel.strings[s - 1].frequency_hz * 2 ** (q / 12)
    want = held_note(reference_model(m), steel, q, target)
    cal = fret_calibration(m, steel, q)
    x0, xf = float(steel.fret_x_m(q, m.spec)) + cal.shift_m, finger_x_m(steel, q, m.spec) + cal.shift_m
    raw = held_note(m, steel, q, target, fret_x=x0, finger_x=xf)
    got = held_note(m, steel, q, target, fret_x=x0, finger_x=xf, damping=cal.damping_n_s_m)
    assert raw.decay_db_s - want.decay_db_s < -5.0
    assert abs(got.decay_db_s - want.decay_db_s) <= DECAY_TOLERANCE_DB_S
    assert abs(1200 * math.log2(got.frequency_hz / want.frequency_hz)) <= TOLERANCE_CENTS
    r0 = steel.finger.damping_n_s_m
    assert cal.damping_n_s_m < r0 if target > 318.0 else cal.damping_n_s_m > r0


@pytest.mark.parametrize("s, q", [(1, 10), (4, 10)])
def test_fretted_notes_at_standard_sustain_as_on_the_fine_grid(steel, s, q):
    """Rendered: the fundamental's decay at the default quality against the same note on the fine
    grid (h <= 1.5 mm, frets uncalibrated): more than 4 dB/s faster with the frets calibrated for
    pitch alone, within 1 dB/s with the finger's damping calibrated too; the pitch stays."""
    fine = _note(s, q, steel, quality=Quality(max_h_m=REFERENCE_H_M, max_oversample=16))
    pitch_only = _note(s, q, steel, calibrate_damping=False)
    both = _note(s, q, steel)
    assert pitch_only[1] - fine[1] < -4.0, (pitch_only, fine)
    assert abs(both[1] - fine[1]) <= 1.0, (both, fine)
    assert abs(both[0] - pitch_only[0]) <= 0.5, (both, pitch_only)


def test_a_shift_moves_that_frets_interpolant_only(steel):
    m = _string(steel, 1)
    plain = geometry(m, steel, [0.9])
    moved = geometry(m, steel, [0.9], fret_shifts={5: -0.3 * m.h})
    x5 = float(steel.fret_x_m(5, m.spec)) - 0.3 * m.h
    p, w0, w1 = plain.fret_p.copy(), plain.fret_w0.copy(), plain.fret_w1.copy()
    assert moved.fret_p[4] * m.h - m.h + moved.fret_w1[4] * m.h == pytest.approx(x5)
    p[4], w0[4], w1[4] = moved.fret_p[4], moved.fret_w0[4], moved.fret_w1[4]
    assert np.array_equal(p, moved.fret_p) and np.array_equal(w0, moved.fret_w0)
    assert np.array_equal(w1, moved.fret_w1)
    assert np.array_equal(plain.fret_m0, moved.fret_m0)  # the heights stay


def test_the_stopped_frets_are_calibrated_and_their_fingers_move_with_them(steel):
    sc = Scene.model_validate({"duration": 1.0, "events": [
        {"type": "fret", "time": 0.0, "string": 2, "fret": 0},
        {"type": "fret", "time": 0.1, "string": 2, "fret": 9},
        {"type": "slide", "time": 0.2, "string": 2, "from_fret": 7, "to_fret": 3,
         "duration": 0.1},
        {"type": "tap", "time": 0.5, "string": 2, "fret": 12}]})
    events = events_on(sc, 6, 2)
    assert stopped_frets(events) == (3, 7, 9, 12)
    m = _string(steel, 2)
    plain = string_controls(events, steel, 2, m.h, m.n, SR, 1.0, lambda c: 1.0).arrays
    moved = string_controls(events, steel, 2, m.h, m.n, SR, 1.0, lambda c: 1.0,
                            {7: -1e-3, 9: 2e-3}).arrays
    # slots: fret 9, the slide 7 -> 3, the tap at 12
    assert np.allclose(moved.fs_x0 - plain.fs_x0, [2e-3, -1e-3, 0.0])
    assert np.allclose(moved.fs_x1 - plain.fs_x1, [2e-3, 0.0, 0.0])


def test_the_shifts_are_the_same_in_every_process(steel):
    """ARPACK starts from a random vector unless given one: the audio would differ in its last bits
    between the service's workers."""
    code = ("from engine.fd.intonation import fret_shift; from engine.presets import get_preset; "
            "from engine.fd.string import tune; p = get_preset('steel-acoustic'); "
            "print(repr(fret_shift(tune(p.strings[0], p.string_length_m(1), 44100), p, 5)))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == repr(fret_shift(_string(steel, 1), steel, 5))


def _holds(s, q, force, pluck_n=1.0):
    """benchmarks/seating.py's criterion (``engine.testing.measure.holds``): after the pluck the
    string rests on fret q (its rigid constraint active) at no fewer than 95 % of the checks."""
    return holds("steel-acoustic", "standard", s, q, force, pluck_n)


@pytest.mark.parametrize("s,q", [(1, 17), (3, 2), (3, 7), (6, 5)])
def test_the_seating_force_is_where_a_pressed_string_starts_to_hold(steel, s, q):
    """Below the static force the string cannot rest on its fret; with SEAT_MARGIN times it, it
    does.  (String 3 fret 7 is the tap of API.md's example scene, whose 0.9 N is below the 1.7 N
    it takes; at fret 2 the pressed string leaves the fret behind, next to the nut.)"""
    static = seating_force(_standard_string(steel, s), steel, q)
    assert 1.0 < static < 3.0
    assert not _holds(s, q, 0.9 * static)
    assert _holds(s, q, SEAT_MARGIN * static)


def test_a_finger_with_no_force_of_its_own_holds_the_high_frets(steel):
    """The preset's 3 N cannot hold string 3 at fret 19 (the action is highest there); a fret
    event with no force presses with SEAT_MARGIN times the seating force where that is more."""
    m = _standard_string(steel, 3)
    assert steel.finger.press_force_n < seating_force(m, steel, 19)
    assert press_force(m, steel, 19) == pytest.approx(SEAT_MARGIN * seating_force(m, steel, 19))
    assert press_force(m, steel, 5) == steel.finger.press_force_n
    assert not _holds(3, 19, steel.finger.press_force_n)
    assert _holds(3, 19, None)  # the default force seats the string on its fret
    no_force = {"type": "fret", "time": 0.0, "string": 3, "fret": 19}
    sc = scene([no_force, pluck(3, time=0.05, force=1.0)], duration=1.0)
    audio = engine.render(sc)
    target = steel.strings[2].frequency_hz * 2 ** (19 / 12)
    f = spectrum_peak(audio[int(0.2 * SR):], SR, target, 0.08)
    assert abs(float(cents(f, target))) <= 10.0  # fret 19's note, which 3 N does not hold


def test_a_slide_presses_with_the_largest_default_force_of_the_frets_it_crosses(steel):
    sc = Scene.model_validate({"duration": 1.0, "events": [
        {"type": "slide", "time": 0.1, "string": 3, "from_fret": 12, "to_fret": 19,
         "duration": 0.2},
        {"type": "fret", "time": 0.5, "string": 3, "fret": 12, "force": 2.5}]})
    events = events_on(sc, 6, 3)
    m = _standard_string(steel, 3)
    ctl = string_controls(events, steel, 3, m.h, m.n, SR, 1.0, lambda c: 1.0, None,
                          lambda q: press_force(m, steel, q)).arrays
    assert ctl.fs_force[0] == max(press_force(m, steel, q) for q in range(12, 20))
    assert ctl.fs_force[1] == 2.5  # a force the scene gives is the force


def test_a_bent_string_stays_on_its_fret(steel):
    """A bend raises the tension, and with it the force that holds the string on its fret: at
    fret 12 of string 3 a three-semitone bend lifts the string off the fret under the preset's
    3 N; a finger with no force of its own presses for the bent tension and holds it."""
    bend = ({"type": "bend", "time": 0.2, "string": 3, "semitones": 3.0, "duration": 0.3},)

    def share(force):
        return resting_share("steel-acoustic", "standard", 3, 12, force, 1.0, bend, start=0.6,
                             duration=1.5)

    assert share(steel.finger.press_force_n) < 0.5
    assert share(None) >= 0.95
