"""Random valid scenes: the one generator, for the tests and for the soak.

``random_scene(draw, ...)`` builds a scene dict inside the documented ranges of ``engine.scene``:
any preset, any event type, forces and speeds up to the allowed maxima (the extremes are drawn
often), extreme but valid physical overrides, any sample rate.  ``draw`` supplies the randomness:

* ``scenes(...)``, a hypothesis strategy (``HypothesisDraw`` underneath), in the tests, so that a
  failing scene shrinks to a small one;
* ``NumpyDraw(np.random.default_rng([seed, i]))`` in the soak (``benchmarks/soak.py``), so that
  case i of a seed can be replayed.

Both explore the same space, since both go through ``random_scene``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from engine.presets import PRESETS, get_preset, note_frequency
from engine.scene import (
    MAX_BEND_SEMITONES,
    MAX_FINGER_FORCE_N,
    MAX_PLUCK_FORCE_N,
    MAX_TAP_VELOCITY_M_S,
    SAMPLE_RATE_MAX,
    SAMPLE_RATE_MIN,
)

COMMON_RATES = (22050, 32000, 44100, 48000, 88200, 96000)
STYLES = ("finger", "pick", "slap", "pop")
NOTES = tuple(f"{n}{o}" for o in range(0, 7) for n in
              ("C", "C#", "D", "D#", "E", "F", "F#", "G", "G#", "A", "A#", "B")
              if 25.0 <= note_frequency(f"{n}{o}") <= 1400.0)
# field: (low, high, drawn on a log scale)
OVERRIDES = {
    "radius_m": (5e-5, 2e-3, True),
    "density_kg_m3": (500.0, 25000.0, True),
    "youngs_modulus_pa": (1e8, 4e11, True),
    "t60_fundamental_s": (0.05, 60.0, True),
    "t60_2khz_s": (0.02, 60.0, True),
    "saddle_setback_m": (0.0, 0.02, False),
    # nut_compensation_m is left out: one more draw would change every stream a seed names (the
    # soak's replays, the waveguide's passivity scenes); tests/engine/test_stability.py covers
    # its largest value on every preset
}


class NumpyDraw:
    """The draw interface over a numpy Generator (the soak)."""

    def __init__(self, rng: np.random.Generator):
        self.rng = rng

    def integer(self, lo: int, hi: int) -> int:
        return int(self.rng.integers(lo, hi + 1))

    def real(self, lo: float, hi: float) -> float:
        return float(self.rng.uniform(lo, hi))

    def choice(self, seq):
        return seq[int(self.rng.integers(len(seq)))]

    def chance(self, p: float) -> bool:
        return bool(self.rng.random() < p)


def edge(d, lo: float, hi: float, log: bool = False, p_edge: float = 0.3) -> float:
    """A value in [lo, hi], exactly lo or hi with probability p_edge."""
    if d.chance(p_edge):
        return d.choice((lo, hi))
    if log and lo > 0:
        return min(max(math.exp(d.real(math.log(lo), math.log(hi))), lo), hi)
    return d.real(lo, hi)


def _force(d, hi: float) -> float:
    return edge(d, 1e-3, hi, log=True, p_edge=0.4) if not d.chance(0.1) else hi


def random_event(d, n_strings: int, frets: int, duration: float) -> dict:
    t = d.real(0.0, duration) if d.chance(0.8) else 0.0
    t = min(t, duration * 0.999)
    s = d.integer(1, n_strings)

    def release() -> dict:
        return {"release": t + edge(d, 1e-4, duration, log=True)} if d.chance(0.3) else {}

    kind = d.choice(("pluck", "pluck", "fret", "tap", "hammer_on", "pull_off", "slide", "bend",
                     "vibrato", "harmonic", "mute", "strum"))
    if kind == "pluck":
        ev = {"position": edge(d, 0.02, 0.98), "force": _force(d, MAX_PLUCK_FORCE_N),
              "style": d.choice(STYLES)}
        if d.chance(0.5):
            ev["duration"] = edge(d, 1e-4, 0.05, log=True)
        return {"type": kind, "time": t, "string": s, **ev}
    if kind in ("fret", "tap", "hammer_on"):
        ev = {"type": kind, "time": t, "string": s,
              "fret": d.integer(0 if kind == "fret" else 1, frets), **release()}
        if d.chance(0.7):
            ev["force"] = _force(d, MAX_FINGER_FORCE_N)
        if kind != "fret":
            ev["velocity"] = edge(d, 0.01, MAX_TAP_VELOCITY_M_S, log=True, p_edge=0.4)
        return ev
    if kind == "pull_off":
        return {"type": kind, "time": t, "string": s, "fret": d.integer(1, frets),
                "force": _force(d, MAX_PLUCK_FORCE_N)}
    if kind == "slide":
        ev = {"type": kind, "time": t, "string": s, "from_fret": d.integer(1, frets),
              "to_fret": d.integer(1, frets), "duration": edge(d, 1e-3, 10.0, log=True),
              **release()}
        if d.chance(0.7):
            ev["force"] = _force(d, MAX_FINGER_FORCE_N)
        return ev
    if kind == "bend":
        return {"type": kind, "time": t, "string": s,
                "semitones": edge(d, 0.01, MAX_BEND_SEMITONES, log=True),
                "duration": edge(d, 1e-3, 10.0, log=True), **release()}
    if kind == "vibrato":
        return {"type": kind, "time": t, "string": s, "depth_cents": edge(d, 0.1, 100.0, log=True),
                "rate_hz": edge(d, 0.5, 15.0), "duration": edge(d, 1e-3, duration, log=True)}
    if kind == "harmonic":
        where = ({"fret": d.integer(1, frets)} if d.chance(0.6)
                 else {"position": d.real(0.021, 0.979)})
        return {"type": kind, "time": t, "string": s, **where, **release()}
    if kind == "mute":
        ev = {"type": kind, "time": t, "position": edge(d, 0.7, 0.99),
              "amount": edge(d, 0.0, 1.0), **release()}
        return {**ev, "string": s} if d.chance(0.6) else ev
    strings = sorted({d.integer(1, n_strings) for _ in range(d.integer(1, n_strings))})
    ev = {"type": "strum", "time": t, "direction": d.choice(("down", "up")),
          "spread": edge(d, 0.0, 1.0), "force": _force(d, MAX_PLUCK_FORCE_N),
          "position": edge(d, 0.02, 0.98), "style": d.choice(STYLES)}
    return {**ev, "strings": strings} if d.chance(0.5) else ev


def random_scene(d, max_duration: float = 0.2, max_events: int = 12,
                 qualities=("draft",), overrides: bool = True, min_duration: float = 0.02) -> dict:
    """A scene inside the documented input ranges (it may still fail cross-field validation,
    e.g. a fret beyond a reduced fret count is never drawn, but callers should validate)."""
    name = d.choice(sorted(PRESETS))
    base = get_preset(name)
    n = base.n_strings
    guitar: dict = {"preset": name}
    if overrides and d.chance(0.6):
        strings = []
        for s in range(1, n + 1):
            if d.chance(0.4):
                o: dict = {"string": s}
                for key, (lo, hi, log) in OVERRIDES.items():
                    if d.chance(0.5):
                        o[key] = edge(d, lo, hi, log)
                if d.chance(0.3):
                    o["note"] = d.choice(NOTES)
                strings.append(o)
        if strings:
            guitar["strings"] = strings
        if d.chance(0.3):
            guitar["action_nut_m"] = edge(d, 1e-4, 3e-3, log=True)
        if d.chance(0.3):
            guitar["action_12th_m"] = edge(d, 3e-4, 8e-3, log=True)
        if d.chance(0.2):
            guitar["frets"] = d.integer(1, 24)
    frets = guitar.get("frets", base.frets)
    rate = (d.choice(COMMON_RATES) if d.chance(0.7)
            else d.integer(SAMPLE_RATE_MIN, SAMPLE_RATE_MAX))
    duration = edge(d, min_duration, max_duration, log=True, p_edge=0.2)
    events = [random_event(d, n, frets, duration) for _ in range(d.integer(1, max_events))]
    return {"duration": duration, "sample_rate": rate, "guitar": guitar, "events": events,
            "quality": d.choice(qualities), "output": {"body": "none", "normalize": False}}


class HypothesisDraw:
    """The draw interface over hypothesis's ``draw`` (the tests: failures shrink)."""

    def __init__(self, draw):
        from hypothesis import strategies as st  # a dev dependency: only the tests need it

        self.draw, self.st = draw, st

    def integer(self, lo: int, hi: int) -> int:
        return self.draw(self.st.integers(lo, hi))

    def real(self, lo: float, hi: float) -> float:
        return self.draw(self.st.floats(lo, hi, allow_nan=False, allow_infinity=False))

    def choice(self, seq):
        return self.draw(self.st.sampled_from(seq))

    def chance(self, p: float) -> bool:
        return self.draw(self.st.floats(0.0, 1.0)) < p


def scenes(**kw):
    """A hypothesis strategy of ``random_scene(draw, **kw)``: ``@given(sc=scenes(...))``."""
    from hypothesis import strategies as st

    return st.composite(lambda draw: random_scene(HypothesisDraw(draw), **kw))()


# ---- the stability soak's cases ---------------------------------------------------------------

LONG_EVERY = 100
LONG_S = 60.0
QUALITIES = ("draft",) * 14 + ("standard",) * 5 + ("high",)
WG_LONG_EVERY = 10
WG_SHORT_S = (0.3, 2.0)


@dataclass(frozen=True)
class SoakDraws:
    """How a model's soak cases are drawn: one in ``long_every`` is ``LONG_S`` long (4 events),
    the others ``short_s`` (min, max) with up to ``short_events``; ``stream`` follows (seed, i) in
    the generator's seed (a model's cases apart from the others'); ``model`` is written into the
    scene when given."""

    long_every: int
    short_s: tuple[float, float]
    short_events: int
    short_qualities: tuple[str, ...]
    stream: tuple[int, ...] = ()
    model: str | None = None


# ``engine.scene.MODELS`` -> its soak's draws (the waveguide is cheaper: longer scenes)
SOAK_DRAWS = {
    "fdtd": SoakDraws(LONG_EVERY, (0.02, 0.2), 16, QUALITIES),
    "waveguide": SoakDraws(WG_LONG_EVERY, WG_SHORT_S, 12, ("draft",), stream=(1,),
                           model="waveguide"),
}


def soak_case(seed: int, i: int, model: str = "fdtd") -> tuple[str, dict]:
    """Case ``i`` of ``benchmarks.soak`` (and ``tools.held_soak``) on ``model``, drawn from seed
    (seed, i, *stream): its kind ('short' or '60 s') and scene (``SOAK_DRAWS``)."""
    how = SOAK_DRAWS[model]
    d = NumpyDraw(np.random.default_rng([seed, i, *how.stream]))
    tag = {} if how.model is None else {"model": how.model}
    if i % how.long_every == how.long_every - 1:
        sc = random_scene(d, max_duration=LONG_S, min_duration=LONG_S, max_events=4,
                          qualities=("draft",))
        return "60 s", {**sc, **tag}
    sc = random_scene(d, max_duration=how.short_s[1], min_duration=how.short_s[0],
                      max_events=how.short_events, qualities=how.short_qualities)
    return "short", {**sc, **tag}
