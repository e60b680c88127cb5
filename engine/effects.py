"""A track's effects chain (``engine.effect_specs``), run by Spotify's ``pedalboard``.

The chain is one ``pedalboard.Pedalboard`` per track, fed block by block with ``reset=False``: its
plugins keep their state (a delay line, a reverb's comb filters, a compressor's envelope) across
blocks, so the blocks of a stream concatenate to the render of the whole scene
(``tests/engine/test_tracks.py``).  Levels: the chain sees the track at the fixed output scale
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

IR_SECONDS = 1.0  # length of a built-in convolution response


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
    if isinstance(spec, Convolution):
        ir = Body(spec.ir, rate, 1).impulse_response(int(IR_SECONDS * rate))
        return pb.Convolution(ir.astype(np.float32), mix=spec.mix, sample_rate=rate)
    raise TypeError(f"not an effect: {spec!r}")


class Chain:
    """The effects of one track, in order, with their state carried from block to block."""

    def __init__(self, specs: list, rate: float):
        import pedalboard as pb

        self.rate = float(rate)
        self.board = pb.Pedalboard([plugin(s, rate) for s in specs])

    def __call__(self, x: np.ndarray) -> np.ndarray:
        """Pickup velocity in, pickup velocity out: (m,) or (m, 2)."""
        if len(x) == 0:
            return x
        scaled = (x * FIXED_GAIN).astype(np.float32)
        y = self.board(scaled.T, self.rate, reset=False)  # pedalboard: (channels, samples)
        return np.asarray(y, dtype=np.float64).T / FIXED_GAIN
