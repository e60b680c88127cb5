"""Stems (engine/mix.py): each string's own signal, before pan, body and effects, at the mix's
gain.  They sum to the dry mix (the scene rendered with every body, pan and effect left out, mono),
through the bodies and pans they are the mix sample for sample, and a note's onset in its
string's stem is at the time the labels give it."""

from __future__ import annotations

import numpy as np
import pytest

import engine
from engine.output import Body, default_pan, pan_gains

MODELS = ("fdtd", "waveguide")
FULL_SCALE_TOL = 1e-6  # issue 36: stems sum to the dry mix within 1e-6 of full scale

# a steel-string acoustic (its body on) with a slide, a bend and a vibrato, panned as a whole;
# an electric bass with its strings spread; a classical with an effects chain and a fader
ACOUSTIC = {"name": "Lead", "guitar": {"preset": "steel-acoustic"}, "pan": -0.4, "gain_db": -3.0,
            "events": [{"type": "fret", "time": 0.0, "string": 3, "fret": 5},
                       {"type": "pluck", "time": 0.01, "string": 3, "force": 1.5},
                       {"type": "slide", "time": 0.08, "string": 3, "from_fret": 5,
                        "to_fret": 7, "duration": 0.04},
                       {"type": "fret", "time": 0.02, "string": 2, "fret": 8},
                       {"type": "pluck", "time": 0.03, "string": 2},
                       {"type": "bend", "time": 0.1, "string": 2, "semitones": 1.0,
                        "duration": 0.05},
                       {"type": "pluck", "time": 0.05, "string": 6, "force": 2.5}]}
BASS = {"name": "Bass", "guitar": {"preset": "bass"},
        "events": [{"type": "pluck", "time": 0.02, "string": 4, "force": 3.0},
                   {"type": "vibrato", "time": 0.06, "string": 4, "depth_cents": 30.0,
                    "rate_hz": 6.0, "duration": 0.1}]}
CLASSICAL = {"guitar": {"preset": "nylon-classical"}, "gain_db": 4.0,
             "effects": [{"type": "drive", "gain_db": 12.0}, {"type": "delay", "delay_s": 0.05}],
             "events": [{"type": "strum", "time": 0.04, "force": 1.0}]}


def scene(model: str, channels: int = 2, normalize: bool = False, duration: float = 0.25) -> dict:
    return {"duration": duration, "model": model,
            "output": {"channels": channels, "normalize": normalize},
            "tracks": [ACOUSTIC, BASS, CLASSICAL]}


def dry(sc: dict) -> dict:
    """The scene with every body, pan and effect left out, mono: what the stems sum to."""
    return {**sc, "output": {**sc["output"], "channels": 1, "body": "none"},
            "tracks": [{**t, "effects": [], "pan": None} for t in sc["tracks"]]}


@pytest.mark.parametrize("model", MODELS)
@pytest.mark.parametrize("normalize", [False, True])
def test_stems_sum_to_the_dry_mix(model, normalize):
    sc = scene(model, normalize=normalize)
    res = engine.render_result(sc, stems=True)
    layout = [(s.track, s.name, s.string) for s in res.stem_layout]
    assert layout == ([(0, "Lead", s) for s in range(6, 0, -1)]
                      + [(1, "Bass", s) for s in range(4, 0, -1)]
                      + [(2, "", s) for s in range(6, 0, -1)])
    assert res.stems.shape == (len(res.audio), 16)
    reference = engine.render(dry({**sc, "output": {**sc["output"], "normalize": False}}))
    # the stems carry the mix's gain: the fixed gain, or the one that puts the mix's peak at -1 dBFS
    expected = reference / engine.FIXED_GAIN * res.gain
    err = np.max(np.abs(res.stems.sum(axis=1) - expected))
    assert err < FULL_SCALE_TOL, err
    # every string played has a signal of its own, every other string is silent
    played = {(0, 6), (0, 3), (0, 2), (1, 4)} | {(2, s) for s in range(1, 7)}
    peaks = np.max(np.abs(res.stems), axis=0)
    for (track, _, string), peak in zip(layout, peaks, strict=True):
        if (track, string) in played:
            assert peak > 1e-3 * peaks.max(), (track, string)
        else:
            assert peak == 0.0, (track, string)


@pytest.mark.parametrize("model", MODELS)
def test_stems_through_the_bodies_and_pans_are_the_mix(model):
    """Without effects, each track's stems panned and through its body (the linear stages after
    them) add up to the stereo mix, sample for sample: they are aligned with it and taken before
    the body."""
    sc = scene(model)
    sc["tracks"] = [{**t, "effects": []} for t in sc["tracks"]]
    res = engine.render_result(sc, stems=True)
    mix = np.zeros_like(res.audio)
    for i, t in enumerate(sc["tracks"]):
        cols = [k for k, s in enumerate(res.stem_layout) if s.track == i]
        strings = [res.stem_layout[k].string for k in cols]
        preset = engine.get_preset(t["guitar"]["preset"])
        if t.get("pan") is not None:
            left, right = pan_gains(t["pan"])
            mono = res.stems[:, cols].sum(axis=1)
            wet = np.stack((left * mono, right * mono), axis=1)
        else:
            pans = [pan_gains(p) for p in default_pan(preset.n_strings)]
            wet = np.stack([sum(pans[s - 1][ch] * res.stems[:, k]
                                for k, s in zip(cols, strings, strict=True))
                            for ch in (0, 1)], axis=1)
        if preset.body != "none":
            body = Body(preset.body, float(res.sample_rate), 2)
            wet = body(wet)
        mix += wet
    assert np.max(np.abs(mix - res.audio)) < 1e-9
    assert np.max(np.abs(res.audio)) > 0.05


@pytest.mark.parametrize("model", MODELS)
def test_stems_come_the_same_in_any_blocks(model):
    sc = scene(model)
    whole = engine.render_result(sc, stems=True)
    blocks = engine.blocks(sc, block_frames=1000, stems=True)
    assert blocks.stem_layout == whole.stem_layout
    mix, stems = zip(*blocks, strict=True)
    assert np.concatenate(mix).tobytes() == whole.audio.tobytes()
    assert np.concatenate(stems).tobytes() == whole.stems.tobytes()
    # the scene's own ``output.stems`` asks for them as the argument does
    asked = engine.render_result({**sc, "output": {**sc["output"], "stems": True}})
    assert asked.stems.tobytes() == whole.stems.tobytes()
    assert engine.render_result(sc).stems is None


@pytest.mark.parametrize("model", MODELS)
def test_an_onset_in_a_stem_is_where_the_labels_put_it(model):
    """Each note of the labels starts in its own string's stem at the labelled time (within the
    pluck's rise and its travel to the pickup, 2 ms), and before it the stem is silent: the
    labels' note_midi annotations are the stems' columns, in the same order."""
    guitar = [{"type": "pluck", "time": 0.03, "string": 6},
              {"type": "pluck", "time": 0.081, "string": 4, "force": 1.0},
              {"type": "pluck", "time": 0.1402, "string": 1, "style": "pick"},
              {"type": "tap", "time": 0.2113, "string": 2, "fret": 5, "force": 1.0}]
    bass = [{"type": "pluck", "time": 0.172, "string": 3, "force": 3.0}]
    sc = {"duration": 0.3, "model": model, "output": {"normalize": False},
          "tracks": [{"guitar": {"preset": "electric"}, "events": guitar},
                     {"guitar": {"preset": "bass"}, "events": bass, "gain_db": -6.0}]}
    res = engine.render_result(sc, stems=True)
    jam = engine.scene_labels(sc)
    notes = [a for a in jam.annotations if a.namespace == "note_midi"]
    assert len(notes) == len(res.stem_layout) == 10
    rate = res.sample_rate
    onsets = 0
    index = engine.stems_index(res.stem_layout, "wav", rate, res.gain)["stems"]
    for ann, stem, col, info in zip(notes, res.stem_layout, res.stems.T, index, strict=True):
        assert (ann.sandbox.track, ann.sandbox.string) == (stem.track, stem.string)
        assert info["track_name"] == ann.sandbox.track_name
        for obs in ann.data:
            onsets += 1
            peak = np.max(np.abs(col))
            at = int(np.argmax(np.abs(col) > 1e-3 * peak)) / rate
            assert obs.time - 0.5e-3 <= at <= obs.time + 2e-3, (stem, obs.time, at)
        if not ann.data:
            assert not np.any(col)
    assert onsets == 5


def test_stems_handed_on_block_by_block_are_the_held_ones():
    sc = scene("waveguide", normalize=True)
    held = engine.render_result(sc, stems=True)
    parts: list[np.ndarray] = []
    res = engine.render_result(sc, on_stems=parts.append)
    assert res.stems is None and res.stem_layout == held.stem_layout and res.gain == held.gain
    assert len(parts) > 1
    assert (np.concatenate(parts) * res.gain).tobytes() == held.stems.tobytes()


@pytest.mark.parametrize("model", MODELS)
def test_normalized_stems_never_clip(model):
    """Under ``normalize`` the one gain puts the loudest of the mix and the stems at -1 dBFS:
    here a string (the acoustic's A) peaks above the mix its body and pan soften, so the stems
    set the gain, and the mix is that much quieter than without stems."""
    sc = {"duration": 0.25, "model": model, "output": {"channels": 2},
          "tracks": [{"pan": -0.3, "events": [{"type": "pluck", "time": 0.01, "string": 3},
                                             {"type": "pluck", "time": 0.03, "string": 5}]}]}
    top = 10.0 ** (-1.0 / 20.0)
    res = engine.render_result(sc, stems=True)
    alone = engine.render_result(sc)
    loudest = max(np.max(np.abs(res.audio)), np.max(np.abs(res.stems)))
    assert loudest == pytest.approx(top, rel=1e-12)
    assert np.max(np.abs(res.stems)) > np.max(np.abs(res.audio))  # the case this is about
    assert np.max(np.abs(alone.audio)) == pytest.approx(top, rel=1e-12)
    np.testing.assert_allclose(res.audio, alone.audio * res.gain / alone.gain, rtol=0,
                               atol=1e-12)


def test_a_lone_guitar_s_stems_are_named_as_its_labels():
    sc = {"duration": 0.1, "events": [{"type": "pluck", "time": 0.0, "string": 1}]}
    ann = engine.scene_labels(sc).annotations[0]
    (first, *_) = engine.stems_index(engine.parse_scene(sc).stems(), "wav", 44100, 1.0)["stems"]
    assert (first["track"], first["track_name"], first["string"]) == (
        ann.sandbox.track, ann.sandbox.track_name, ann.sandbox.string)
