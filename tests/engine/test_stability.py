"""No NaN or Inf for any valid scene: extremes of the allowed ranges, and random scenes."""

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import engine
from engine.scene import MAX_FINGER_FORCE_N, MAX_PLUCK_FORCE_N, MAX_TAP_VELOCITY_M_S

from .conftest import fret, pluck, scene, tap


@pytest.mark.parametrize("preset", ["steel-acoustic", "nylon-classical"])
def test_forces_at_the_top_of_the_range(preset):
    evs = []
    for s in range(1, 7):
        evs += [fret(s, 1 + 2 * s, force=MAX_FINGER_FORCE_N),
                pluck(s, time=0.01, force=MAX_PLUCK_FORCE_N, duration=1e-4, position=0.98),
                tap(s, 12, time=0.05, force=MAX_FINGER_FORCE_N, velocity=MAX_TAP_VELOCITY_M_S),
                pluck(s, time=0.06, force=MAX_PLUCK_FORCE_N, position=0.02)]
    r = engine.render(scene(evs, duration=0.25, guitar={"preset": preset}, diagnostics=True))
    assert np.isfinite(r.audio).all()
    assert r.energy_error < 1e-10


articulation = st.one_of(
    st.builds(lambda s, t, a, b, d: {"type": "slide", "time": t, "string": s, "from_fret": a,
                                     "to_fret": b, "duration": d},
              st.integers(1, 6), st.floats(0, 0.14), st.integers(1, 19), st.integers(1, 19),
              st.floats(0.001, 0.2)),
    st.builds(lambda s, t, q, v: {"type": "hammer_on", "time": t, "string": s, "fret": q,
                                  "velocity": v},
              st.integers(1, 6), st.floats(0, 0.14), st.integers(1, 19),
              st.floats(0.01, MAX_TAP_VELOCITY_M_S)),
    st.builds(lambda s, t, q, f: {"type": "pull_off", "time": t, "string": s, "fret": q,
                                  "force": f},
              st.integers(1, 6), st.floats(0, 0.14), st.integers(1, 19),
              st.floats(0.01, MAX_PLUCK_FORCE_N)),
    st.builds(lambda s, t, x, d: {"type": "bend", "time": t, "string": s, "semitones": x,
                                  "duration": d},
              st.integers(1, 6), st.floats(0, 0.14), st.floats(0.01, 3.0), st.floats(0.001, 0.2)),
    st.builds(lambda s, t, c, r: {"type": "vibrato", "time": t, "string": s, "depth_cents": c,
                                  "rate_hz": r, "duration": 0.1},
              st.integers(1, 6), st.floats(0, 0.14), st.floats(0.1, 100), st.floats(0.5, 15)),
    st.builds(lambda s, t, q: {"type": "harmonic", "time": t, "string": s, "fret": q},
              st.integers(1, 6), st.floats(0, 0.14), st.integers(1, 19)),
    st.builds(lambda s, t, a: {"type": "mute", "time": t, "string": s, "amount": a},
              st.integers(1, 6), st.floats(0, 0.14), st.floats(0, 1)),
    st.builds(lambda t, f, style: {"type": "strum", "time": t, "force": f, "style": style},
              st.floats(0, 0.14), st.floats(0.01, MAX_PLUCK_FORCE_N),
              st.sampled_from(["finger", "pick", "slap", "pop"])),
)

event = st.one_of(
    st.builds(lambda s, t, f, p, d: pluck(s, time=t, force=f, position=p, duration=d),
              st.integers(1, 6), st.floats(0, 0.14), st.floats(0.01, MAX_PLUCK_FORCE_N),
              st.floats(0.02, 0.98), st.floats(1e-4, 0.05)),
    st.builds(lambda s, q, t, f: fret(s, q, time=t, force=f),
              st.integers(1, 6), st.integers(0, 19), st.floats(0, 0.14),
              st.floats(0.01, MAX_FINGER_FORCE_N)),
    st.builds(lambda s, q, t, f, v: tap(s, q, time=t, force=f, velocity=v),
              st.integers(1, 6), st.integers(1, 19), st.floats(0, 0.14),
              st.floats(0.01, MAX_FINGER_FORCE_N), st.floats(0.01, MAX_TAP_VELOCITY_M_S)),
)


@settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(events=st.lists(st.one_of(event, articulation), min_size=1, max_size=8),
       rate=st.sampled_from([22050, 44100, 48000]),
       preset=st.sampled_from(["steel-acoustic", "nylon-classical"]))
def test_random_scenes_stay_finite_and_balanced(events, rate, preset):
    r = engine.render(scene(events, duration=0.15, sample_rate=rate, guitar={"preset": preset},
                            diagnostics=True, quality="draft"))
    assert np.isfinite(r.audio).all()
    assert r.energy_error < 1e-10
