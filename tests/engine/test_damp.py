"""The ``damp`` event: the relaxed fretting hand stops the string (engine/fd/controls.py: DAMP_*)."""

from __future__ import annotations

import numpy as np
import pytest

import engine
from engine.fd.instrument import prepare
from engine.scene import Scene

SR = 44100
DAMP_AT = 0.3
# the documented limits (docs/engine.md): time to -60 dB after a damp
LIMIT_S = {1: 0.03, 2: 0.03, 3: 0.05, 4: 0.06, 5: 0.08, 6: 0.09}


def _scene(string: int, fret: int, duration: float = 0.6, **extra) -> dict:
    ev = [{"type": "fret", "time": 0.0, "string": string, "fret": fret}] if fret else []
    ev += [{"type": "pluck", "time": 0.01, "string": string},
           {"type": "damp", "time": DAMP_AT, "string": string}]
    return {"duration": duration, "output": {"normalize": False, "body": "none"}, "events": ev,
            **extra}


def time_to_minus_60_db(y: np.ndarray, t0: float) -> float:
    """Seconds from t0 until the 2 ms RMS envelope stays 60 dB below its level just before t0."""
    w = int(0.002 * SR)
    env = np.sqrt(np.convolve(y**2, np.ones(w) / w, mode="same"))
    i0 = int(t0 * SR)
    ref = env[i0 - 3 * w:i0 - w].max()
    above = np.nonzero(env[i0:] >= ref * 1e-3)[0]
    return (above[-1] + 1) / SR if above.size else 0.0


@pytest.mark.parametrize("string", range(1, 7))
def test_a_damped_note_dies_within_tens_of_milliseconds(string):
    times = []
    for fret in (0, 5):
        y = engine.render(_scene(string, fret))
        t = time_to_minus_60_db(y, DAMP_AT)
        times.append(t)
        print(f"string {string} fret {fret}: -60 dB in {1e3 * t:.0f} ms ({60 / t:.0f} dB/s)")
        assert t <= LIMIT_S[string]
    # an undamped note lasts seconds: the damp, not the string's own loss, stops it
    free = engine.render({**_scene(string, 5), "events": _scene(string, 5)["events"][:-1]})
    assert time_to_minus_60_db(free, DAMP_AT) > 0.25


def test_the_next_event_releases_the_damp():
    """A pluck after a damp sounds as loud as the first one (the hand has left the string)."""
    sc = _scene(1, 0, duration=0.8)
    sc["events"].append({"type": "pluck", "time": 0.5, "string": 1})
    y = engine.render(sc)
    first = np.max(np.abs(y[:int(0.2 * SR)]))
    second = np.max(np.abs(y[int(0.5 * SR):int(0.7 * SR)]))
    assert second > 0.7 * first
    assert time_to_minus_60_db(y[:int(0.5 * SR)], DAMP_AT) < LIMIT_S[1]


@pytest.mark.parametrize("string,fret", [(1, 0), (6, 5), (3, 12)])
def test_energy_balance_holds_through_a_damp(string, fret):
    r = engine.render(_scene(string, fret, duration=0.4), diagnostics=True)
    print(f"string {string} fret {fret}: energy error {r.energy_error:.2e}")
    assert 0.0 < r.energy_error <= 1e-13


def test_a_damped_string_stops_being_computed():
    """The decayed-string skip (engine/fd/voice.py) stops a damped string soon after the damp; the
    same note left ringing is computed to the end."""
    stopped_at = {}
    for damped in (True, False):
        sc = _scene(6, 3, duration=2.0)
        if not damped:
            sc["events"] = sc["events"][:-1]
        g = prepare(Scene.model_validate(sc))
        v = g.voices[0]
        t = None
        for _ in g.blocks(441):
            if v.stopped and t is None:
                t = g.frame / SR
        stopped_at[damped] = t
    print(f"damped low E stopped being computed at {stopped_at[True]:.2f} s (damp at {DAMP_AT} s)")
    assert stopped_at[False] is None
    assert stopped_at[True] is not None and stopped_at[True] < DAMP_AT + 0.5


def test_damp_without_a_string_stops_every_string():
    sc = {"duration": 0.6, "output": {"normalize": False, "body": "none"},
          "events": [{"type": "strum", "time": 0.0}, {"type": "damp", "time": DAMP_AT}]}
    y = engine.render(sc)
    assert time_to_minus_60_db(y, DAMP_AT) <= max(LIMIT_S.values())
