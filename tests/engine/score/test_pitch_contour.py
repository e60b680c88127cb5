"""The labels' pitch contours against the audio: a pitch tracker (librosa's YIN) run on a rendered
string that is bent, released and shaken with vibrato agrees with the contour within 10 cents
wherever the note is loud enough to track, in both string models."""

from __future__ import annotations

import numpy as np
import pytest

import engine
from engine.score import scene_labels

HOP = 0.01
SCENE = {"duration": 3.0, "events": [
    {"type": "fret", "time": 0.0, "string": 3, "fret": 5},
    {"type": "pluck", "time": 0.05, "string": 3, "force": 3.0},
    {"type": "bend", "time": 0.3, "string": 3, "semitones": 2.0, "duration": 0.2, "release": 0.9},
    {"type": "damp", "time": 1.4, "string": 3},
    {"type": "fret", "time": 1.45, "string": 3, "fret": 7},
    {"type": "pluck", "time": 1.5, "string": 3, "force": 3.0},
    {"type": "vibrato", "time": 1.6, "string": 3, "depth_cents": 40.0, "rate_hz": 5.0,
     "duration": 1.0},
    {"type": "damp", "time": 2.8, "string": 3},
]}


def _contour(jam) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    (ann,) = [a for a in jam.search(namespace="pitch_contour") if a.sandbox["string"] == 3]
    t = np.array([o.time for o in ann.data])
    f = np.array([o.value["frequency"] for o in ann.data])
    v = np.array([o.value["voiced"] for o in ann.data])
    return t, f, v


def test_contour_follows_the_planned_pitch():
    jam = scene_labels(SCENE)
    jam.validate()
    t, f, v = _contour(jam)
    c4 = 440.0 * 2 ** ((60 - 69) / 12)
    at = {round(x, 2): (y, w) for x, y, w in zip(t, f, v, strict=True)}
    assert at[0.1] == (pytest.approx(c4, rel=1e-4), True)  # G3 + 5
    assert at[0.6][0] == pytest.approx(c4 * 2 ** (2 / 12), rel=1e-4)  # bent a whole tone
    assert at[1.2][0] == pytest.approx(c4, rel=1e-4)  # released
    assert at[1.4] == (pytest.approx(c4, rel=1e-4), False)  # damped: unvoiced, then nothing
    assert 1.43 not in at
    vib = np.array([at[round(x, 2)][0] for x in np.arange(1.7, 2.5, HOP)])
    cents = 1200 * np.log2(vib / (c4 * 2 ** (2 / 12)))
    assert cents.max() == pytest.approx(40, abs=1) and cents.min() == pytest.approx(-40, abs=1)
    # each frame names its note in the string's note_midi data
    (notes,) = [a for a in jam.search(namespace="note_midi") if a.sandbox["string"] == 3]
    assert len(notes.data) == 2
    assert {o.value["index"] for o in jam.search(namespace="pitch_contour")[3].data} == {0, 1}


@pytest.mark.parametrize("model", ["waveguide", "fdtd"])
def test_a_pitch_tracker_agrees_within_10_cents(model):
    librosa = pytest.importorskip("librosa")
    scene = {**SCENE, "model": model}
    rate = 44100
    x = np.asarray(engine.render(scene), float)  # mono
    hop = round(HOP * rate)
    f0 = librosa.yin(x, fmin=150, fmax=600, sr=rate, frame_length=2048, hop_length=hop,
                     center=True)
    rms = librosa.feature.rms(y=x, frame_length=1024, hop_length=hop, center=True)[0]
    t, f, v = _contour(scene_labels(scene))
    k = np.round(t / HOP).astype(int)
    # frames whose window (2048 samples, 23 ms either side) holds neither an attack nor a damp
    edges = np.array([0.05, 1.4, 1.5, 2.8])
    clear = np.min(np.abs(t[:, None] - edges[None, :]), axis=1) > 0.03
    loud = rms[k] > 10 ** (-30 / 20) * rms.max()
    ok = v & loud & clear
    assert ok.sum() > 150  # most of the 2.5 s the notes sound
    err = 1200 * np.log2(f0[k[ok]] / f[ok])
    assert np.max(np.abs(err)) < 10.0, (model, np.round(err, 1))
