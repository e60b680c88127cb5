"""A track's effects chain (``engine.effect_specs``), run by Spotify's ``pedalboard``.

The chain is one ``pedalboard.Pedalboard`` per track, fed block by block with ``reset=False``: its
plugins keep their state (a delay line, a reverb's comb filters, a compressor's envelope) across
blocks, so the blocks of a stream concatenate to the render of the whole scene
(``tests/engine/test_tracks.py``, bit for bit).  ``convolution`` takes only the built-in bodies'
responses, which are sums of decaying sinusoids: it runs as their recursive modal filter
(``output.Body``), which is exact convolution with the whole response and, unlike pedalboard's
partitioned FFT ``Convolution`` (whose float32 rounding depends on the block size), gives the same
samples for any block size.  Levels: the chain sees the track at the fixed output scale
(``FIXED_GAIN``: 1.0 is full scale) and its output is scaled back to pickup velocity, so the rest of
the output chain (normalisation, the fixed gain) treats a track with effects like one without.
pedalboard computes in 32-bit floats; a track with effects carries that precision.
"""

from __future__ import annotations

import numpy as np

from .effect_specs import (
    Chorus,
    Compressor,
    Convolution,
    Delay,
    Drive,
    Highpass,
    HighShelf,
    Lowpass,
    LowShelf,
    Peak,
    Reverb,
)
from .output import FIXED_GAIN, Body


def plugin(spec, rate: float):
    """The pedalboard plugin of one effect of the schema, its parameters converted from units."""
    import pedalboard as pb  # imported only when a scene has effects

    if isinstance(spec, Drive):
        return pb.Distortion(drive_db=spec.gain_db)
    if isinstance(spec, Compressor):
        return pb.Compressor(threshold_db=spec.threshold_db, ratio=spec.ratio,
                             attack_ms=1e3 * spec.attack_s, release_ms=1e3 * spec.release_s)
    if isinstance(spec, Highpass):
        return pb.HighpassFilter(cutoff_frequency_hz=spec.cutoff_hz)
    if isinstance(spec, Lowpass):
        return pb.LowpassFilter(cutoff_frequency_hz=spec.cutoff_hz)
    if isinstance(spec, Peak | LowShelf | HighShelf):
        cls = {Peak: pb.PeakFilter, LowShelf: pb.LowShelfFilter, HighShelf: pb.HighShelfFilter}
        return cls[type(spec)](cutoff_frequency_hz=spec.cutoff_hz, gain_db=spec.gain_db, q=spec.q)
    if isinstance(spec, Chorus):
        return pb.Chorus(rate_hz=spec.rate_hz, depth=spec.depth,
                         centre_delay_ms=1e3 * spec.centre_delay_s, feedback=spec.feedback,
                         mix=spec.mix)
    if isinstance(spec, Delay):
        return pb.Delay(delay_seconds=spec.delay_s, feedback=spec.feedback, mix=spec.mix)
    if isinstance(spec, Reverb):
        return pb.Reverb(room_size=spec.room_size, damping=spec.damping, width=spec.width,
                         wet_level=spec.mix, dry_level=1.0 - spec.mix)
    raise TypeError(f"not an effect: {spec!r}")


class _BodyConvolution:
    """``convolution`` with a built-in body: (1 - mix) x + mix (h * x), h the body's response."""

    def __init__(self, spec: Convolution, rate: float):
        self.spec, self.rate, self.body = spec, rate, None

    def __call__(self, x: np.ndarray) -> np.ndarray:
        if self.body is None:  # the channel count is known with the first block
            self.body = Body(self.spec.ir, self.rate, 1 if x.ndim == 1 else x.shape[1])
        return (1.0 - self.spec.mix) * x + self.spec.mix * self.body(x)


class _Board:
    """A run of pedalboard plugins (float32), fed with ``reset=False``."""

    def __init__(self, plugins: list, rate: float):
        import pedalboard as pb  # imported only when a scene has effects

        self.rate, self.board = rate, pb.Pedalboard(plugins)

    def __call__(self, x: np.ndarray) -> np.ndarray:
        y = self.board(x.astype(np.float32).T, self.rate, reset=False)  # (channels, samples)
        return np.asarray(y, dtype=np.float64).T


class Chain:
    """The effects of one track, in order, with their state carried from block to block."""

    def __init__(self, specs: list, rate: float):
        self.stages: list = []
        run: list = []
        for s in specs:
            if isinstance(s, Convolution):
                if run:
                    self.stages.append(_Board(run, float(rate)))
                    run = []
                self.stages.append(_BodyConvolution(s, float(rate)))
            else:
                run.append(plugin(s, rate))
        if run:
            self.stages.append(_Board(run, float(rate)))

    def __call__(self, x: np.ndarray) -> np.ndarray:
        """Pickup velocity in, pickup velocity out: (m,) or (m, 2)."""
        if len(x) == 0:
            return x
        y = x * FIXED_GAIN
        for stage in self.stages:
            y = np.ascontiguousarray(stage(y))
        return y / FIXED_GAIN
