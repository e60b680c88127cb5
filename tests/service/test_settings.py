"""service.config.Settings: GUITAR_* environment variables, defaults and consistency checks."""

from __future__ import annotations

import os

import pytest
from pydantic import ValidationError

from service.config import Settings


def test_defaults(monkeypatch: pytest.MonkeyPatch) -> None:
    for key in [k for k in os.environ if k.startswith("GUITAR_")]:
        monkeypatch.delenv(key)
    s = Settings()
    assert s.workers == len(os.sched_getaffinity(0))
    assert s.max_duration_s == 30.0 and s.max_events == 500 and s.max_body_bytes == 262144
    assert (s.min_sample_rate, s.max_sample_rate) == (22050, 96000)
    assert s.time_limit_s(2.0) == pytest.approx(10.0 + 5.0 * 2.0)


def test_environment_overrides(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("GUITAR_WORKERS", "3")
    monkeypatch.setenv("GUITAR_MAX_DURATION_S", "5")
    monkeypatch.setenv("GUITAR_QUEUE_SIZE", "0")
    s = Settings()
    assert (s.workers, s.max_duration_s, s.queue_size) == (3, 5.0, 0)


@pytest.mark.parametrize("env,value", [
    ("GUITAR_WORKERS", "0"), ("GUITAR_MAX_DURATION_S", "500"), ("GUITAR_MAX_SAMPLE_RATE", "192000"),
    ("GUITAR_MP_CONTEXT", "fork"), ("GUITAR_MAX_EVENTS", "many"),
])
def test_bad_settings_are_refused(monkeypatch: pytest.MonkeyPatch, env: str, value: str) -> None:
    monkeypatch.setenv(env, value)
    with pytest.raises(ValidationError):
        Settings()


def test_min_rate_above_max_rate_is_refused() -> None:
    with pytest.raises(ValidationError):
        Settings(min_sample_rate=48000, max_sample_rate=44100)
