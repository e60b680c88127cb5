"""service.config.Settings: GUITAR_* environment variables, defaults and consistency checks."""

from __future__ import annotations

import os
import re
from pathlib import Path

import pytest
from pydantic import ValidationError

from engine.scene import MAX_DURATION_S, MAX_EVENTS, SAMPLE_RATE_MAX, SAMPLE_RATE_MIN
from service.config import Settings

DOCS = Path(__file__).resolve().parents[2] / "docs" / "service.md"


def _documented_defaults() -> dict[str, str]:
    """``GUITAR_*`` -> default, from docs/service.md's settings table."""
    out = {}
    for line in DOCS.read_text().splitlines():
        m = re.match(r"\| (`GUITAR_\w+`(?: / `GUITAR_\w+`)?) \| ([^|]+) \|", line)
        if m:
            names = re.findall(r"GUITAR_(\w+)", m.group(1))
            for name, default in zip(names, m.group(2).split(" / "), strict=True):
                out[name.lower()] = default.strip()
    return out


def test_the_documented_defaults_are_the_codes(monkeypatch: pytest.MonkeyPatch) -> None:
    for key in [k for k in os.environ if k.startswith("GUITAR_")]:
        monkeypatch.delenv(key)
    s = Settings()
    documented = _documented_defaults()
    assert set(documented) == set(Settings.model_fields), "a setting is missing from the docs"
    assert documented.pop("workers") == "CPUs this process may use"
    assert s.workers == len(os.sched_getaffinity(0))
    assert documented.pop("heavy_workers") == "workers − 1 (at least 1)"
    assert s.heavy_workers is None and s.heavy_slots() == max(1, s.workers - 1)
    # read by the engine from the environment; the setting validates it at start-up
    assert documented.pop("compile_jobs") == "the cores"
    from engine import precompile

    assert s.compile_jobs is None and precompile.compile_jobs() == len(os.sched_getaffinity(0))
    for name, text in documented.items():
        value = getattr(s, name)
        if isinstance(value, bool):
            assert text == str(value).lower(), name
        elif isinstance(value, int | float):
            assert float(text) == value, name
        else:
            assert text == value, name


@pytest.mark.parametrize("name,limit", [("max_duration_s", MAX_DURATION_S),
                                        ("max_events", MAX_EVENTS),
                                        ("max_sample_rate", SAMPLE_RATE_MAX)])
def test_a_server_limit_may_reach_the_engines_but_not_pass_it(name: str, limit: float) -> None:
    assert getattr(Settings(**{name: limit}), name) == limit
    with pytest.raises(ValidationError):
        Settings(**{name: limit + 1})


def test_no_sample_rate_below_the_engines() -> None:
    assert Settings(min_sample_rate=SAMPLE_RATE_MIN).min_sample_rate == SAMPLE_RATE_MIN
    with pytest.raises(ValidationError):
        Settings(min_sample_rate=SAMPLE_RATE_MIN - 1)


def test_environment_overrides(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("GUITAR_WORKERS", "3")
    monkeypatch.setenv("GUITAR_MAX_DURATION_S", "5")
    monkeypatch.setenv("GUITAR_QUEUE_SIZE", "0")
    s = Settings()
    assert (s.workers, s.max_duration_s, s.queue_size) == (3, 5.0, 0)


@pytest.mark.parametrize("env,value", [
    ("GUITAR_WORKERS", "0"), ("GUITAR_MAX_DURATION_S", "5000"), ("GUITAR_MAX_SAMPLE_RATE", "192000"),
    ("GUITAR_MP_CONTEXT", "fork"), ("GUITAR_MAX_EVENTS", "many"),
])
def test_bad_settings_are_refused(monkeypatch: pytest.MonkeyPatch, env: str, value: str) -> None:
    monkeypatch.setenv(env, value)
    with pytest.raises(ValidationError):
        Settings()


def test_min_rate_above_max_rate_is_refused() -> None:
    with pytest.raises(ValidationError):
        Settings(min_sample_rate=48000, max_sample_rate=44100)
