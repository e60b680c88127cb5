"""Validation at the edge: every bad input names its field and the allowed range."""

import pytest
from pydantic import ValidationError

import engine

GOOD = {"duration": 1.0, "events": [{"type": "pluck", "time": 0.0, "string": 1}]}


def _bad(patch):
    sc = {**GOOD, **patch}
    with pytest.raises(ValidationError) as e:
        engine.render(sc)
    return str(e.value)


@pytest.mark.parametrize("patch,words", [
    ({"duration": 0}, ["duration", "greater than 0"]),
    ({"duration": 1e9}, ["duration", "less than or equal"]),
    ({"sample_rate": 8000}, ["sample_rate", "22050"]),
    ({"events": [{"type": "pluck", "time": 0, "string": 7}]}, ["string", "1..6"]),
    ({"events": [{"type": "pluck", "time": 0, "string": 0}]}, ["string", "greater than or equal"]),
    ({"events": [{"type": "pluck", "time": 2.0, "string": 1}]}, ["time", "< 1.0"]),
    ({"events": [{"type": "pluck", "time": -1, "string": 1}]}, ["time", "greater than or equal"]),
    ({"events": [{"type": "pluck", "time": 0, "string": 1, "force": -1}]}, ["force"]),
    ({"events": [{"type": "pluck", "time": 0, "string": 1, "force": 100}]}, ["force", "20"]),
    ({"events": [{"type": "pluck", "time": 0, "string": 1, "position": 1.5}]}, ["position"]),
    ({"events": [{"type": "fret", "time": 0, "string": 1, "fret": 22}]}, ["fret", "0..20"]),
    ({"events": [{"type": "tap", "time": 0, "string": 1, "fret": 0}]}, ["fret"]),
    ({"events": [{"type": "fret", "time": 0.5, "string": 1, "fret": 2, "release": 0.2}]},
     ["release", "after"]),
    ({"events": [{"type": "wobble", "time": 0, "string": 1}]}, ["pluck", "fret", "tap"]),
    ({"guitar": {"preset": "banjo"}}, ["preset", "steel-acoustic"]),
    ({"guitar": {"tuning": ["E2"] * 13}}, ["tuning", "at most 12"]),  # 1..12 notes: fit_strings
    ({"guitar": {"tuning": ["H2"] * 6}}, ["note name"]),
    ({"output": {"format": "mp3"}}, ["format", "wav"]),
    ({"duration": float("nan")}, ["duration"]),
    ({"events": [{"type": "pluck", "time": 0, "string": 1, "force": float("inf")}]}, ["force"]),
    ({"extra": 1}, ["extra"]),
    ({"guitar": {"strings": [{"string": 1, "nut_compensation_m": 0.01}]}},
     ["nut_compensation_m", "less than or equal to 0.007"]),
    ({"guitar": {"strings": [{"string": 1, "nut_compensation_m": -1e-3}]}},
     ["nut_compensation_m", "greater than or equal to 0"]),
    # the string's rest line must rise from the nut, or it starts below the upper fret tips
    ({"guitar": {"action_nut_m": 3e-3, "action_12th_m": 3e-4}},
     ["guitar.action_12th_m", "action_12th_m >= action_nut_m"]),
    ({"guitar": {"action_nut_m": 3e-3}}, ["guitar.action_nut_m", "action_12th_m >= action_nut_m"]),
    # bending stiffness alone above the pitch: no positive tension tunes the string
    ({"guitar": {"strings": [{"string": 1, "note": "C#1", "radius_m": 2e-3,
                              "density_kg_m3": 500.0, "youngs_modulus_pa": 4e11}]}},
     ["guitar.strings[0].youngs_modulus_pa", "must be below", "Pa"]),
])
def test_bad_input_names_the_field(patch, words):
    msg = _bad(patch)
    for w in words:
        assert w in msg, msg


def test_overrides_apply():
    sc = engine.parse_scene({**GOOD, "guitar": {"tuning": ["D4", "B3", "G3", "D3", "G2", "D2"],
                                                 "frets": 22, "action_12th_m": 0.0025}})
    p = sc.preset()
    assert p.strings[5].note == "D2" and p.frets == 22 and p.action_12th_m == 0.0025


def _stiff_string(fraction):
    """String 1 of the default preset tuned to C#1 with a 2 mm radius and its Young's modulus at
    ``fraction`` of the largest the validation allows (tension positive down to a 100-cent
    vibrato: pi^2 E I / L^2 < 2^(-1/6) 4 L^2 rho A f0^2)."""
    from engine.presets import apply_overrides, get_preset
    from engine.scene import Guitar

    o = {"string": 1, "note": "C#1", "radius_m": 2e-3, "density_kg_m3": 500.0}
    p = apply_overrides(get_preset("steel-acoustic"), Guitar.model_validate({"strings": [o]}))
    spec, length = p.strings[0], p.string_length_m(1)
    e_max = spec.youngs_modulus_pa * 2.0 ** (-1.0 / 6.0) * spec.pitch_tension_n(length) / \
        spec.stiffness_tension_n(length)
    return {"duration": 0.1, "output": {"body": "none", "normalize": False},
            "guitar": {"strings": [{**o, "youngs_modulus_pa": fraction * e_max}]},
            "events": [{"type": "pluck", "time": 0.0, "string": 1, "force": 20.0},
                       {"type": "vibrato", "time": 0.0, "string": 1, "depth_cents": 100.0,
                        "rate_hz": 15.0, "duration": 0.1}]}


def test_a_string_just_inside_the_stiffness_limit_renders_a_full_vibrato():
    from engine.testing.stability import check, violations

    with pytest.raises(ValidationError):
        engine.parse_scene(_stiff_string(1.001))
    assert violations(check(_stiff_string(0.999))) == []


def test_a_pitch_too_high_to_pin_the_10th_partial_is_rendered_in_tune():
    """An open C6 at 22.05 kHz: partial 10 (10.5 kHz) is above 0.4 x the rate, so the dispersion
    compensation pins a lower one (engine.fd.string.pinned_partial); the string renders, in tune."""
    from engine.analysis import cents, spectrum_peak

    sc = {"duration": 0.5, "sample_rate": 22050, "quality": "draft", "output": {"body": "none"},
          "guitar": {"strings": [{"string": 1, "note": "C6"}]},
          "events": [{"type": "pluck", "time": 0.0, "string": 1, "force": 0.2}]}
    x = engine.render(sc)
    f0 = 1046.5
    assert abs(cents(spectrum_peak(x[1000:], 22050, f0), f0)) < 1.0


def test_a_strum_names_the_string_it_cannot_play():
    sc = {"duration": 1.0, "guitar": {"preset": "bass"},
          "events": [{"type": "strum", "time": 0.0, "strings": [1, 6]}]}
    with pytest.raises(ValidationError, match=r"events\[0\]\.strings\[1\]: 6 outside 1\.\.4"):
        engine.parse_scene(sc)
