"""A live session: a guitar played event by event, its audio pulled block by block, open-ended.

    >>> s = engine.Session({"preset": "steel-acoustic"}, sample_rate=44100, block_frames=256)
    >>> s.push({"type": "pluck", "string": 1})
    >>> block = s.block()  # 256 samples at the fixed gain, as ``engine.blocks`` yields them

The session holds an instrument (``engine.instrument.Instrument``) of the model it is opened with
(``engine.models``) and asks it, never which model it is, to render a block, to compile a string
again from its events and for its delay.

Events come without ``time`` (``engine.live_events``): an event pushed between blocks acts
``offset`` frames into the next block, plus the session's ``delay``
(``Instrument.live_delay``): when a block ends, a string has already been computed some steps
beyond it (the finite-difference model's decimation filter looks ``Decimator.lead`` steps ahead,
13 frames at factors 2 and 3: 0.3 ms at 44.1 kHz).  An event acting there would change steps
already computed; acting ``delay`` frames later it changes nothing computed.

Grids.  A render chooses each string's grid from its events (a fingered string gets the finer
contact grid; a bend raises the tension the grid must stay stable at).  A session cannot know its
events in advance, so every string is built for the worst case it allows
(``RenderOptions.live_grid``): as fingered, for the largest bend of the schema
(``MAX_BEND_SEMITONES``), with every fret calibrated.  That costs more per string than a render of
the same events usually does; ``quality`` ``draft`` (the default of ``WS /live``) keeps it within
real time for six strings.

Exactness.  The kernel derives every control value from the absolute step number, so when a
block's events arrive, each string they touch has its control arrays compiled again, once, from
all its events so far (``Instrument.rebuild``, the functions ``prepare`` uses), keeping its state
(u, u1, contact and finger states, step counter).  An event appended at the current step with
the earlier ones unchanged gives the same samples as if it had been known in advance: a
session's blocks equal ``engine.blocks`` of ``scene()`` rendered with
``RenderOptions(live_grid=True)`` (``tests/engine/test_live.py``).  What makes that so, and the
rules that keep it:

* a ``release`` sets the release of the event that put the finger, bend, palm or touch there, at a
  time that has not been simulated yet;
* a ``bend`` or ``vibrato`` is refused while the string's tension is not back at its tuned value
  (an earlier bend not released and returned, a vibrato still running): the scene's breakpoints
  would interpolate between the two, which would change the past;
* a string that has decayed below ``decay_velocity`` stops being computed (it costs nothing), as in
  a render; a render knows the later events and keeps it running until the last, a session resumes
  it from its frozen state when one comes.  The difference is below the decay level (1e-7 m/s,
  -140 dB); with ``RenderOptions(skip_decayed=False)`` the samples are equal to the bit.  A string
  never played costs nothing either (at rest, nothing is computed).

Events whose effect is over (plucks past, dampers and bends released and done, fingers gone) are
dropped from a string's list as it grows, so a long session recompiles only what still acts.

The waveguide model (``model="waveguide"``, ``engine.waveguide``) plays the same way: a string's
timeline is compiled again from its events when one comes (``WaveguideVoice.rebuild``), keeping the
rails, the filters' and junctions' states and the kernel's schedules, and the samples are those
of the waveguide render of ``scene()`` with ``RenderOptions(live_grid=True)``, to the bit
(``tests/engine/test_live.py``; with the decayed-string skip off, as above).  Its ``delay`` is
``waveguide.LIVE_DELAY`` (256 frames, 5.8 ms at 44.1 kHz): the waveguide kernel fixes the
period's next stretch and the collision points it checks that far ahead, so an event must act
no sooner after the block that learns of it.  It has no grids, so ``quality`` does nothing;
``live_grid`` prepares the finger's damping of a note held at every fret (the finite-difference
held-note analysis, kept on disk per machine: ``engine.calibration_store``), so that a held note
decays as in any render of the model and no note waits for its analysis.
"""

from __future__ import annotations

from dataclasses import replace
from typing import Any

import numpy as np

from .instrument import FINGERS
from .live_events import LiveError, LiveEvent, Release, parse_live_event
from .models import prepare
from .options import RenderOptions
from .output import FIXED_GAIN
from .performance import per_string
from .scene import MODELS, Bend, Fret, Guitar, Harmonic, Mute, Scene, Strum, Vibrato

# a string's event list is pruned when it grows past this many events: a compilation costs in
# proportion to the events it reads, and pruning them costs less than reading them
# (``benchmarks.live_blocks``)
_PRUNE_AT = 16


class Session:
    """One open-ended performance on one guitar (mono, at the fixed gain)."""

    def __init__(self, guitar: dict | Guitar | str | None = None, sample_rate: int = 44100,
                 block_frames: int = 256, quality: str = "draft",
                 options: RenderOptions | None = None, record: bool = False,
                 model: str = "fdtd"):
        if model not in MODELS:
            raise ValueError(f"model must be one of {MODELS}, not {model!r}")
        if isinstance(guitar, str):
            guitar = {"preset": guitar}
        scene = Scene(duration=1.0, sample_rate=sample_rate, guitar=guitar or {}, quality=quality,
                      model=model)
        self.options = replace(options or RenderOptions(), skip_silent=False, live_grid=True)
        self.model = model
        self.instrument = prepare(scene, self.options)
        self.instrument.at_rest()  # nothing to compute until an event comes
        self.guitar_spec = scene.guitar
        self.preset = self.instrument.preset
        self.sample_rate = sample_rate
        self.block_frames = block_frames
        self.quality = quality
        # frames after the block boundary where an event acts (see the module's docstring)
        self.delay = self.instrument.live_delay
        self.frame = 0  # frames sent so far
        self._events: dict[int, list] = {v.index: [] for v in self.voices}
        self._pending: list[tuple[int, Any]] = []  # (frame it acts at, event with its time)
        self._stale: set[int] = set()  # strings whose controls wait for the block's events
        self.record = record
        self.recorded: list = []  # every event as the scene has it (when recording)

    @property
    def voices(self) -> list:
        return self.instrument.voices

    # ---- events -----------------------------------------------------------------------------

    def push(self, message: dict | LiveEvent) -> None:
        """Validate an event (``engine.live_events.parse_live_event``) and schedule it for the next
        block; raises ``LiveError`` (naming the field) for one that cannot be played."""
        ev = (message if isinstance(message, LiveEvent)
              else parse_live_event(message, self.preset, self.block_frames))
        at = self.frame + ev.offset + self.delay
        self._check_tension(ev.event, at)
        self._pending.append((at, ev.event))

    def _check_tension(self, e: Any, at: int) -> None:
        if not isinstance(e, Bend | Vibrato):
            return
        for _at, pe in self._pending:
            if isinstance(pe, Bend | Vibrato) and pe.string == e.string:
                raise LiveError("type", f"string {e.string} already has a {pe.type} in this block")
        inst = self.instrument
        v = inst.voice(e.string)
        if not inst.tension_settled(v, at):
            t_step, _, per_frame = inst.tension_breakpoints(v)
            held = next((x for x in reversed(self._events[e.string])
                         if isinstance(x, Bend | Vibrato)), None)
            what = (f"its bend is held (send a release of string {e.string}'s bend and let it "
                    "return)" if isinstance(held, Bend)
                    and held.release is None else
                    f"its {held.type if held else 'bend'} has not returned to pitch yet "
                    f"(until {t_step[-1] / (per_frame * self.sample_rate):.3f} s)")
            raise LiveError("type", f"a {e.type} on string {e.string} must wait: {what}")

    def _apply(self, at: int, e: Any) -> None:
        t = at / self.sample_rate
        if isinstance(e, Release):
            self._release(at, e)
            return
        rel = getattr(e, "release", None)
        update: dict[str, Any] = {"time": t}
        if rel is not None:
            update["release"] = t + rel
        e = e.model_copy(update=update)
        each = per_string(e, self.preset.n_strings)  # a strum's plucks, a mute per string
        if self.record:  # a strum as itself, a string-less mute as one per string
            self.recorded += [e] if isinstance(e, Strum) else each
        for x in each:
            self._add(x.string, x)

    def _release(self, at: int, r: Release) -> None:
        t = at / self.sample_rate
        kinds = {"finger": FINGERS, "bend": (Bend,), "mute": (Mute,), "harmonic": (Harmonic,)}
        types = (tuple(x for k in kinds.values() for x in k) if r.what == "all"
                 else kinds[r.what])
        strings = [r.string] if r.string is not None else list(self._events)
        for s in strings:
            changed = False
            events = self._events[s]
            for j, e in enumerate(events):
                if (isinstance(e, types) and not (isinstance(e, Fret) and e.fret == 0)
                        and (e.release is None or e.release > t)):
                    # a release in the frame of the event itself acts one frame later
                    late = max(t, e.time + 1.0 / self.sample_rate)
                    events[j] = e.model_copy(update={"release": late})
                    changed = True
                    if self.record:
                        k = next(i for i, x in enumerate(self.recorded) if x is e)
                        self.recorded[k] = events[j]
            if changed:
                self._stale.add(s)

    def _add(self, s: int, e: Any) -> None:
        events = self._events[s]
        events.append(e)
        events.sort(key=lambda x: x.time)  # stable: same-time events keep their order
        self._stale.add(s)

    def _compile(self, s: int) -> None:
        events = self._events[s]
        self._events[s] = self.instrument.rebuild(self.instrument.voice(s), events,
                                                  prune=len(events) > _PRUNE_AT)

    # ---- audio ------------------------------------------------------------------------------

    def block(self) -> np.ndarray:
        """The next ``block_frames`` samples (float64, mono, at the fixed gain)."""
        due = self._pending
        self._pending = []
        for at, e in due:
            self._apply(at, e)
        # A string's controls are compiled once for all the events of the block that touched it
        # (a fret, its pluck and a slide: one compilation, not three): compilations are most of
        # what a block with events costs more than one without, on a live worker's audio thread
        # (``benchmarks.live_blocks``).
        for s in sorted(self._stale):
            self._compile(s)
        self._stale.clear()
        out = self.instrument.render_frames(self.block_frames)
        self.frame = self.instrument.frame
        return out * FIXED_GAIN

    def active_strings(self) -> list[int]:
        """The strings being computed now (the others are at rest or have decayed)."""
        return [v.index for v in self.voices if not v.stopped]

    def scene(self, duration: float | None = None) -> dict:
        """The equivalent scene of what was played so far (needs ``record=True``): rendered with
        ``RenderOptions(live_grid=True)`` and the same quality, its audio is this session's."""
        if not self.record:
            raise RuntimeError("the session was not recording (record=True)")
        return {
            "duration": duration if duration is not None else self.frame / self.sample_rate,
            "sample_rate": self.sample_rate,
            "guitar": self.guitar_spec.model_dump(exclude_none=True),
            "quality": self.quality,
            "model": self.model,
            "events": [e.model_dump(exclude_none=True) for e in self.recorded],
        }

