"""The public helpers the service uses: frame_count, tuned_tension, scene_warnings and warmup."""

import json
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

import engine
from engine.fd import instrument as guitar_module
from engine.fd.instrument import prepare
from engine.options import RenderOptions
from engine.scene import Scene
from engine.testing.scenes import fret, pluck

ROOT = Path(__file__).resolve().parents[2]


@pytest.mark.parametrize("rate", [22050, 44100, 48000, 96000])
@pytest.mark.parametrize("duration", [0.01, 1 / 30, 0.0123457, 0.05])
def test_frame_count_is_what_render_and_blocks_return(rate, duration):
    sc = {"duration": duration, "sample_rate": rate, "quality": "draft",
          "events": [pluck(1)], "output": {"normalize": False}}
    n = engine.frame_count(sc)
    assert isinstance(n, int)
    assert n == len(engine.render(sc))
    assert n == sum(len(b) for b in engine.blocks(sc, block_frames=97))


def test_frame_count_of_stereo_and_silent_scenes():
    stereo = {"duration": 0.02, "sample_rate": 48000, "events": [pluck(6)],
              "output": {"channels": 2}}
    assert engine.frame_count(stereo) == engine.render(stereo).shape[0] == 960
    silent = Scene(duration=1 / 3, sample_rate=48000)  # a Scene object is accepted too
    assert engine.frame_count(silent) == len(engine.render(silent)) == 16000


@pytest.mark.parametrize("preset", sorted(engine.PRESETS))
def test_tuned_tension_is_the_engines(preset):
    p = engine.get_preset(preset)
    for string in (1, p.n_strings):
        sc = Scene.model_validate({"duration": 0.01, "guitar": {"preset": preset},
                                   "events": [pluck(string)]})
        voice = prepare(sc, RenderOptions(oversample=1)).voices[0]
        assert voice.index == string
        assert engine.tuned_tension(preset, string) == voice.model.tension_n
        assert engine.tuned_tension(p, string, 44100) == voice.model.tension_n
        assert 20.0 < engine.tuned_tension(preset, string) < 300.0


def test_tuned_tension_rejects_a_missing_string():
    with pytest.raises(ValueError, match="outside"):
        engine.tuned_tension("bass", 5)
    with pytest.raises(KeyError):
        engine.tuned_tension("banjo", 1)


# Run in a fresh process, so that kernels compiled by other tests cannot hide a path warmup()
# misses: after warmup(), renders of every kind must add no signature to any numba dispatcher
# (a new signature is a compilation, or a cache load, during a real render).
_AFTER_WARMUP = r"""
import json, sys
import numpy as np
from numba.core.dispatcher import Dispatcher
import engine, engine.fd.kernels, engine.output

def signatures():
    out = {}
    for mod in (engine.fd.kernels, engine.output):
        for name, obj in vars(mod).items():
            if isinstance(obj, Dispatcher):
                out[mod.__name__ + "." + name] = sorted(str(s) for s in obj.signatures)
    return out

engine.warmup()
before = signatures()
for sc in json.loads(sys.argv[1]):
    engine.render(sc, diagnostics=True)
    engine.render(sc)
    for _ in engine.blocks(sc, block_frames=257):
        pass
engine.render(json.loads(sys.argv[1])[0], impulse_response=np.array([1.0, 0.5, 0.25]))
print(json.dumps({"before": before, "after": signatures()}))
"""

_EVERY_KIND = [
    {"duration": 0.02, "events": [fret(5, 3), pluck(5, time=0.001), fret(5, 0, time=0.01)]},
    {"duration": 0.02, "quality": "high", "guitar": {"preset": "bass"},
     "events": [fret(4, 5, release=0.01), pluck(4, style="pop"), pluck(1, style="slap"),
                {"type": "hammer_on", "time": 0.005, "string": 4, "fret": 7},
                {"type": "pull_off", "time": 0.012, "string": 4, "fret": 7}]},
    {"duration": 0.02, "sample_rate": 96000, "quality": "draft",
     "guitar": {"preset": "electric", "tuning": ["D4", "B3", "G3", "D3", "A2", "D2"]},
     "output": {"pickups": [{"position": 0.95}, {"position": 0.7, "gain": 0.3},
                            {"position": 0.5}], "body": "acoustic"},
     "events": [{"type": "strum", "time": 0.0, "direction": "up"},
                {"type": "slide", "time": 0.002, "string": 2, "from_fret": 7, "to_fret": 5,
                 "duration": 0.01},
                {"type": "tap", "time": 0.003, "string": 1, "fret": 12, "velocity": 2.0}]},
    {"duration": 0.02, "sample_rate": 22050, "guitar": {"preset": "nylon-classical"},
     "output": {"channels": 2, "pan": [0.5, 0.3, 0.1, -0.1, -0.3, -0.5], "normalize": False},
     "events": [{"type": "harmonic", "time": 0.0, "string": 4, "position": 0.25,
                 "release": 0.01}, pluck(4),
                {"type": "mute", "time": 0.0, "amount": 0.3, "release": 0.015}, pluck(5),
                {"type": "bend", "time": 0.0, "string": 2, "semitones": 2.0, "duration": 0.005,
                 "release": 0.01}, pluck(2),
                {"type": "vibrato", "time": 0.0, "string": 1, "depth_cents": 50, "rate_hz": 15,
                 "duration": 0.02}, pluck(1)]},
]


def test_warmup_leaves_nothing_to_compile():
    proc = subprocess.run([sys.executable, "-c", _AFTER_WARMUP, json.dumps(_EVERY_KIND)],
                          cwd=ROOT, capture_output=True, text=True, timeout=600, check=False)
    assert proc.returncode == 0, proc.stderr
    got = json.loads(proc.stdout.strip().splitlines()[-1])
    before, after = got["before"], got["after"]
    assert before["engine.fd.kernels.step_block"], "warmup() did not run the time-step kernel"
    assert before["engine.output.fir_decimate"], "warmup() did not run the decimator"
    assert before["engine.output._modal"], "warmup() did not run the body filter"
    assert after == before


def test_warmup_returns_its_time_and_its_scenes_sound():
    """warmup() returns the seconds it spent (not a constant: positive, and no more than the wall
    time around the call), and each of its scenes renders audible, finite audio, so that the
    paths it compiles are the paths a real scene takes."""
    t0 = time.perf_counter()
    took = engine.warmup()
    elapsed = time.perf_counter() - t0
    assert 0.0 < took <= elapsed
    for sc in engine.WARMUP_SCENES:
        audio = engine.render(sc, diagnostics=False)
        assert np.isfinite(audio).all() and np.max(np.abs(audio)) > 1e-6


API_EXAMPLE = {  # the scene of ../shared/API.md
    "duration": 2.0, "sample_rate": 44100, "guitar": {"preset": "steel-acoustic"},
    "events": [
        {"type": "fret", "time": 0.0, "string": 5, "fret": 3, "force": 2.0},
        {"type": "pluck", "time": 0.05, "string": 5, "position": 0.8, "force": 2.0,
         "duration": 0.001},
        {"type": "tap", "time": 1.0, "string": 3, "fret": 7, "force": 0.9}],
    "output": {"format": "wav"}, "diagnostics": False}


def test_scene_warnings_name_a_finger_too_light_to_seat_its_string():
    """API.md's tap presses 0.9 N where string 3 rests on fret 7 from about 1.7 N (the fret at
    2 N on string 5 at fret 3 is enough); the warning says so, and diagnostics carry the same
    list."""
    sc = engine.parse_scene(API_EXAMPLE)
    warnings = engine.scene_warnings(sc)
    assert len(warnings) == 1
    assert warnings[0].startswith("string 3: the tap at 1 s presses 0.9 N; holding the string on "
                                  "fret 7 takes about 2.3 N (it rests on the fret from 1.")
    short = {**API_EXAMPLE, "duration": 1.1}
    assert engine.render(short, diagnostics=True).warnings == warnings


def test_no_warning_for_a_firm_or_a_default_press_and_the_slides_worst_fret():
    events = [{"type": "fret", "time": 0.0, "string": 3, "fret": 19},  # default force: enough
              {"type": "fret", "time": 0.1, "string": 4, "fret": 7, "force": 3.0},
              {"type": "fret", "time": 0.2, "string": 4, "fret": 0, "force": 0.1},  # lifts
              {"type": "slide", "time": 0.3, "string": 2, "from_fret": 5, "to_fret": 19,
               "duration": 0.2, "force": 2.5},
              {"type": "hammer_on", "time": 0.6, "string": 1, "fret": 9, "force": 0.5}]
    warnings = engine.scene_warnings(engine.parse_scene({"duration": 1.0, "events": events}))
    assert len(warnings) == 2  # the slide (fret 19) and the hammer-on, in time order
    assert warnings[0].startswith("string 2: the slide at 0.3 s presses 2.5 N; holding the "
                                  "string on frets 5-19 takes about 3.")
    assert warnings[1].startswith("string 1: the hammer-on at 0.6 s presses 0.5 N")


def test_a_press_that_holds_the_string_at_rest_but_not_bent_is_warned_about():
    """3 N is enough for string 3 at fret 10 at rest; bent three semitones, the string needs
    more, and the warning says so."""
    fret10 = {"type": "fret", "time": 0.0, "string": 3, "fret": 10, "force": 3.0}
    bend = {"type": "bend", "time": 0.2, "string": 3, "semitones": 3.0, "duration": 0.3}
    assert engine.scene_warnings(engine.parse_scene({"duration": 1.0, "events": [fret10]})) == []
    bent = engine.parse_scene({"duration": 1.0, "events": [fret10, bend]})
    warned = engine.scene_warnings(bent)
    assert len(warned) == 1 and warned[0].startswith("string 3: the fret at 0 s presses 3 N")
    assert prepare(bent).warnings() == warned  # the voice keeps the bent tension


def test_render_result_carries_the_warnings_without_diagnostics_and_survives_their_failure(
        monkeypatch, caplog):
    """The service's workers take the warnings from ``render_result`` (no energy terms computed:
    ``energy_error`` is None).  Warnings are advice: if working them out fails, the audio still
    comes, without them, and the failure is logged."""
    light_tap = {"duration": 0.2, "events": [
        {"type": "tap", "time": 0.0, "string": 3, "fret": 7, "force": 0.9}]}
    result = engine.render_result(light_tap)
    assert result.energy_error is None
    assert result.warnings == engine.scene_warnings(engine.parse_scene(light_tap))
    assert len(result.warnings) == 1
    assert engine.blocks(light_tap).warnings == result.warnings

    def broken(*args, **kwargs):
        raise RuntimeError("boom")

    monkeypatch.setattr(guitar_module, "finger_warnings", broken)
    failed = engine.render_result(light_tap)
    assert failed.warnings == [] and np.array_equal(failed.audio, result.audio)
    assert "warnings failed" in caplog.text


def test_every_model_the_schema_names_has_an_instrument():
    """``engine.models`` is the one place that maps a scene's ``model`` to an instrument: one for
    each name the schema accepts, each with the face the mixer and the live session use."""
    from engine import models
    from engine.instrument import Instrument

    assert tuple(models.PREPARE) == engine.MODELS
    assert tuple(models.ENTRY_POINTS) == engine.MODELS
    assert tuple(models.TRAITS) == engine.MODELS
    for model in engine.MODELS:
        sc = engine.parse_scene({"duration": 0.01, "model": model, "events": [pluck(1)]})
        inst = models.prepare(sc)
        assert isinstance(inst, Instrument), model
        assert sum(len(b) for b in inst.blocks(64)) == engine.frame_count(sc)
