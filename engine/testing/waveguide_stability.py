"""The waveguide's numerical-safety check of a render, shared by the tests
(``tests/engine/waveguide/test_passivity.py``) and the soak (``python -m benchmarks.soak --model
waveguide``).

Every part of the waveguide is passive by construction (``engine.waveguide.pluck``, ``collision``,
``string``, ``fingering``; argued in ``test_passivity``'s docstring), so once the forces stop the
string's energy may only fall.  The waveguide has no discrete energy balance to check step by
step, as the finite-difference model's ``stability.check`` does; it is judged by the rails'
energy (``WaveguideVoice.energy``: mu X (du/dt)^2 of both travelling waves over the sounding grid),
read every ``BLOCK`` samples.  That energy leaves out what is in transit inside a termination's
filters (a few samples of the loop) and beats between partials, so it is averaged over windows:
once a string's last event and its contacts' release have passed, no window's mean may exceed the
one before by more than ``GROWTH``.  The tension modulation (``glide``) trades energy with the
string's stretch, which the rails' energy leaves out, so that window-to-window check is made with
the glide off; with it on, the energy may not rise above its first window by more than
``GROWTH``.  ``check`` renders a scene both ways.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from engine.models import PRESSED_STRING
from engine.scene import Scene
from engine.waveguide import WaveguideOptions, prepare

BLOCK = 64  # samples between two readings of the energy
GROWTH = 1e-3  # a window's mean energy over the one before (glide off) or the first (glide on)
WINDOW_S = 0.05  # the default window


@dataclass
class Report:
    """The check of one scene: every sample finite, the worst window-to-window growth of the
    energy after each string's last event (glide off), the worst rise above the first window
    (glide on), the largest pitch ratio the glide reached (read every ``BLOCK`` samples), the
    audio's length (s) and the wall time of both renders (s)."""

    finite: bool
    growth: float
    rise: float
    glide_max: float
    seconds: float
    wall: float

    @property
    def ok(self) -> bool:
        return self.finite and self.growth <= GROWTH and self.rise <= GROWTH


def energy_windows(scene: Scene, window_s: float = WINDOW_S,
                   glide: bool = False) -> tuple[bool, float, float, float]:
    """(finite, worst growth of the windowed mean energy from one window to the next, largest
    window mean over the first one less 1, largest glide ratio) of a scene rendered on the
    waveguide without the decay skip, counting each string's energy from just after its last
    event (two periods and 3 ms past it: the junctions' release)."""
    inst = prepare(scene, WaveguideOptions(skip_decayed=False, glide=glide), statics=PRESSED_STRING)
    rate = scene.sample_rate
    win = max(int(window_s * rate / BLOCK), 1)
    history: dict[int, list[float]] = {v.index: [] for v in inst.voices}
    finite = True
    glide_max = 1.0
    for block in inst.blocks(BLOCK):
        finite &= bool(np.isfinite(block).all())
        for v in inst.voices:
            glide_max = max(glide_max, float(v.st["glide"]))
            if v.step > v.timeline.last_step + 2 * v.p0 + int(0.003 * rate):
                history[v.index].append(v.energy())
    worst = above = 0.0
    for h in history.values():
        a = np.asarray(h)
        means = [a[i:i + win].mean() for i in range(0, len(a) - win + 1, win)]
        for m0, m1 in zip(means, means[1:], strict=False):
            if m0 > 0.0:
                worst = max(worst, m1 / m0 - 1.0)
        if len(means) > 1 and means[0] > 0.0:
            above = max(above, max(means[1:]) / means[0] - 1.0)
    return finite, worst, above, glide_max


def check(sc: dict, window_s: float = WINDOW_S) -> Report:
    """A scene (dict, any model: it is rendered on the waveguide) checked with the glide off (its
    growth) and on (its rise).  Raises pydantic's ValidationError for an invalid scene."""
    scene = Scene.model_validate({**sc, "model": "waveguide"})
    t = time.perf_counter()
    finite_off, growth, _, _ = energy_windows(scene, window_s)
    finite_on, _, rise, glide_max = energy_windows(scene, window_s, glide=True)
    return Report(finite_off and finite_on, growth, rise, glide_max, scene.duration,
                  time.perf_counter() - t)
