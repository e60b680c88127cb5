"""Articulations, measured on rendered audio (issue: the playable guitar)."""

import numpy as np
import pytest

import engine
from engine.analysis import band_level_db, cents, level_db, pitch_track, spectrum_peak
from engine.guitar import RenderOptions, prepare
from engine.scene import Scene

from .conftest import SR, fret, pluck, scene

STEEL = engine.get_preset("steel-acoustic")


def _render(events, duration, **extra):
    r = engine.render(scene(events, duration=duration, **extra), diagnostics=True)
    assert np.isfinite(r.audio).all()
    assert r.energy_error < 1e-11  # every articulation keeps the balance
    return r.audio


def _note(string, q):
    return STEEL.strings[string - 1].frequency_hz * 2 ** (q / 12)


def _pitch(audio, t0, t1, f):
    return float(cents(spectrum_peak(audio[int(t0 * SR):int(t1 * SR)], SR, f, 0.08), f))


def test_bend_two_semitones_holds_the_target_pitch():
    a = _render([pluck(2, force=2.0), {"type": "bend", "time": 0.2, "string": 2,
                                        "semitones": 2.0, "duration": 0.15}], 1.2)
    assert abs(_pitch(a, 0.5, 1.1, _note(2, 2))) <= 10.0


def test_bend_returns_after_release():
    a = _render([pluck(2, force=2.0), {"type": "bend", "time": 0.1, "string": 2,
                                        "semitones": 1.0, "duration": 0.1, "release": 0.4}], 1.4)
    assert abs(_pitch(a, 0.2, 0.4, _note(2, 1))) <= 10.0
    assert abs(_pitch(a, 0.7, 1.4, _note(2, 0))) <= 10.0


def test_vibrato_rate_and_depth():
    depth, rate = 30.0, 5.0
    a = _render([pluck(1, force=1.0), {"type": "vibrato", "time": 0.3, "string": 1,
                                        "depth_cents": depth, "rate_hz": rate,
                                        "duration": 1.5}], 2.0)
    t, f = pitch_track(a, SR, _note(1, 0))
    c = cents(f[(t > 0.5) & (t < 1.7)], _note(1, 0))
    spec = np.abs(np.fft.rfft((c - c.mean()) * np.hanning(len(c)), 8 * len(c)))
    measured_rate = np.fft.rfftfreq(8 * len(c), t[1] - t[0])[np.argmax(spec)]
    measured_depth = (np.percentile(c, 98) - np.percentile(c, 2)) / 2
    assert measured_rate == pytest.approx(rate, rel=0.05)
    assert measured_depth == pytest.approx(depth, rel=0.2)


def test_slide_from_5_to_7_lands_on_fret_7():
    a = _render([fret(3, 5), pluck(3, time=0.05), {"type": "slide", "time": 0.4, "string": 3,
                                                     "from_fret": 5, "to_fret": 7,
                                                     "duration": 0.15}], 1.5)
    assert abs(_pitch(a, 0.2, 0.4, _note(3, 5))) <= 10.0
    assert abs(_pitch(a, 0.7, 1.5, _note(3, 7))) <= 10.0


def test_hammer_on_5_to_7_and_pull_off_back_to_5():
    hammer = _render([fret(3, 5), pluck(3, time=0.05),
                      {"type": "hammer_on", "time": 0.4, "string": 3, "fret": 7}], 1.5)
    assert abs(_pitch(hammer, 0.6, 1.5, _note(3, 7))) <= 10.0
    pull = _render([fret(3, 5), {"type": "hammer_on", "time": 0.0, "string": 3, "fret": 7},
                    pluck(3, time=0.05), {"type": "pull_off", "time": 0.4, "string": 3,
                                           "fret": 7}], 1.5)
    assert abs(_pitch(pull, 0.15, 0.4, _note(3, 7))) <= 10.0
    assert abs(_pitch(pull, 0.6, 1.5, _note(3, 5))) <= 10.0


@pytest.mark.parametrize("q,partial", [(12, 2), (7, 3)])
def test_natural_harmonics(q, partial):
    """Touch at fret 12: the fundamental >= 20 dB below the octave; at fret 7 the third partial
    dominates."""
    a = _render([{"type": "harmonic", "time": 0.0, "string": 1, "fret": q, "release": 0.3},
                 pluck(1, time=0.02, force=2.0, position=0.85)], 1.2)[int(0.4 * SR):]
    f0 = _note(1, 0)
    levels = {n: band_level_db(a, SR, n * f0) for n in range(1, 6)}
    assert max(levels, key=levels.get) == partial, levels
    if q == 12:
        assert levels[1] <= levels[2] - 20.0, levels


def test_palm_mute_shortens_the_decay():
    open_ = _render([pluck(1, force=2.0)], 1.0)
    muted = _render([{"type": "mute", "time": 0.0, "string": 1}, pluck(1, force=2.0)], 1.0)
    late = slice(int(0.5 * SR), int(0.6 * SR))
    assert level_db(muted[late]) <= level_db(open_[late]) - 20.0


def test_mute_without_a_string_mutes_every_string():
    sc = Scene.model_validate(scene([{"type": "mute", "time": 0.0}, pluck(6)], duration=0.1))
    eng = prepare(sc)
    assert [v.index for v in eng.voices] == list(range(1, 7))
    assert all(len(v.ctl.arrays.dp_on) == 1 for v in eng.voices)


def test_strum_down_plucks_low_to_high():
    sc = Scene.model_validate(scene([{"type": "strum", "time": 0.0, "spread": 0.05}],
                                    duration=0.1))
    eng = prepare(sc)
    starts = {v.index: v.ctl.arrays.pl_start[0] / v.oversample for v in eng.voices}
    assert sorted(starts, key=starts.get) == [6, 5, 4, 3, 2, 1]


def test_pluck_styles_change_the_excitation():
    styles = {}
    for style in ("finger", "pick", "slap", "pop"):
        sc = Scene.model_validate(scene([pluck(1, style=style)], duration=0.05))
        styles[style] = prepare(sc).voices[0].ctl.arrays
    assert styles["pick"].pl_len[0] < styles["finger"].pl_len[0] < styles["pop"].pl_len[0]
    assert styles["slap"].pl_amp[0] < 0 < styles["finger"].pl_amp[0]


def test_dead_note_is_short():
    """A finger resting without pressing: the note dies fast."""
    fretted = _render([fret(3, 5), pluck(3, time=0.05)], 0.8)
    dead = _render([fret(3, 5, force=0.05), pluck(3, time=0.05)], 0.8)
    late = slice(int(0.5 * SR), int(0.6 * SR))
    assert level_db(dead[late]) <= level_db(fretted[late]) - 20.0


def test_bass_slap_rattles_against_the_frets():
    """Slap and pop on the bass drive the string into the frets: with the frets switched off the
    sound is a different one (the rattle is the difference)."""
    evs = [pluck(4, force=10.0, style="slap", position=0.85),
           pluck(1, time=0.2, force=10.0, style="pop", position=0.85)]
    sc = scene(evs, duration=0.5, guitar={"preset": "bass"})
    with_frets = engine.render(sc)
    without = engine.render(sc, options=RenderOptions(frets=False))
    err = np.linalg.norm(with_frets - without) / np.linalg.norm(without)
    assert err > 0.1


def test_stereo_pans_low_strings_left():
    a = engine.render(scene([pluck(6)], duration=0.3, output={"channels": 2, "body": "none"}))
    assert a.shape[1] == 2
    assert np.abs(a[:, 0]).max() > 2 * np.abs(a[:, 1]).max()


def test_body_and_user_impulse_response():
    evs = [pluck(1)]
    dry = engine.render(scene(evs, duration=0.3, output={"normalize": False, "body": "none"}))
    body = engine.render(scene(evs, duration=0.3, output={"normalize": False,
                                                          "body": "acoustic"}))
    assert not np.allclose(dry, body)
    ir = np.zeros(100)
    ir[10] = 0.5  # a delay and a gain
    wet = engine.render(scene(evs, duration=0.3, output={"normalize": False}),
                        impulse_response=ir)
    np.testing.assert_allclose(wet[10:], 0.5 * dry[:-10], atol=1e-12)


@pytest.mark.parametrize("preset", ["electric", "bass"])
def test_new_presets_render_in_tune(preset):
    p = engine.get_preset(preset)
    a = _render([pluck(p.n_strings, force=1.0)], 1.0, guitar={"preset": preset})
    f = p.strings[-1].frequency_hz
    assert abs(_pitch(a, 0.1, 1.0, f)) < 1.0
