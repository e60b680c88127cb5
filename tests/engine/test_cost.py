"""``engine.estimate_cost`` (no kernels imported) against the grids ``prepare`` really builds."""

from __future__ import annotations

import pytest

import engine
from engine.cost import expanded_event_count
from engine.fd.voice import string_model
from engine.options import QUALITY, RenderOptions
from engine.performance import events_on
from engine.presets import PRESETS
from engine.scene import Scene


def _scene(preset, quality, rate, kind):
    n = Scene.model_validate({"duration": 1, "guitar": {"preset": preset}}).preset().n_strings
    events = []
    for s in range(1, n + 1):
        if kind == "open":
            events.append({"type": "pluck", "time": 0, "string": s})
        elif kind == "fretted":
            events.append({"type": "fret", "time": 0, "string": s, "fret": 5})
        else:  # fretted and bent
            events += [{"type": "fret", "time": 0, "string": s, "fret": 7},
                       {"type": "bend", "time": 0.1, "string": s, "semitones": 2.5}]
    return Scene.model_validate({"duration": 1, "sample_rate": rate, "quality": quality,
                                 "guitar": {"preset": preset}, "events": events})


@pytest.mark.parametrize("preset", sorted(PRESETS))
@pytest.mark.parametrize("quality", sorted(QUALITY))
@pytest.mark.parametrize("rate", [22050, 44100, 48000, 96000])
@pytest.mark.parametrize("kind", ["open", "fretted", "bent"])
def test_the_estimate_matches_the_grids_prepare_builds(preset, quality, rate, kind):
    sc = _scene(preset, quality, rate, kind)
    preset, n = sc.preset(), sc.preset().n_strings
    real = {}
    for i in range(1, n + 1):
        os_, model, _ = string_model(preset, i, events_on(sc, n, i), float(rate), QUALITY[quality],
                                     RenderOptions())
        real[i] = (os_, model.n)
    est = {c.string: (c.oversample, c.nodes) for c in engine.estimate_cost(sc).strings}
    assert est.keys() == real.keys()
    for s, (os_, n) in real.items():
        e_os, e_n = est[s]
        # the factor is the engine's, or one more where the tuned grid sits at the max_h_m edge
        assert os_ <= e_os <= os_ + 1, (s, est[s], real[s])
        assert e_os * e_n >= os_ * n, (s, est[s], real[s])  # never below the real work
    total = sum(a * b for a, b in est.values()) / sum(a * b for a, b in real.values())
    assert total <= 1.3, (est, real)


def test_the_estimate_is_linear_in_duration_and_counts_only_strings_with_events():
    one = engine.estimate_cost({"duration": 1, "events": [
        {"type": "pluck", "time": 0, "string": 1}]})
    two = engine.estimate_cost({"duration": 2, "events": [
        {"type": "pluck", "time": 0, "string": 1}]})
    assert two.work == pytest.approx(2 * one.work) and len(one.strings) == 1
    six = engine.estimate_cost({"duration": 1, "events": [{"type": "strum", "time": 0}]})
    assert len(six.strings) == 6 and six.work > 5 * one.work


@pytest.mark.parametrize("events, count", [
    ([{"type": "strum", "time": 0}], 6),
    ([{"type": "strum", "time": 0, "strings": [1, 3]}], 2),
    ([{"type": "mute", "time": 0}], 6),
    ([{"type": "damp", "time": 0}], 6),  # a damp without a string damps every string
    ([{"type": "mute", "time": 0, "string": 2}, {"type": "pluck", "time": 0, "string": 2}], 2),
    ([{"type": "strum", "time": 0}] * 10 + [{"type": "mute", "time": 0}] * 3, 78),
])
def test_expanded_event_count(events, count):
    assert expanded_event_count(Scene.model_validate({"duration": 1, "events": events})) == count
