"""The live-session worker: the code that runs inside each process of ``service.live.LivePool``.

One process hosts several sessions (``engine.Session``) and computes their blocks in one loop, each
session paced to real time: block k of a session is computed when the wall clock reaches
``t0 + k * block_seconds - lead`` (so blocks reach the client ``lead`` ahead of when they play), the
session whose block is due soonest first.  Between blocks it reads the pipe, so an event is
applied in the next block computed for its session.

    parent -> worker   ("open", sid, open_message) | ("event", sid, message) | ("close", sid)
                       | None (stop)
    worker -> parent   ("ready", pid, warmup_seconds, frozen)   warmed up; ``frozen``: objects
                                                               moved out of the garbage
                                                               collector's sight
                       ("opened", sid, info)                  the session exists
                       ("block", sid, frame, float32_bytes)   one block (mono, little-endian)
                       ("ack", sid, id, frame)                 an event with an ``id`` acts at frame
                       ("error", sid, field, message, id)      an event refused (the session goes on)
                       ("failed", sid, message)                the session could not go on
                       ("late", sid, n)                        n blocks were finished after
                                                               their play time since the last
                                                               such report (underruns the server
                                                               caused); at most one a second

Everything sent is plain data.  An exception in one session ends that session only (``failed``),
never the process or its other sessions.

Opening a session prepares its guitar (tuning every string, calibrating every fret; on the
waveguide model, the finger's damping of a note held at every fret: seconds the first time on a
machine, a fraction of a second once the calibrations are on disk, ``engine.calibration_store``
and ``benchmarks/calibration.py``), which would stall the other sessions of the process for that
long.  So each guitar, rate, quality and model is prepared once and kept (``_TEMPLATES``, the
most recent few); a session is a copy of it (about a millisecond).  The warm-up prepares the
default guitar at 44.1 and 48 kHz on both models.  A guitar not prepared yet is prepared in a
thread of the process (``_Preparing``) while its loop goes on computing the other sessions' blocks
(the preparation's numerical work runs in numpy, LAPACK and numba code that releases the GIL);
the new session's ``opened`` is sent when it is ready, and the events sent before that are kept
and applied then, in order.
"""

from __future__ import annotations

import contextlib
import copy
import heapq
import json
import os
import signal
import time
from concurrent.futures import Future, ThreadPoolExecutor
from dataclasses import dataclass, field
from multiprocessing.connection import Connection
from typing import Any

import numpy as np

from . import heap

_TEMPLATES: dict[str, Any] = {}  # prepared sessions, most recently used last
_MAX_TEMPLATES = 8


def _key(opened: Any) -> str:
    return json.dumps([opened.scene_guitar().model_dump(), opened.sample_rate, opened.quality,
                       opened.model])


def _prepare(engine: Any, opened: Any) -> Any:
    """The prepared session of an open message's guitar, rate, quality and model (seconds, the
    first time on a machine)."""
    return engine.Session(opened.scene_guitar(), opened.sample_rate, 256, opened.quality,
                          model=opened.model)


def _keep(key: str, template: Any) -> None:
    _TEMPLATES.pop(key, None)
    _TEMPLATES[key] = template
    while len(_TEMPLATES) > _MAX_TEMPLATES:
        _TEMPLATES.pop(next(iter(_TEMPLATES)))


def _copy(template: Any, opened: Any) -> Any:
    s = copy.deepcopy(template)
    s.block_frames = opened.block_frames
    return s


def _new_session(engine: Any, opened: Any) -> Any:
    """A session for a validated open message: a copy of the prepared one for its guitar, rate,
    quality and model (prepared now, in this thread, if it is new)."""
    key = _key(opened)
    template = _TEMPLATES.get(key)
    if template is None:
        template = _prepare(engine, opened)
    _keep(key, template)
    return _copy(template, opened)


@dataclass
class _Preparing:
    """A session waiting for its guitar, prepared in ``_Server.preparer``: its open message, the
    preparation (shared by every session that asked for the same guitar meanwhile) and the
    messages that came for it before it was ready."""

    opened: Any
    key: str
    future: Future
    messages: list[tuple] = field(default_factory=list)


class _Live:
    def __init__(self, session: Any, lead_s: float):
        self.session = session
        self.block_s = session.block_frames / session.sample_rate
        self.lead_s = lead_s
        # block k is due at t0 + k * block_s and plays lead_s later: block 0 plays now, so the
        # first blocks go out at once and every later one lead_s ahead of the client's clock,
        # which starts at block 0's arrival (block 0 is never counted late: it cannot be early)
        self.t0 = time.monotonic() - lead_s
        self.k = 0
        self.acks: list[tuple[Any, int]] = []
        self.late = 0  # blocks finished after their play time, not yet reported
        self.late_sent = 0.0

    @property
    def due(self) -> float:
        return self.t0 + self.k * self.block_s

    @property
    def plays(self) -> float:
        """When the block being computed plays: ``lead`` after it is due."""
        return self.due + self.lead_s


def main(conn: Connection, warmup: bool, lead_s: float, nice: int = 0,
         realtime: int = 0) -> None:
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    if nice:
        # An audio process needs little CPU but needs it on time: a negative niceness puts it
        # ahead of renders and other load (as audio servers raise their priority).  Without the
        # privilege it runs at the default priority, and says so.
        try:
            os.setpriority(os.PRIO_PROCESS, 0, nice)
        except OSError as exc:
            print(f"live worker: niceness {nice} not set ({exc}); running at the default",
                  flush=True)
    import engine

    t0 = time.perf_counter()
    if warmup:
        warm_up(engine)
    frozen = heap.freeze_warm_up()
    if realtime:
        _realtime(realtime)
    try:
        conn.send(("ready", os.getpid(), time.perf_counter() - t0, frozen))
        _serve(conn, engine, lead_s)
    except (BrokenPipeError, EOFError, ConnectionResetError):
        pass


def warm_up(engine: Any) -> None:
    """The kernels loaded, the default guitar prepared on both models at 44.1 and 48 kHz, and a
    session's first calls made."""
    engine.warmup()
    for rate in (44100, 48000):
        for model in engine.MODELS:
            s = _new_session(engine, engine.parse_live_open({"sample_rate": rate,
                                                             "model": model}))
            s.push({"type": "fret", "string": 1, "fret": 2})
            s.push({"type": "pluck", "string": 1})
            s.block()


def _realtime(priority: int) -> None:
    """The audio thread (this one: it computes every block) on SCHED_RR at ``priority``: a block
    due runs at once, ahead of every normally scheduled process, whatever their niceness (the
    kernel still keeps 5 % of each second for them: sched_rt_runtime_us).  The session
    preparer's thread goes back to normal scheduling (``_normal_scheduling``): preparing a guitar
    takes a fifth of a second, which must not hold a core at real-time priority."""
    try:
        os.sched_setscheduler(0, os.SCHED_RR, os.sched_param(priority))
    except (OSError, AttributeError) as exc:
        print(f"live worker: real-time priority {priority} not set ({exc}); running with "
              "normal scheduling", flush=True)


def _normal_scheduling() -> None:
    """For a thread of an audio thread: Linux threads inherit the real-time policy."""
    with contextlib.suppress(OSError, AttributeError):
        if os.sched_getscheduler(0) != os.SCHED_OTHER:
            os.sched_setscheduler(0, os.SCHED_OTHER, os.sched_param(0))


PREPARING_POLL_S = 0.01  # how often the loop looks whether a preparation has finished


def _serve(conn: Connection, engine: Any, lead_s: float) -> None:
    sessions: dict[int, _Live] = {}
    preparing: dict[int, _Preparing] = {}
    with ThreadPoolExecutor(1, thread_name_prefix="prepare",
                            initializer=_normal_scheduling) as preparer:
        while True:
            now = time.monotonic()
            wait = min((s.due for s in sessions.values()), default=now + 1.0) - now
            if preparing:
                wait = min(wait, PREPARING_POLL_S)
            if conn.poll(max(wait, 0.0)):
                while True:  # every message waiting, then the blocks due
                    msg = conn.recv()
                    if msg is None:
                        for p in preparing.values():
                            p.future.cancel()
                        return
                    _handle(conn, engine, sessions, preparing, preparer, msg, lead_s)
                    if not conn.poll(0):
                        break
            for sid in [sid for sid, p in preparing.items() if p.future.done()]:
                _prepared(conn, engine, sessions, preparing.pop(sid), sid, lead_s)
            now = time.monotonic()
            due = [(s.due, sid) for sid, s in sessions.items() if s.due <= now]
            heapq.heapify(due)
            while due:
                _, sid = heapq.heappop(due)
                _block(conn, sessions, sid)


def _open(conn: Connection, sessions: dict[int, _Live], sid: int, s: Any, lead_s: float) -> None:
    live = sessions[sid] = _Live(s, lead_s)
    conn.send(("opened", sid, {"sample_rate": s.sample_rate, "block_frames": s.block_frames,
                               "delay_frames": s.delay, "quality": s.quality,
                               "model": s.model,
                               "strings": s.preset.n_strings, "frets": s.preset.frets,
                               "preset": s.preset.name, "lead_s": lead_s,
                               "block_seconds": live.block_s}))


def _prepared(conn: Connection, engine: Any, sessions: dict[int, _Live], p: _Preparing, sid: int,
              lead_s: float) -> None:
    """A preparation has finished: open the session (or say why not) and play what came for it."""
    try:
        template = p.future.result()
    except Exception as exc:
        conn.send(("failed", sid, f"{type(exc).__name__}: {exc}"))
        return
    _keep(p.key, template)
    _open(conn, sessions, sid, _copy(template, p.opened), lead_s)
    for msg in p.messages:
        _handle(conn, engine, sessions, {}, None, msg, lead_s)


def _handle(conn: Connection, engine: Any, sessions: dict[int, _Live],
            preparing: dict[int, _Preparing], preparer: ThreadPoolExecutor | None, msg: tuple,
            lead_s: float) -> None:
    kind, sid = msg[0], msg[1]
    if sid in preparing:  # not open yet: kept until it is, or forgotten with it
        if kind == "close":
            p = preparing.pop(sid)
            if not any(q.future is p.future for q in preparing.values()):
                p.future.cancel()  # not started yet: dropped; under way: it runs out, unused
        else:
            preparing[sid].messages.append(msg)
        return
    if kind == "open":
        try:
            opened = engine.parse_live_open(msg[2])
            key = _key(opened)
            template = _TEMPLATES.get(key)
            if template is None and preparer is not None:
                same = next((p.future for p in preparing.values() if p.key == key), None)
                preparing[sid] = _Preparing(opened, key,
                                            same or preparer.submit(_prepare, engine, opened))
                return
            if template is None:
                template = _prepare(engine, opened)
            _keep(key, template)
            s = _copy(template, opened)
        except Exception as exc:
            conn.send(("failed", sid, f"{type(exc).__name__}: {exc}"))
            return
        _open(conn, sessions, sid, s, lead_s)
    elif kind == "event":
        live = sessions.get(sid)
        if live is None:
            return
        message = dict(msg[2])
        ident = message.pop("id", None)
        try:
            at = live.session.frame + message.get("offset", 0) + live.session.delay
            live.session.push(message)
            if ident is not None:
                live.acks.append((ident, at))
        except ValueError as exc:  # engine.LiveError, or a validation the parent let through
            field = getattr(exc, "field", "message")
            conn.send(("error", sid, field, getattr(exc, "message", str(exc)), ident))
    elif kind == "close":
        sessions.pop(sid, None)


def _block(conn: Connection, sessions: dict[int, _Live], sid: int) -> None:
    live = sessions[sid]
    s = live.session
    frame = s.frame
    try:
        x = s.block()
        if not np.all(np.isfinite(x)):
            raise FloatingPointError("the session's audio became non-finite")
    except Exception as exc:
        sessions.pop(sid, None)
        conn.send(("failed", sid, f"{type(exc).__name__}: {exc}"))
        return
    for ident, at in live.acks:
        conn.send(("ack", sid, ident, at))
    live.acks.clear()
    data = x.astype("<f4").tobytes()
    conn.send(("block", sid, frame, data, time.monotonic()))  # sent at: the relay is timed
    now = time.monotonic()
    if now > live.plays and live.k > 0:  # block 0 plays when the session opens (``_Live``)
        live.late += 1
    if live.late and now - live.late_sent >= 1.0:  # counted, not one message each: a worker
        conn.send(("late", sid, live.late))        # behind is not slowed down further
        live.late, live.late_sent = 0, now
    live.k += 1
