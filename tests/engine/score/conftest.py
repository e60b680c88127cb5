"""Shared by the score tests: the third-party corpus (``make test-data``) and a checker of the
scene's JSON form against ../shared/API.md (the engine does not take ``tracks`` or ``damp`` yet, so
the scenes' structure is checked here, field by field)."""

from __future__ import annotations

import glob
import math
import os

import pytest

from engine import presets

ROOT = os.path.join(os.path.dirname(__file__), "..", "..", "..", ".cache", "score-corpus")


def corpus(kind: str, pattern: str, collecting: bool = False) -> list[str]:
    """The corpus files; missing, they fail the run under CI=true and skip the tests elsewhere
    (``collecting``: called to parametrize, where an empty list skips the test)."""
    files = sorted(glob.glob(os.path.join(ROOT, kind, pattern)))
    if not files:
        msg = f"score corpus missing in {os.path.abspath(ROOT)}: run `make test-data`"
        if os.environ.get("CI") == "true":
            pytest.fail(msg, pytrace=False)
        if not collecting:
            pytest.skip(msg)
    return files


# API.md's fields per event type (type, time, string are common; mute/damp/strum: string optional)
FIELDS = {
    "pluck": {"position", "force", "duration", "style"},
    "fret": {"fret", "force", "release"},
    "tap": {"fret", "force", "velocity", "release"},
    "hammer_on": {"fret", "force", "velocity", "release"},
    "pull_off": {"fret", "force"},
    "slide": {"from_fret", "to_fret", "duration", "force", "release"},
    "bend": {"semitones", "duration", "release"},
    "vibrato": {"depth_cents", "rate_hz", "duration"},
    "harmonic": {"fret", "position", "release"},
    "mute": {"position", "amount", "release"},
    "strum": {"strings", "direction", "spread", "force", "position", "style"},
    "damp": set(),
}


def check_scene(scene: dict) -> None:
    """Every field where API.md allows it, in its range."""
    assert set(scene) <= {"duration", "sample_rate", "tracks", "output", "quality", "diagnostics",
                          "score"}
    dur = scene["duration"]
    if "score" in scene:  # bars and beats as played: in time order, within the scene
        from engine.scene import ScoreInfo

        info = ScoreInfo.model_validate(scene["score"])
        for times in (info.bars, info.beats, [m.time for m in info.tempo]):
            assert times == sorted(times) and all(0.0 <= t < dur for t in times)
        assert all(p >= 1 for p in info.beat_positions)
    assert isinstance(dur, float | int) and dur > 0
    assert scene["tracks"], "no tracks"
    for ti, tr in enumerate(scene["tracks"]):
        assert set(tr) <= {"name", "guitar", "events", "gain_db", "pan", "effects"}, tr.keys()
        g = tr["guitar"]
        assert g["preset"] in presets.PRESETS
        n = len(g.get("tuning") or presets.get_preset(g["preset"]).strings)
        for name in g.get("tuning") or []:
            assert 25.0 <= presets.note_frequency(name) <= 1400.0
        frets = g.get("frets", presets.get_preset(g["preset"]).frets)
        assert frets <= 24
        assert -1.0 <= tr.get("pan", 0.0) <= 1.0
        for e in tr["events"]:
            where = f"track {ti} event {e}"
            kind = e["type"]
            assert kind in FIELDS, where
            assert set(e) - {"type", "time", "string"} <= FIELDS[kind], where
            assert 0.0 <= e["time"] < dur, where
            assert all(math.isfinite(v) for v in e.values() if isinstance(v, float)), where
            if "string" in e:
                assert 1 <= e["string"] <= n, where
            elif kind not in ("mute", "damp", "strum"):
                raise AssertionError(f"{where}: no string")
            if "release" in e:
                assert e["release"] > e["time"], where
            for f in ("fret", "from_fret", "to_fret"):
                if f in e and e[f] is not None:
                    low = 0 if (kind == "fret") else 1
                    assert low <= e[f] <= frets, where
            if kind == "pluck":
                assert 0.02 <= e["position"] <= 0.98 and 0 < e["force"] <= 20, where
                assert e.get("style", "finger") in ("finger", "pick", "slap", "pop"), where
            if kind == "bend":
                assert 0 < e["semitones"] <= 3.0 and e["duration"] > 0, where
            if kind == "vibrato":
                assert 0 < e["depth_cents"] <= 100 and 0.5 <= e["rate_hz"] <= 15, where
            if kind == "harmonic":
                assert (e.get("fret") is None) != (e.get("position") is None), where
                if e.get("position") is not None:
                    assert 0.02 < e["position"] < 0.98, where
            if kind == "mute":
                assert 0.7 <= e.get("position", 0.96) <= 0.99 and 0 <= e["amount"] <= 1, where
            if kind == "strum":
                assert e["direction"] in ("down", "up") and 0 <= e["spread"] <= 1, where
                assert all(1 <= s <= n for s in e["strings"]), where
            if kind in ("tap", "hammer_on"):
                assert 0 < e.get("velocity", 1.0) <= 5.0, where
            if kind == "pull_off":
                assert 0 < e["force"] <= 20, where


def match_labels(scene, labels: list[dict]) -> list:
    """The converter's notes that no label matches (same track, string, time to 1 us, fret and
    pitch to 0.01 semitone), and the count of labels."""
    want = [n for n in scene.notes if not n["dead"]]
    by = {(n["track"], n["string"], round(n["time"], 6)): n for n in labels}
    bad = []
    for n in want:
        lab = by.get((n["track"], n["string"], round(n["time"], 6)))
        if lab is None or lab["fret"] != n["fret"] or abs(lab["pitch"] - n["pitch"]) > 0.01:
            bad.append((n, lab))
    return bad


def no_overlap(labels: list[dict]) -> None:
    """One note per string at a time."""
    per: dict = {}
    for n in labels:
        per.setdefault((n["track"], n["string"]), []).append(n)
    for key, ns in per.items():
        ns.sort(key=lambda n: n["time"])
        for a, b in zip(ns, ns[1:], strict=False):
            assert a["time"] + a["duration"] <= b["time"] + 1e-9, (key, a, b)
