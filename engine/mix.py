"""A scene of tracks: one instrument per track, each through its effects and fader, mixed block by
block.

A track's strings are independent of every other track's (each track is its own instrument,
``engine.instrument``, of the model the track names: ``engine.models``).  Per block, each track's
instrument renders its pickup velocity (through its body), then, in this order:

1. pan: a track with a ``pan`` is rendered mono and placed in the stereo field by the constant-power
   law (``output.pan_gains``); a track without one spreads its strings as a single guitar does
   (``output.pan``, or low strings left);
2. its effects chain (``engine.effects``: pedalboard plugins with their state kept across blocks),
   on the mono or stereo signal, so a reverb's width acts in stereo;
3. its ``gain_db`` (a fader after the effects);

and the tracks are summed.  A scene with top-level ``guitar``/``events`` is the one-track case and
renders exactly (bit for bit) as its instrument alone.

Shared bodies: the body is a linear, time-invariant filter (``output.Body``), and so are a track's
pan and gain, so tracks with no effects whose bodies are the same filter (the same body at the same
rate) are summed (panned, with their gains) before one body rather than after one body each: the
same mix up to the rounding of the sums (``tests/engine/test_tracks.py`` bounds it), for the cost
of one body where a song's five acoustic tracks ran five.  A track alone with its body keeps it,
and so renders as before to the bit.  Nothing here grows with the scene's duration:
each block is computed from the voices' states and the effects' states and handed on.

Threads (``jobs``): the strings of every track are independent until their instrument sums them, and
the kernels release the GIL, so with ``jobs`` > 1 each block's voices (of all tracks at once) are
computed by that many threads (the calling one and ``jobs`` - 1 of a pool), each taking the next
voice from one list, most costly first (by their cost in the block before), and then summed,
bodies, effects and faders applied on the calling thread in the same order as with one: the
samples are the same, bit for bit, whatever ``jobs`` is.  A block hands the pool ``jobs`` - 1
tasks, not one per voice: a song's voice is a fraction of a millisecond of a block, most of it
asleep, and a task per voice cost the threads more CPU than it gave them work.

Stems (``Mix.stems``, ``blocks(stems=True)``): each string of each track on its own, its pickup
velocity before pan, body and effects, times its track's ``gain_db``; their sum is the **dry mix**,
the scene's mix with every body, pan and effect left out (mono).  Columns in the labels' order:
track by track, within a track from the lowest string to the highest (``Stem``).
"""

from __future__ import annotations

import threading
import time
from concurrent.futures import ThreadPoolExecutor, wait
from contextlib import nullcontext
from dataclasses import dataclass, field

import numpy as np

from . import models
from .effects import Chain
from .instrument import Instrument
from .options import RenderOptions
from .output import Body, pan_gains
from .scene import Scene, Stem, frame_count


@dataclass
class Track:
    """One track prepared: its instrument, stereo place, effects and linear gain."""

    instrument: Instrument
    label: str  # for warnings; "" for a single guitar
    pan: tuple[float, float] | None  # constant-power gains when the whole track is placed
    chain: Chain | None
    gain: float
    shared: int | None = None  # the ``Mix.bodies`` its frames go through (its own body: None)

    def render_frames(self, m: int, voice_frames: list[np.ndarray] | None = None,
                      strings: np.ndarray | None = None) -> np.ndarray:
        """The track's next ``m`` frames (not yet through the body it shares, if it shares
        one); ``voice_frames``: its voices' frames computed already (``Mix._voice_frames``);
        ``strings``: its stems (``Instrument.render_frames``), times its gain."""
        y = self.instrument.render_frames(m, voice_frames, strings, body=self.shared is None)
        if strings is not None and self.gain != 1.0:
            strings *= self.gain
        if self.pan is not None:
            y = np.stack((self.pan[0] * y, self.pan[1] * y), axis=1)
        if self.chain is not None:
            y = self.chain(y)
        if self.gain != 1.0:
            y = y * self.gain
        return y


@dataclass
class Mix:
    """A scene prepared for rendering: its tracks, mixed block by block, their voices computed on
    ``jobs`` threads."""

    scene: Scene
    tracks: list[Track]
    frames: int
    frame: int = 0
    jobs: int = 1
    bodies: list[Body] = field(default_factory=list)  # each filters the sum of its tracks
    # seconds each voice (in ``voices`` order) took in the block before: the pool's order
    _cost: list[float] = field(default_factory=list, repr=False)

    def blocks(self, block_frames: int | None = None, stems: bool = False):
        """Yield the mix (pickup velocity, m/s; (m,) mono, (m, 2) stereo) block by block; with
        ``stems``, (mix, stems) pairs, stems of shape (m, len(self.stems())) in m/s."""
        bf = block_frames or self.tracks[0].instrument.options.block_frames
        width = len(self.stems()) if stems else 0
        threads = min(self.jobs, len(self.voices))
        # the calling thread is one of the ``threads``
        executor = (ThreadPoolExecutor(threads - 1, thread_name_prefix="guitar-render")
                    if threads >= 2 else nullcontext())
        with executor as pool:
            while self.frame < self.frames:
                m = min(bf, self.frames - self.frame)
                if stems:
                    s = np.zeros((m, width))
                    yield self.render_frames(m, pool, s), s
                else:
                    yield self.render_frames(m, pool)

    def render_frames(self, m: int, pool: ThreadPoolExecutor | None = None,
                      stems: np.ndarray | None = None) -> np.ndarray:
        """The next ``m`` frames of the mix; with a ``pool`` (``blocks``'), every voice's frames
        computed on its threads and this one first; ``stems``, (m, len(self.stems())) zeros:
        filled with the stems."""
        per_track = self._voice_frames(m, pool) if pool is not None else [None] * len(self.tracks)
        mix = None
        shared: list = [None] * len(self.bodies)
        at = 0
        for t, frames in zip(self.tracks, per_track, strict=True):
            n = t.instrument.preset.n_strings
            y = t.render_frames(m, frames, None if stems is None else stems[:, at:at + n])
            at += n
            if t.shared is None:
                mix = y if mix is None else mix + y
            else:
                k = t.shared
                shared[k] = y if shared[k] is None else shared[k] + y
        for body, x in zip(self.bodies, shared, strict=True):
            y = body(x)
            mix = y if mix is None else mix + y
        self.frame += m
        return mix

    def _voice_frames(self, m: int, pool: ThreadPoolExecutor) -> list[list[np.ndarray]]:
        """Every voice's next ``m`` frames, per track, computed by this thread and ``pool``'s:
        each takes the next voice of one list, most costly first (longest processing time
        first, by the block before), so that no thread is left with a long string at the end of
        the block while the others wait."""
        work = [(t.instrument, v) for t in self.tracks for v in t.instrument.voices]
        if len(self._cost) != len(work):
            self._cost = [0.0] * len(work)
        order = iter(sorted(range(len(work)), key=self._cost.__getitem__, reverse=True))
        lock = threading.Lock()
        out: list = [None] * len(work)

        def drain() -> None:
            while True:
                with lock:
                    i = next(order, None)
                if i is None:
                    return
                out[i], self._cost[i] = _timed(*work[i], m)

        # ``blocks``' pool: one thread fewer than it deals the voices to
        helpers = [pool.submit(drain) for _ in range(min(self.jobs, len(work)) - 1)]
        try:
            drain()
        finally:  # every thread done before the block is used or an error raised
            wait(helpers)
        for f in helpers:
            f.result()  # a voice's error on a pool thread
        per_track, k = [], 0
        for t in self.tracks:
            n = len(t.instrument.voices)
            per_track.append(out[k:k + n])
            k += n
        return per_track

    def stems(self) -> list[Stem]:
        """What each column of the stems holds (``Scene.stems``; a silent string's column is
        zeros)."""
        return self.scene.stems()

    @property
    def voices(self):
        return [v for t in self.tracks for v in t.instrument.voices]

    def oversample(self) -> dict[int, int]:
        """String number -> internal oversampling factor (the largest over the tracks)."""
        out: dict[int, int] = {}
        for v in self.voices:
            out[v.index] = max(out.get(v.index, 0), v.oversample)
        return out

    def energy_error(self) -> float:
        return max((t.instrument.energy_error() for t in self.tracks), default=0.0)

    def warnings(self) -> list[str]:
        """Every track's instrument's warnings, each named by its track when there are several."""
        return [f"{t.label}: {w}" if t.label else w
                for t in self.tracks for w in t.instrument.warnings()]


def _timed(instrument: Instrument, voice, m: int) -> tuple[np.ndarray, float]:
    """A voice's next ``m`` frames (``Instrument.voice_frames``) and the seconds they took."""
    t0 = time.perf_counter()
    y = instrument.voice_frames(voice, instrument.frame + m)
    return y, time.perf_counter() - t0


def prepare(scene: Scene, options: RenderOptions | None = None, jobs: int = 1,
            share_bodies: bool = True) -> Mix:
    """An instrument for every track (``models.prepare``: of the model the track names) with its
    pan, effects and gain; its blocks computed on ``jobs`` threads (``Mix``); the tracks with no
    effects and the same body through one body (``share_bodies``: the module's docstring)."""
    if jobs < 1:
        raise ValueError(f"jobs must be at least 1, not {jobs}")
    frames = frame_count(scene)
    stereo = scene.output.channels == 2
    tracks = []
    for i, (track, single) in enumerate(zip(scene.instruments(), scene.track_scenes(), strict=True)):
        placed = stereo and track.pan is not None
        if placed:  # rendered mono, then placed as a whole
            single = single.model_copy(
                update={"output": single.output.model_copy(update={"channels": 1})})
        instrument = models.prepare(single, options)
        chain = Chain(track.effects, scene.sample_rate) if track.effects else None
        tracks.append(Track(instrument, scene.track_label(i),
                            pan_gains(track.pan) if placed else None, chain,
                            10.0 ** (track.gain_db / 20.0)))
    bodies = _shared_bodies(tracks, 2 if stereo else 1) if share_bodies else []
    return Mix(scene, tracks, frames, jobs=jobs, bodies=bodies)


def _shared_bodies(tracks: list[Track], channels: int) -> list[Body]:
    """One body for each set of two or more tracks with no effects whose bodies are the same
    filter (name and rate), each such track told which (``Track.shared``)."""
    groups: dict[tuple, list[Track]] = {}
    for t in tracks:
        body = t.instrument.body
        if t.chain is None and body is not None:
            groups.setdefault((body.name, body.rate), []).append(t)
    bodies = []
    for (name, rate), members in groups.items():
        if len(members) >= 2:
            for t in members:
                t.shared = len(bodies)
            bodies.append(Body(name, rate, channels))
    return bodies
