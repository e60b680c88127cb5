"""The output chain after the strings: decimation to the output rate, pickup mix, stereo panning,
the body response and the output scale.

Body.  The DAFx24 model leaves body coupling out (its sec. 7 suggests measured responses).  A
built-in body here is a *modal* model of a guitar body seen from the bridge: a direct path plus a
bank of damped resonances (the Helmholtz air mode, the top plate's monopole and dipole modes, the
back plate), each a two-pole resonator.  Its impulse response is the sum of decaying sinusoids; the
filter bank *is* convolution with that response, computed recursively, sample by sample in a fixed
order, so the body keeps block rendering bit-identical (an FFT overlap-add would not).  After a
track falls silent its resonators' states decay towards zero for minutes and, below 1e-308, go
through the subnormal numbers, on which the processor computes far slower (a silent track's body
then took half of a song's render); so on a grid of ``FLUSH_EVERY`` samples of
the output's own count (not of the blocks: any blocks give the same samples) the states below
``FLUSH_BELOW`` are set to zero, which moves no sample by more than 1e-190
(tests/engine/test_body.py).  Mode
frequencies and Q factors are typical measured values for the two body types (Fletcher & Rossing,
*The Physics of Musical Instruments*, 2nd ed., ch. 9: steel-string and classical guitars): air mode
near 100 Hz, main top resonance near 200 Hz, higher top/back modes 250-600 Hz with Q 20-60.  A user
impulse response (any length) is applied with scipy's FFT convolution, in ``engine.render`` only.
"""

from __future__ import annotations

import math
from functools import lru_cache

import numpy as np
from numba import njit

from . import calibration_store
from .config import JIT

# Output gain for ``normalize: false`` and for streams: pickup velocity (m/s) -> full scale.  A 2 N
# strum of the six open strings peaks near 0.26 and an 8 N one near 0.8 (benchmarks/skips.py prints
# the peaks); louder scenes clip in PCM, which is what a fixed gain means.
FIXED_GAIN = 0.03
PEAK_DBFS = -1.0  # ``normalize: true`` scales the peak here
# the body's resonator states below FLUSH_BELOW are set to zero every FLUSH_EVERY samples (a power
# of two): far above the subnormal numbers, which the slowest mode (95 Hz, Q 22) takes over a
# million samples to reach from there even at 96 kHz
FLUSH_EVERY = 4096
FLUSH_BELOW = 1e-200

# (frequency Hz, Q, gain) per mode; gains relative to the direct path of 1
BODIES: dict[str, tuple[tuple[float, float, float], ...]] = {
    "acoustic": (  # steel-string dreadnought-like
        (102.0, 25.0, 3.0),  # Helmholtz air mode T(1,1)_1
        (195.0, 35.0, 4.0),  # top monopole T(1,1)_2
        (235.0, 30.0, 2.0),  # back plate T(1,1)_3
        (385.0, 40.0, 1.5),  # top cross-dipole T(2,1)
        (520.0, 45.0, 1.2),  # top long-dipole T(1,2)
        (650.0, 45.0, 0.8),
        (870.0, 50.0, 0.6),
        (1150.0, 55.0, 0.4),
    ),
    "classical": (
        (95.0, 22.0, 3.5),
        (185.0, 30.0, 4.5),
        (225.0, 28.0, 2.0),
        (400.0, 35.0, 1.5),
        (560.0, 40.0, 1.0),
        (750.0, 45.0, 0.6),
        (1000.0, 50.0, 0.4),
    ),
}


class Body:
    """A modal body filter with state kept across blocks (one per output channel)."""

    def __init__(self, name: str, rate: float, channels: int):
        # what the filter is: two bodies of one name at one rate are the same linear filter
        # (``engine.mix`` shares one between tracks)
        self.name, self.rate = name, rate
        modes = BODIES[name]
        self.coef = np.zeros((len(modes), 3))  # a1, a2, gain
        for i, (f, q, g) in enumerate(modes):
            r = math.exp(-math.pi * f / (q * rate))
            theta = 2.0 * math.pi * f / rate
            # normalised so that each resonator's gain at its peak is g
            peak = (1.0 - r) * abs(1.0 - r * complex(math.cos(2 * theta), -math.sin(2 * theta)))
            self.coef[i] = (2.0 * r * math.cos(theta), -r * r, g * peak)
        self.state = np.zeros((channels, len(modes), 2))
        self.frame = 0  # samples filtered so far (the flush grid, ``_modal``)
        self.flush_below = FLUSH_BELOW  # 0: no flush (the tests' reference)

    def __call__(self, x: np.ndarray) -> np.ndarray:
        y = np.empty_like(x)
        if x.ndim == 1:
            y[:] = _modal(x, self.coef, self.state[0], self.frame, self.flush_below)
        else:
            for ch in range(x.shape[1]):
                y[:, ch] = _modal(np.ascontiguousarray(x[:, ch]), self.coef, self.state[ch],
                                  self.frame, self.flush_below)
        self.frame += x.shape[0]
        return y

    def impulse_response(self, n: int) -> np.ndarray:
        saved = self.state.copy()
        self.state[:] = 0.0
        x = np.zeros(n)
        x[0] = 1.0
        ir = _modal(x, self.coef, self.state[0], 0, self.flush_below)
        self.state[:] = saved
        return ir


@njit(**JIT)
def _modal(x, coef, state, start, flush_below):
    """y = x + sum_m resonator_m(x): two-pole resonators y_m[n] = a1 y_m[n-1] + a2 y_m[n-2] + g x[n].
    ``start``: the output's sample index of x[0]; at every multiple of ``FLUSH_EVERY`` the states
    below ``flush_below`` (``FLUSH_BELOW``) are set to zero."""
    n = x.shape[0]
    nm = coef.shape[0]
    y = np.empty(n)
    for i in range(n):
        if (start + i) & (FLUSH_EVERY - 1) == 0:
            for m in range(nm):
                if abs(state[m, 0]) < flush_below and abs(state[m, 1]) < flush_below:
                    state[m, 0] = 0.0
                    state[m, 1] = 0.0
        acc = x[i]
        for m in range(nm):
            v = coef[m, 0] * state[m, 0] + coef[m, 1] * state[m, 1] + coef[m, 2] * x[i]
            state[m, 1] = state[m, 0]
            state[m, 0] = v
            acc += v
        y[i] = acc
    return y


def pan_gains(pan: float) -> tuple[float, float]:
    """Constant-power pan law: -1 left, 0 centre, 1 right."""
    a = (pan + 1.0) * math.pi / 4.0
    return math.cos(a), math.sin(a)


_SILENCE: dict[int, np.ndarray] = {}
_SILENCE_LENGTHS = 8  # a render's block length and its last, short block, and a few others


def silence(m: int) -> np.ndarray:
    """``m`` zeros, read-only, one array per length: what a voice that computed nothing returns
    (a sleeping or stopped string), so that ``add_to_mix`` knows it without reading it.  Only the
    last few lengths are kept: a worker renders scenes of every length, and their last blocks
    would otherwise each leave an array behind for the life of the process (one that is gone is
    merely added as zeros)."""
    z = _SILENCE.get(m)
    if z is None:
        if len(_SILENCE) >= _SILENCE_LENGTHS:  # a render's threads may evict at once
            _SILENCE.pop(next(iter(_SILENCE), None), None)
        z = np.zeros(m)
        z.flags.writeable = False
        _SILENCE[m] = z
    return z


def add_to_mix(mix: np.ndarray, y: np.ndarray, gains: tuple[float, float]) -> None:
    """Add one string's output ``y`` to ``mix``: as it is in mono, with its (left, right) pan
    ``gains`` in stereo (``mix`` of shape (frames, 2)).  ``silence`` is not added: adding +0.0
    changes no sample of a mix that starts at +0.0 (no sum of the voices' samples is -0.0)."""
    if _SILENCE.get(len(y)) is y:
        return
    if mix.ndim == 2:
        mix[:, 0] += gains[0] * y
        mix[:, 1] += gains[1] * y
    else:
        mix += y


def default_pan(n_strings: int) -> list[float]:
    """Low strings to the left, high strings to the right (as the player hears it), +-0.6."""
    if n_strings == 1:
        return [0.0]
    return [0.6 - 1.2 * i / (n_strings - 1) for i in range(n_strings)]


def convolve_ir(audio: np.ndarray, ir: np.ndarray) -> np.ndarray:
    """A user impulse response, by scipy's FFT convolution, trimmed to the input length."""
    from scipy import signal  # here: importing scipy.signal takes a second of CPU

    ir = np.asarray(ir, dtype=float)
    if audio.ndim == 1:
        return signal.fftconvolve(audio, ir)[: len(audio)]
    return np.stack([signal.fftconvolve(audio[:, c], ir)[: len(audio)]
                     for c in range(audio.shape[1])], axis=1)


def output_gain(peak: float, normalize: bool) -> float:
    """The gain from pickup velocity (m/s) to samples of a signal whose largest magnitude is
    ``peak``: the one that puts it at ``PEAK_DBFS``, or ``FIXED_GAIN`` (1 for silence)."""
    if not normalize:
        return FIXED_GAIN
    return 10.0 ** (PEAK_DBFS / 20.0) / peak if peak > 0.0 else 1.0


def largest_magnitude(x: np.ndarray) -> float:
    """max |x| (0 for no samples), without an array of magnitudes: a long render's would be as
    large as its audio."""
    return float(max(x.max(), -x.min())) if x.size else 0.0


def to_output_scale(velocity: np.ndarray, normalize: bool, in_place: bool = False) -> np.ndarray:
    """Pickup velocity (m/s) -> samples: peak at ``PEAK_DBFS``, or the fixed gain ``FIXED_GAIN``
    (``output_gain``).  ``in_place``: scale ``velocity`` itself (a long render holds one copy of
    its output)."""
    out = velocity if in_place else None
    peak = largest_magnitude(velocity) if normalize else 0.0
    if normalize and peak == 0.0:
        return velocity if in_place else velocity.copy()
    return np.multiply(velocity, output_gain(peak, normalize), out=out)


def _firwin(ntaps: int, rate_out: float, factor: int) -> tuple[float, ...]:
    from scipy import signal  # only on a machine's first use of a factor: a second of CPU

    return tuple(signal.firwin(ntaps, 0.45 * rate_out, fs=rate_out * factor,
                               window=("kaiser", 9.0))[::-1])


@lru_cache(maxsize=64)
def _stored_taps(ntaps: int, rate_out: float, factor: int) -> tuple[float, ...]:
    return calibration_store.recall("decimation_taps", (ntaps, rate_out, factor),
                                    lambda: _firwin(ntaps, rate_out, factor),
                                    sources=("output.py",))


def decimation_taps(ntaps: int, rate_out: float, factor: int) -> np.ndarray:
    """The decimator's taps, reversed: designed by scipy's ``firwin`` once per machine and kept
    in the calibration store (exact to the bit, as every value there), so that a render need not
    import scipy.signal."""
    return np.array(_stored_taps(ntaps, rate_out, factor), dtype=np.float64)


class Decimator:
    """Linear-phase FIR low-pass (scipy's firwin, Kaiser window) + downsampling by an integer
    factor, with the input history kept across blocks.  Each output sample is one dot product in a
    fixed order (``fir_decimate``), so any block size gives bit-identical samples.

    The filter's delay is removed exactly, so strings at different factors line up in time: the
    kernel's output at step n is the velocity (u^(n+1) - u^n) / k, i.e. at time (n + 1/2) k, so
    output sample m of a string at the output rate is the velocity at (m + 1/2) / rate, and at
    factor f the same time is internal step m f + (f - 1) / 2.  A linear-phase FIR of ``ntaps``
    taps delays by (ntaps - 1) / 2 internal steps: 24 f + 1 taps for odd f, 24 f + 2 for even f
    (half a step more), so that the string run ``lead`` = (ntaps - 1) / 2 + (f - 1) / 2 steps
    ahead (an integer) gives output m centred on exactly that time.  The first output is taken
    at input index ``lead``; the string simply runs ``lead`` steps past the last frame.
    """

    def __init__(self, factor: int, rate_out: float):
        self.factor = factor
        self.pos = 0  # inputs consumed so far
        self.lead = 0
        if factor > 1:
            ntaps = 24 * factor + (1 if factor % 2 else 2)
            self.lead = (ntaps - 1 + factor - 1) // 2
            self.taps = decimation_taps(ntaps, float(rate_out), factor)
            self.history = np.zeros(ntaps - 1)

    def __call__(self, x: np.ndarray) -> np.ndarray:
        """The output samples whose input (index lead + m factor) is in this block."""
        if self.factor == 1:
            return x
        buf = np.concatenate((self.history, x))
        ahead = self.lead - self.pos
        start = ahead if ahead >= 0 else ahead % self.factor
        y = fir_decimate(buf, self.taps, start, self.factor, len(x))
        self.pos += len(x)
        self.history = buf[len(x):]
        return y

    def skip(self, n: int) -> np.ndarray:
        """``self(np.zeros(n))`` while the history holds only zeros (a silent string), without
        the filter's arithmetic: as many zeros as that call gives."""
        if self.factor == 1:
            return np.zeros(n)
        ahead = self.lead - self.pos
        start = ahead if ahead >= 0 else ahead % self.factor
        self.pos += n
        return np.zeros(0 if start >= n else (n - 1 - start) // self.factor + 1)


@njit(**JIT)
def fir_decimate(buf, rtaps, start, factor, nnew):
    """y[m] = sum_i rtaps[i] buf[j + i] for the new inputs j = start, start + factor, ... (buf
    holds len(rtaps) - 1 samples of history before the nnew new ones; rtaps is time-reversed)."""
    nt = rtaps.shape[0]
    count = 0 if start >= nnew else (nnew - 1 - start) // factor + 1
    out = np.empty(count)
    for m in range(count):
        j = start + m * factor
        acc = 0.0
        for i in range(nt):
            acc += rtaps[i] * buf[j + i]
        out[m] = acc
    return out
