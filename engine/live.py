"""A live session: a guitar played event by event, its audio pulled block by block, open-ended.

    >>> s = engine.Session({"preset": "steel-acoustic"}, sample_rate=44100, block_frames=256)
    >>> s.push({"type": "pluck", "string": 1})
    >>> block = s.block()  # 256 samples at the fixed gain, as ``engine.blocks`` yields them

Events come without ``time`` (``engine.live_events``): an event pushed between blocks acts
``offset`` frames into the next block, plus the session's ``delay``.  The delay is the decimation
filter's look-ahead: a string's output frame m is centred on its internal step m f + (f - 1) / 2, and
the linear-phase filter needs ``Decimator.lead`` steps past it, so when a block ends a string has
already been simulated ``lead`` steps (``ceil(lead / f)`` frames) beyond it.  An event acting there
would change steps already computed; acting ``delay`` frames later (the largest over the strings,
13 frames at factors 2 and 3: 0.3 ms at 44.1 kHz) it changes nothing computed.

Grids.  A render chooses each string's grid from its events (a fingered string gets the finer
contact grid; a bend raises the tension the grid must stay stable at).  A session cannot know its
events in advance, so every string is built for the worst case it allows
(``RenderOptions.live_grid``): as fingered, for the largest bend of the schema
(``MAX_BEND_SEMITONES``), with every fret calibrated.  That costs more per string than a render of
the same events usually does; ``quality`` ``draft`` (the default of ``WS /live``) keeps it within
real time for six strings.

Exactness.  The kernel derives every control value from the absolute step number, so when an event
arrives the string's control arrays are compiled again from all its events so far
(``Voice.rebuild``), keeping its state (u, u1, contact and finger states, step counter).  An event
appended at the current step with the earlier ones unchanged gives the same samples as if it had
been known in advance: a session's blocks equal ``engine.blocks`` of ``scene()`` rendered with
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
timeline is compiled again from its events when one comes (``waveguide.rebuild``), keeping the
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

from . import waveguide
from .fd import kernels
from .fd.instrument import prepare
from .live_events import LiveError, LiveEvent, Release, parse_live_event
from .options import RenderOptions
from .output import FIXED_GAIN
from .scene import (
    MODELS,
    Bend,
    Fret,
    Guitar,
    Harmonic,
    Mute,
    Pluck,
    PullOff,
    Scene,
    Slide,
    Strum,
    Tap,
    Vibrato,
)

_FINGERS = (Fret, Tap, Slide)  # HammerOn is a Tap
_PRUNE_AT = 64  # a string's event list is pruned when it grows past this many events
# a waveguide junction's pulse (at most 50 ms), release (at most the pulse) and leak (8 time
# constants at ``LEAK_HZ``, 64 ms) are over this long after it starts or lets go
_OVER_S = 0.2


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
        self.waveguide = model == "waveguide"
        if self.waveguide:
            g = waveguide.prepare(scene, waveguide.options_from(self.options))
        else:
            g = prepare(scene, self.options)
        self.guitar_spec = scene.guitar
        self.preset = g.preset
        self.sample_rate = sample_rate
        self.block_frames = block_frames
        self.quality = quality
        self.voices = g.voices
        self.body = g.body
        for v in self.voices:
            v.stopped = True  # at rest: nothing to compute until an event comes
        # frames after the block boundary where an event acts (see the module's docstring)
        self.delay = (waveguide.LIVE_DELAY if self.waveguide else
                      max(-(-v.decimator.lead // v.oversample) for v in self.voices))
        self.frame = 0  # frames sent so far
        self._events: dict[int, list] = {v.index: [] for v in self.voices}
        self._pending: list[tuple[int, Any]] = []  # (frame it acts at, event with its time)
        self.record = record
        self.recorded: list = []  # every event as the scene has it (when recording)

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
        step_rate = self.sample_rate
        for _at, pe in self._pending:
            if isinstance(pe, Bend | Vibrato) and pe.string == e.string:
                raise LiveError("type", f"string {e.string} already has a {pe.type} in this block")
        v = self._voice(e.string)
        if self.waveguide:  # the pitch ratio's breakpoints, at the scene's rate
            t_step, t_ratio, over = v.pb_step, v.pb_f, 1
        else:
            t_step, t_ratio, over = v.ctl.arrays.tb_step, v.ctl.arrays.tb_ratio, v.oversample
        step = at * over
        if t_step.size and (t_step[-1] > step or t_ratio[-1] != 1.0):
            held = next((x for x in reversed(self._events[e.string])
                         if isinstance(x, Bend | Vibrato)), None)
            what = (f"its bend is held (send a release of string {e.string}'s bend and let it "
                    "return)" if isinstance(held, Bend)
                    and held.release is None else
                    f"its {held.type if held else 'bend'} has not returned to pitch yet "
                    f"(until {t_step[-1] / (over * step_rate):.3f} s)")
            raise LiveError("type", f"a {e.type} on string {e.string} must wait: {what}")

    def _voice(self, string: int):
        return next(v for v in self.voices if v.index == string)

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
        n = self.preset.n_strings
        if isinstance(e, Mute) and e.string is None:  # a mute per string, as controls.expand does
            for s in range(1, n + 1):
                each = e.model_copy(update={"string": s})
                if self.record:
                    self.recorded.append(each)
                self._add(s, each)
            return
        if self.record:
            self.recorded.append(e)
        if isinstance(e, Strum):  # as controls.expand does it
            strings = sorted(e.strings or range(1, n + 1), reverse=e.direction == "down")
            dt = e.spread / max(len(strings) - 1, 1)
            for i, s in enumerate(strings):
                self._add(s, Pluck(time=t + i * dt, string=s, force=e.force, position=e.position,
                                   style=e.style))
        else:
            self._add(e.string, e)

    def _release(self, at: int, r: Release) -> None:
        t = at / self.sample_rate
        kinds = {"finger": _FINGERS, "bend": (Bend,), "mute": (Mute,), "harmonic": (Harmonic,)}
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
                self._compile(s)

    def _add(self, s: int, e: Any) -> None:
        events = self._events[s]
        events.append(e)
        events.sort(key=lambda x: x.time)  # stable: same-time events keep their order
        self._compile(s)

    def _compile(self, s: int) -> None:
        v = self._voice(s)
        events = self._events[s]
        if self.waveguide:
            if len(events) > _PRUNE_AT:
                events = self._events[s] = self._prune_waveguide(v, events)
            waveguide.rebuild(v, events)  # it runs again (a string at rest or decayed too)
            return
        old = len(v.ctl.arrays.fs_on)
        keep = list(range(old))  # the old slot of each slot kept, in order
        if len(events) > _PRUNE_AT:
            events, keep = self._prune(v, events)
            self._events[s] = events
        ctl, geom = v.rebuild(events)
        new = len(ctl.arrays.fs_on)
        take = [k if k < old else -1 for k in keep] + [-1] * (new - len(keep))  # -1: a new slot
        if take != list(range(new)):
            v.state = _with_slots(v.state, take)
        v.ctl, v.geom = ctl, geom
        v.stopped = False

    def _prune(self, v, events: list) -> tuple[list, list[int]]:
        """Drop the events whose effect is over at the voice's current step: plucks whose pulse
        has ended, fret-0 lifts past with no finger kept that they may have lifted, dampers
        released, bends and vibratos when the tension is back at
        its tuned value for good, fingers whose slot is gone (and pull-offs of their fret).  The
        samples stay the same: the kernel skips all of these (a finished pluck adds nothing, a
        released damper and a gone finger form no column, a tension of exactly 1 gives the
        unbent stencil).  Returns the events kept and the old slot of each finger slot kept."""
        step = v.step
        rate = self.sample_rate * v.oversample
        arr = v.ctl.arrays
        tension_done = (arr.tb_step.size == 0
                        or (arr.tb_step[-1] < step and arr.tb_ratio[-1] == 1.0))
        keep_slots: list[int] = []
        kept_frets: set[int] = set()
        keep = [False] * len(events)
        slot = 0
        for i, e in enumerate(events):  # fingers first: their slots are the state's
            if isinstance(e, _FINGERS) and not _is_lift(e):
                if round(e.time * rate) >= step or v.state.f_state[slot] != kernels.GONE:
                    keep[i] = True
                    keep_slots.append(slot)
                    kept_frets.add(e.to_fret if isinstance(e, Slide) else e.fret)
                slot += 1
        for i, e in enumerate(events):
            if keep[i]:
                continue
            if _is_lift(e):
                keep[i] = _lift_kept(e, events, keep, step, rate)
            elif isinstance(e, _FINGERS):
                continue
            elif round(e.time * rate) >= step:
                keep[i] = True
            elif isinstance(e, Bend | Vibrato):
                keep[i] = not tension_done
            elif isinstance(e, Mute | Harmonic):
                keep[i] = e.release is None or round(e.release * rate) >= step
            elif isinstance(e, PullOff):
                keep[i] = e.fret in kept_frets
            else:  # a pluck: its pulse lasts at most 50 ms
                keep[i] = round(e.time * rate) + round(0.05 * rate) + 1 >= step
        return [e for e, k in zip(events, keep, strict=True) if k], keep_slots

    def _prune_waveguide(self, v, events: list) -> list:
        """Drop the events whose effect is over at the waveguide voice's current step (the
        same samples: the kernel skips all of these): plucks (and pull-offs) whose junction has
        let go and leaked away, fingers lifted as long ago (and fret-0 lifts past with no finger
        kept that they may have lifted), dampers released as long ago, bends
        and vibratos when the pitch is back at its tuned value for good.  ``_OVER_S`` bounds
        each junction's pulse, release and leak (``engine.waveguide.pluck``)."""
        step = v.step
        rate = self.sample_rate
        over = round(_OVER_S * rate)
        tension_done = v.pb_step.size == 0 or (v.pb_step[-1] < step and v.pb_f[-1] == 1.0)
        # one finger per finger event, in their order (a fret 0 lifts, it puts no finger)
        fingers = iter(waveguide.timeline_of(v, events).fingers)
        keep = [False] * len(events)
        for i, e in enumerate(events):  # fingers first: a lift is kept with them
            if isinstance(e, _FINGERS) and not _is_lift(e):
                f = next(fingers)
                keep[i] = round(e.time * rate) >= step or f.rel + over >= step
        for i, e in enumerate(events):
            on = round(e.time * rate)
            if _is_lift(e):
                keep[i] = _lift_kept(e, events, keep, step, rate)
            elif isinstance(e, _FINGERS):
                continue
            elif on >= step:
                keep[i] = True
            elif isinstance(e, Bend | Vibrato):
                keep[i] = not tension_done
            elif isinstance(e, Mute | Harmonic):
                keep[i] = e.release is None or round(e.release * rate) + over >= step
            else:  # a pluck or a pull-off
                keep[i] = on + 2 * over >= step
        return [e for e, k in zip(events, keep, strict=True) if k]

    # ---- audio ------------------------------------------------------------------------------

    def block(self) -> np.ndarray:
        """The next ``block_frames`` samples (float64, mono, at the fixed gain)."""
        m = self.block_frames
        end = self.frame + m
        due = [(at, e) for at, e in self._pending]
        self._pending = []
        for at, e in due:
            self._apply(at, e)
        mix = np.zeros(m)
        for v in self.voices:
            if self.waveguide:
                mix += v.run(m)  # nothing computed while it is at rest or has decayed
                continue
            target = end * v.oversample + v.decimator.lead
            nsteps = target - v.step
            d = v.decimator
            if v.stopped and (d.factor == 1 or not d.history.any()):
                v.step += nsteps  # a silent string: nothing to compute, its output is zero
                d.pos += nsteps
                continue
            mix += d(v.run(nsteps))
        self.frame = end
        out = self.body(mix) if self.body is not None else mix
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


def _is_lift(e: Any) -> bool:
    """A ``fret`` 0: it lifts the fingers down on its string and puts none."""
    return isinstance(e, Fret) and e.fret == 0


def _lift_kept(e: Any, events: list, keep: list[bool], step: int, rate: float) -> bool:
    """Whether pruning keeps the lift ``e``: while it is still to come, or some finger kept
    (``keep``, decided first) was put down before it, which it may have lifted (without it, that
    finger would be held again when the string is compiled)."""
    return round(e.time * rate) >= step or any(
        k and isinstance(x, _FINGERS) and not _is_lift(x) and x.time <= e.time
        for x, k in zip(events, keep, strict=True))


def _with_slots(st: kernels.State, take: list[int]) -> kernels.State:
    """The state with its finger-slot arrays re-indexed: new slot j takes old slot take[j]
    (-1: a new slot, idle)."""
    idx = np.array(take, np.int64)
    new = idx < 0

    def pick(a: np.ndarray) -> np.ndarray:
        out = a[np.where(new, 0, idx)] if a.size else np.zeros(len(idx), a.dtype)
        out[new] = 0
        return out.astype(a.dtype)

    return st._replace(f_state=pick(st.f_state), f_w=pick(st.f_w), f_w1=pick(st.f_w1),
                       f_psi=pick(st.f_psi), f_bprev=pick(st.f_bprev))
