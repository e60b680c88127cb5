"""Articulations, measured on rendered audio (issue: the playable guitar)."""

import numpy as np
import pytest

import engine
from engine.fd.instrument import prepare
from engine.options import RenderOptions
from engine.scene import Scene
from engine.testing import articulations as art
from engine.testing.scenes import pluck, scene

# Each target is measured by engine.testing.articulations; benchmarks/articulations.py prints the
# same figures as a table.
LIMIT_CENTS = 10.0
LIMIT_BALANCE = 1e-11  # every articulation keeps the energy balance


def test_bend_two_semitones_holds_the_target_pitch():
    m = art.bend()
    assert abs(m["held"]) <= LIMIT_CENTS and m["energy"] < LIMIT_BALANCE


def test_bend_returns_after_release():
    m = art.bend_release()
    assert abs(m["held"]) <= LIMIT_CENTS and abs(m["released"]) <= LIMIT_CENTS
    assert m["energy"] < LIMIT_BALANCE


def test_vibrato_rate_and_depth():
    m = art.vibrato()
    assert m["rate_hz"] == pytest.approx(m["asked_rate_hz"], rel=0.05)
    assert m["depth_cents"] == pytest.approx(m["asked_depth_cents"], rel=0.2)
    assert m["energy"] < LIMIT_BALANCE


def test_slide_from_5_to_7_lands_on_fret_7():
    m = art.slide()
    assert abs(m["before"]) <= LIMIT_CENTS and abs(m["after"]) <= LIMIT_CENTS
    assert m["energy"] < LIMIT_BALANCE


def test_hammer_on_5_to_7_and_pull_off_back_to_5():
    h, p = art.hammer_on(), art.pull_off()
    assert abs(h["after"]) <= LIMIT_CENTS
    assert abs(p["before"]) <= LIMIT_CENTS and abs(p["after"]) <= LIMIT_CENTS
    assert max(h["energy"], p["energy"]) < LIMIT_BALANCE


@pytest.mark.parametrize("q,partial", [(12, 2), (7, 3)])
def test_natural_harmonics(q, partial):
    """Touch at fret 12: the fundamental >= 20 dB below the octave; at fret 7 the third partial
    dominates."""
    m = art.harmonic(q)
    levels = m["levels"]
    assert m["loudest"] == partial, levels
    if q == 12:
        assert levels[1] <= levels[2] - 20.0, levels
    assert m["energy"] < LIMIT_BALANCE


def test_palm_mute_shortens_the_decay():
    m = art.palm_mute()
    assert m["drop_db"] >= 20.0 and m["energy"] < LIMIT_BALANCE


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
    m = art.dead_note()
    assert m["drop_db"] >= 20.0 and m["energy"] < LIMIT_BALANCE


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
    r = engine.render(scene([pluck(p.n_strings, force=1.0)], 1.0, guitar={"preset": preset}),
                      diagnostics=True)
    f = p.strings[-1].frequency_hz
    assert abs(art.pitch(r.audio, 0.1, 1.0, f)) < 1.0
    assert r.energy_error < LIMIT_BALANCE
