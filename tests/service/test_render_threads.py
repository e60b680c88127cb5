"""GUITAR_RENDER_THREADS: a worker renders on that many threads (engine/mix.py), and the bytes it
sends, whole files and streamed blocks, are those of one thread."""

from __future__ import annotations

import pytest
from pydantic import ValidationError

import engine
from service import worker
from service.config import Settings

SCENE = {"duration": 0.2, "output": {"channels": 2},
         "tracks": [{"events": [{"type": "strum", "time": 0.0, "spread": 0.02}]},
                    {"guitar": {"preset": "bass"}, "model": "waveguide",
                     "events": [{"type": "pluck", "time": 0.05, "string": 4}]}]}


class _Conn:
    """The worker's pipe end, keeping what the worker sends."""

    def __init__(self):
        self.sent = []

    def send(self, msg):
        self.sent.append(msg)

    def poll(self):
        return False


def _rendered(threads: int) -> bytes:
    conn = _Conn()
    worker._render(conn, engine, 1, {"scene": SCENE, "sample_rate": 44100, "format": "wav",
                                     "subtype": "FLOAT", "channels": 2}, threads)
    (kind, _, data, _meta), = conn.sent
    assert kind == "done"
    return data


def _streamed(threads: int) -> bytes:
    conn = _Conn()
    payload = {"scene": SCENE, "frames": engine.frame_count(engine.parse_scene(SCENE)),
               "subtype": "FLOAT64", "channels": 2}
    worker._stream(conn, engine, 1, payload, 2048, threads)
    assert conn.sent[-1][0] == "end"
    return b"".join(m[2] for m in conn.sent if m[0] == "block")


def test_a_worker_on_two_threads_sends_the_bytes_of_one():
    assert _rendered(2) == _rendered(1)
    assert _streamed(2) == _streamed(1)


def test_the_setting_defaults_to_one_thread_and_refuses_zero(monkeypatch):
    monkeypatch.delenv("GUITAR_RENDER_THREADS", raising=False)
    assert Settings().render_threads == 1
    monkeypatch.setenv("GUITAR_RENDER_THREADS", "2")
    assert Settings().render_threads == 2
    monkeypatch.setenv("GUITAR_RENDER_THREADS", "0")
    with pytest.raises(ValidationError):
        Settings()
