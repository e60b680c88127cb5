"""Events -> per-string control arrays the kernel reads (plucks, finger slots).

Times become step indices at the string's internal rate once, before the loop; the kernel derives
every control value from the global step number, so rendering in blocks of any size gives the same
samples as rendering at once.

Fingers.  A ``fret`` or ``tap`` event puts a finger (its own mass, eqs. (9)-(10)) on the string a
fraction ``FINGER_BEHIND`` of the fret spacing behind the fret, on the nut side, where players press.
A later ``fret``/``tap`` on the same string lifts the previous finger at that moment (a finger moves
by being lifted and put down again); ``fret: 0`` only lifts.  A lifted finger is pulled up with its
pressing force and leaves the model once it is ``Coefs.fg_lift`` above the string.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .kernels import interp
from .presets import Preset
from .scene import Fret, Pluck, Scene, Tap

FINGER_BEHIND = 0.3  # of the spacing between fret q-1 and fret q
TAP_GAP_S = 1e-3  # a tap starts this long (at its velocity) above the string
NEVER = np.iinfo(np.int64).max // 4


def finger_x_m(preset: Preset, fret: int) -> float:
    """Metres from the nut of a finger stopping ``fret`` (just behind it)."""
    xq = preset.fret_x_m(fret)
    return float(xq - FINGER_BEHIND * (xq - preset.fret_x_m(fret - 1)))


@dataclass
class StringControls:
    """Arrays for ``kernels.step_block``; lengths are the counts of plucks and finger slots."""

    pl_start: np.ndarray
    pl_len: np.ndarray
    pl_amp: np.ndarray
    pl_p: np.ndarray
    pl_w0: np.ndarray
    pl_w1: np.ndarray
    fs_on: np.ndarray
    fs_rel: np.ndarray
    fs_x0: np.ndarray
    fs_x1: np.ndarray
    fs_ms: np.ndarray
    fs_me: np.ndarray
    fs_force: np.ndarray
    fs_v0: np.ndarray
    fs_gap: np.ndarray
    last_step: int  # the last step at which any control changes (for the decay skip)

    @property
    def silent(self) -> bool:
        return len(self.pl_start) == 0 and len(self.fs_on) == 0

    def kernel_args(self) -> tuple:
        return (self.pl_start, self.pl_len, self.pl_amp, self.pl_p, self.pl_w0, self.pl_w1,
                self.fs_on, self.fs_rel, self.fs_x0, self.fs_x1, self.fs_ms, self.fs_me,
                self.fs_force, self.fs_v0, self.fs_gap)


def string_controls(scene: Scene, preset: Preset, string: int, h: float, n: int,
                    rate: float) -> StringControls:
    """Compile the events on ``string`` (1-based) for a grid of spacing h at ``rate`` Hz."""
    evs = sorted((e for e in scene.events if e.string == string), key=lambda e: e.time)
    length_m = preset.string_length_m(string)

    def step(t: float) -> int:
        return int(round(t * rate))

    plucks = []
    slots: list[dict] = []
    last = 0
    for e in evs:
        if isinstance(e, Pluck):
            p, w0, w1 = interp(e.position * length_m, h, n)
            ln = max(1, step(e.duration))
            plucks.append((step(e.time), ln, e.force, p, w0, w1))
            last = max(last, step(e.time) + ln)
        elif isinstance(e, Fret | Tap):
            on = step(e.time)
            last = max(last, on)
            for s in slots:  # the previous finger lifts now
                if s["rel"] > on:
                    s["rel"] = on
            if e.fret == 0:
                continue
            x = finger_x_m(preset, e.fret)
            rel = step(e.release) if e.release is not None else NEVER
            if e.release is not None:
                last = max(last, rel)
            v0 = e.velocity if isinstance(e, Tap) else 0.0
            gap = v0 * TAP_GAP_S
            slots.append(dict(on=on, rel=rel, x=x, force=e.force, v0=v0, gap=gap))
    pl = np.array(plucks, dtype=float).reshape(-1, 6)
    i64 = np.int64
    return StringControls(
        pl_start=pl[:, 0].astype(i64),
        pl_len=pl[:, 1].astype(i64),
        pl_amp=pl[:, 2].copy(),
        pl_p=pl[:, 3].astype(i64),
        pl_w0=pl[:, 4].copy(),
        pl_w1=pl[:, 5].copy(),
        fs_on=np.array([s["on"] for s in slots], i64),
        fs_rel=np.array([s["rel"] for s in slots], i64),
        fs_x0=np.array([s["x"] for s in slots], float),
        fs_x1=np.array([s["x"] for s in slots], float),
        fs_ms=np.zeros(len(slots), i64),
        fs_me=np.zeros(len(slots), i64),
        fs_force=np.array([s["force"] for s in slots], float),
        fs_v0=np.array([s["v0"] for s in slots], float),
        fs_gap=np.array([s["gap"] for s in slots], float),
        last_step=last,
    )
