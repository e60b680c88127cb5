"""Scenes of several tracks (engine/mix.py), their effects chains (engine/effects.py) and presets
extended to a score's string count (engine/presets.py: fit_strings)."""

from __future__ import annotations

import numpy as np
import pytest
from pydantic import ValidationError

import engine
from engine.analysis import cents, spectrum_peak
from engine.presets import fit_strings, get_preset, note_frequency, tension_n
from engine.scene import MAX_EVENTS

SR = 44100
PLUCKS = [{"type": "fret", "time": 0.0, "string": 4, "fret": 2},
          {"type": "pluck", "time": 0.01, "string": 4},
          {"type": "pluck", "time": 0.05, "string": 1, "force": 1.0}]


def test_a_single_guitar_is_exactly_a_scene_with_one_track():
    for output in ({"normalize": False}, {"normalize": False, "channels": 2}):
        single = engine.render({"duration": 0.3, "guitar": {"preset": "electric"},
                                "events": PLUCKS, "output": output})
        track = engine.render({"duration": 0.3, "output": output,
                               "tracks": [{"guitar": {"preset": "electric"}, "events": PLUCKS}]})
        assert single.tobytes() == track.tobytes()


def test_tracks_are_mixed_with_their_gain_and_pan():
    out = {"normalize": False, "channels": 2}
    a = {"guitar": {"preset": "electric"}, "events": PLUCKS, "pan": -0.5, "gain_db": -6.0}
    b = {"guitar": {"preset": "bass"}, "events": [{"type": "pluck", "time": 0.02, "string": 4}],
         "pan": 1.0}
    both = engine.render({"duration": 0.3, "output": out, "tracks": [a, b]})
    alone = [engine.render({"duration": 0.3, "output": {"normalize": False},
                            "guitar": t["guitar"], "events": t["events"]}) for t in (a, b)]
    gl, gr = np.cos((0.5 * np.pi) / 4), np.sin((0.5 * np.pi) / 4)  # pan -0.5, constant power
    g = 10 ** (-6.0 / 20)
    left = g * gl * alone[0] + 0.0 * alone[1]
    right = g * gr * alone[0] + 1.0 * alone[1]
    np.testing.assert_allclose(both[:, 0], left, rtol=0, atol=1e-12)
    np.testing.assert_allclose(both[:, 1], right, rtol=0, atol=1e-12)


@pytest.mark.parametrize("channels", [1, 2])
def test_tracks_with_the_same_body_share_one_and_mix_as_with_their_own(channels):
    """Three steel-string tracks (one placed, one quieter) and a classical one: the first three go
    through one body, the classical alone through its own; the mix is the one with a body each up
    to the rounding of the sums; with no two tracks of one body, the samples are those of a body
    each to the bit."""
    from engine.mix import prepare
    from engine.scene import parse_scene

    steel = {"preset": "steel-acoustic"}
    tracks = [{"guitar": steel, "events": PLUCKS},
              {"guitar": steel, "events": [{"type": "pluck", "time": 0.03, "string": 2}],
               "gain_db": -9.0, **({"pan": 0.4} if channels == 2 else {})},
              {"guitar": steel, "events": [{"type": "pluck", "time": 0.0, "string": 6}]},
              {"guitar": {"preset": "nylon-classical"}, "events": PLUCKS}]
    sc = parse_scene({"duration": 0.4, "output": {"normalize": False, "channels": channels},
                      "tracks": tracks})
    shared, own = prepare(sc), prepare(sc, share_bodies=False)
    assert [t.shared for t in shared.tracks] == [0, 0, 0, None] and len(shared.bodies) == 1
    assert not own.bodies
    a = np.concatenate(list(shared.blocks(4096)))
    b = np.concatenate(list(own.blocks(4096)))
    err = np.max(np.abs(a - b)) / np.max(np.abs(b))
    print(f"{channels} channel(s): shared body against a body each, max difference {err:.1e} "
          "of the peak")
    assert err < 1e-13
    # a body alone in its kind stays the track's own: that mix is the one before, to the bit
    sc = parse_scene({"duration": 0.4, "output": {"normalize": False, "channels": channels},
                      "tracks": tracks[2:]})
    assert not prepare(sc).bodies
    a = np.concatenate(list(prepare(sc).blocks(4096)))
    assert a.tobytes() == np.concatenate(list(prepare(sc, share_bodies=False).blocks(4096))).tobytes()


CHAIN = [{"type": "drive", "gain_db": 12.0}, {"type": "compressor", "threshold_db": -24.0},
         {"type": "highpass", "cutoff_hz": 70.0}, {"type": "peak", "cutoff_hz": 800.0,
                                                   "gain_db": 3.0, "q": 1.0},
         {"type": "lowpass", "cutoff_hz": 6000.0}, {"type": "chorus"},
         {"type": "delay", "delay_s": 0.12, "feedback": 0.5},
         {"type": "reverb", "room_size": 0.8, "mix": 0.4},
         {"type": "convolution", "ir": "acoustic", "mix": 0.3}]


@pytest.mark.parametrize("channels", [1, 2])
def test_effects_keep_their_state_across_blocks(channels):
    """A delay's repeats and a reverb's tail cross block boundaries: the stream's blocks equal
    the whole render (normalize false), for blocks of an odd size."""
    sc = {"duration": 0.6, "output": {"normalize": False, "channels": channels},
          "tracks": [{"guitar": {"preset": "electric"}, "events": PLUCKS, "effects": CHAIN,
                      "pan": 0.3}]}
    whole = engine.render(sc)
    parts = np.concatenate(list(engine.blocks(sc, block_frames=1000)))
    dry = engine.render({**sc, "tracks": [{**sc["tracks"][0], "effects": []}]})
    assert parts.tobytes() == whole.tobytes()
    assert np.all(np.isfinite(whole))
    # the chain is heard: the delay repeats the pluck 0.12 s later, after the dry note decayed
    assert np.max(np.abs(whole - dry)) > 0.1 * np.max(np.abs(dry))


def test_a_delay_repeats_the_note_at_its_delay_time():
    delay = {"type": "delay", "delay_s": 0.2, "feedback": 0.0, "mix": 0.5}
    sc = {"duration": 0.5, "output": {"normalize": False},
          "tracks": [{"events": [{"type": "pluck", "time": 0.0, "string": 1},
                                 {"type": "damp", "time": 0.05, "string": 1}],
                      "effects": [delay]}]}
    y = engine.render(sc)
    onset = lambda x: int(np.argmax(np.abs(x) > 0.1 * np.max(np.abs(x))))  # noqa: E731
    first = onset(y[: int(0.15 * SR)])
    second = int(0.15 * SR) + onset(y[int(0.15 * SR):])
    assert abs((second - first) / SR - 0.2) < 0.002


def test_effect_parameters_are_checked_and_named():
    bad = {"duration": 1.0, "tracks": [{"effects": [{"type": "reverb", "room_size": 2.0}]}]}
    with pytest.raises(ValidationError, match=r"tracks\.0\.effects\.0\.reverb\.room_size"):
        engine.parse_scene(bad)
    bad = {"duration": 1.0, "tracks": [{"effects": [{"type": "convolution", "ir": "/etc/passwd"}]}]}
    with pytest.raises(ValidationError, match="ir"):
        engine.parse_scene(bad)


def test_track_validation_names_the_field():
    with pytest.raises(ValidationError, match="either tracks or top-level"):
        engine.parse_scene({"duration": 1.0, "events": PLUCKS, "tracks": [{"events": PLUCKS}]})
    with pytest.raises(ValidationError, match=r"tracks\[1\]\.events\[0\]\.string: 5 outside 1\.\.4"):
        engine.parse_scene({"duration": 1.0, "tracks": [
            {"events": PLUCKS}, {"guitar": {"preset": "bass"},
                                 "events": [{"type": "pluck", "time": 0, "string": 5}]}]})
    with pytest.raises(ValidationError, match=r"tracks\[0\]\.events\[0\]\.time"):
        engine.parse_scene({"duration": 1.0, "tracks": [
            {"events": [{"type": "pluck", "time": 1.5, "string": 1}]}]})
    with pytest.raises(ValidationError, match="output.pan"):
        engine.parse_scene({"duration": 1.0, "output": {"channels": 2, "pan": [0] * 6},
                            "tracks": [{"events": PLUCKS}]})
    with pytest.raises(ValidationError, match=r"tracks\.0\.pan"):
        engine.parse_scene({"duration": 1.0, "tracks": [{"pan": 1.5}]})
    half = [{"type": "pluck", "time": 0.0, "string": 1}] * (MAX_EVENTS // 2 + 1)
    with pytest.raises(ValidationError, match=f"events over all tracks, at most {MAX_EVENTS}"):
        engine.parse_scene({"duration": 1.0, "tracks": [{"events": half}, {"events": half}]})
    sc = engine.parse_scene({"duration": 1.0, "tracks": [{"events": PLUCKS}, {"events": PLUCKS}]})
    assert sc.event_count() == 2 * len(PLUCKS)


def test_warnings_name_their_track():
    light = [{"type": "fret", "time": 0.0, "string": 6, "fret": 1, "force": 0.2},
             {"type": "pluck", "time": 0.01, "string": 6}]
    sc = {"duration": 0.2, "tracks": [{"events": PLUCKS}, {"name": "Lead", "events": light}]}
    warnings = engine.render_result(sc).warnings
    assert warnings and all(w.startswith("track 2 'Lead': ") for w in warnings)
    assert engine.scene_warnings(engine.parse_scene(sc)) == warnings


# --- presets extended to a score's string count

SEVEN = ["E4", "B3", "G3", "D3", "A2", "E2", "B1"]
FIVE_BASS = ["G2", "D2", "A1", "E1", "B0"]


@pytest.mark.parametrize("preset,tuning", [("electric", SEVEN), ("steel-acoustic", SEVEN),
                                           ("bass", FIVE_BASS)])
def test_an_added_string_is_built_like_its_neighbours(preset, tuning):
    base = get_preset(preset)
    sc = engine.parse_scene({"duration": 1.0, "guitar": {"preset": preset, "tuning": tuning}})
    p = sc.preset()
    assert p.n_strings == len(tuning)
    low, added = p.strings[-2], p.strings[-1]
    assert added.density_kg_m3 == low.density_kg_m3  # same construction
    assert added.youngs_modulus_pa == low.youngs_modulus_pa
    assert added.radius_m > low.radius_m
    n = base.n_strings
    neighbours = [engine.tuned_tension(base, i) for i in (n - 1, n)]
    t_added = engine.tuned_tension(p, len(tuning))
    print(f"{preset}: added {added.note} gauge {2 * added.radius_m / 0.0254:.3f} in, "
          f"tension {t_added:.1f} N; neighbours {neighbours[0]:.1f}, {neighbours[1]:.1f} N")
    assert min(neighbours) <= t_added <= max(neighbours)
    assert abs(tension_n(added, p.string_length_m(len(tuning))) - np.mean(
        [tension_n(s, base.string_length_m(i)) for i, s in ((n - 1, base.strings[-2]),
                                                               (n, base.strings[-1]))])) < 1e-9


@pytest.mark.parametrize("preset,tuning", [("electric", SEVEN), ("bass", FIVE_BASS)])
def test_an_added_string_sounds_its_note_within_a_cent(preset, tuning):
    n = len(tuning)
    y = engine.render({"duration": 1.5, "guitar": {"preset": preset, "tuning": tuning},
                       "output": {"normalize": False},
                       "events": [{"type": "pluck", "time": 0.0, "string": n, "force": 0.5}]})
    f0 = note_frequency(tuning[-1])
    f = spectrum_peak(y[int(0.3 * SR):], SR, f0)
    print(f"{preset} string {n} ({tuning[-1]}): {f:.3f} Hz, {float(cents(f, f0)):+.3f} cents")
    assert abs(cents(f, f0)) < 1.0


def test_fewer_notes_keep_the_nearest_run_of_strings():
    guitar = get_preset("electric")
    strings = fit_strings(guitar, ["G2", "D2", "A1", "E1"])  # a bass part on a guitar
    assert [s.radius_m for s in strings] == [s.radius_m for s in guitar.strings[2:]]
    strings = fit_strings(guitar, ["E4", "B3", "G3", "D3"])
    assert [s.radius_m for s in strings] == [s.radius_m for s in guitar.strings[:4]]
    sc = engine.parse_scene({"duration": 1.0, "guitar": {"preset": "electric",
                                                          "tuning": ["G2", "D2", "A1", "E1"]}})
    assert sc.preset().n_strings == 4
    with pytest.raises(ValidationError, match=r"events\[0\]\.string: 5 outside 1\.\.4"):
        engine.parse_scene({"duration": 1.0, "guitar": {"preset": "electric",
                                                        "tuning": ["G2", "D2", "A1", "E1"]},
                            "events": [{"type": "pluck", "time": 0, "string": 5}]})


def test_seven_strings_take_string_seven_in_strums_and_stereo():
    sc = {"duration": 0.3, "guitar": {"preset": "electric", "tuning": SEVEN},
          "output": {"channels": 2, "normalize": False},
          "events": [{"type": "strum", "time": 0.0, "strings": [7, 6, 5]}]}
    y = engine.render(sc)
    assert np.all(np.isfinite(y)) and np.max(np.abs(y)) > 0
    with pytest.raises(ValidationError, match="output.pan: 7 values"):
        engine.parse_scene({**sc, "output": {"channels": 2, "pan": [0.0] * 6}})
