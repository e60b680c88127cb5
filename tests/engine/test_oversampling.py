"""Strings at different internal rates line up in time: the decimator's delay is removed exactly.

Fingered strings are oversampled for contact resolution and open ones are not (engine.fd.instrument), so
a delay left in the decimation filter (24 f + 1 taps: 12 output samples) shifted them against each
other within one scene.
"""

import numpy as np
import pytest
from scipy import signal

import engine
from engine.options import RenderOptions
from engine.output import Decimator
from engine.testing.scenes import SR, pluck, scene


def _pulse(t):
    """A smooth pulse (Gaussian, sigma 0.3 ms): its spectrum is far below the filter's cutoff."""
    return np.exp(-0.5 * ((t - 0.005) / 3e-4) ** 2)


@pytest.mark.parametrize("factor", [2, 3, 4, 5, 8, 16])
def test_decimator_output_sample_m_is_the_input_at_the_same_time(factor):
    """The kernel's output at step n is the velocity at (n + 1/2) k.  Fed the samples of a smooth
    signal at (n + 1/2) / (f rate), in odd blocks, the decimator must return the signal at
    (m + 1/2) / rate, as a string at 1x does.  Half a sample of misalignment would leave an
    error of ~5 % of the peak here; the filter's passband ripple leaves ~1e-6."""
    d = Decimator(factor, SR)
    m = np.arange(600)
    n = np.arange(len(m) * factor + d.lead)  # the engine runs each string ``lead`` steps ahead
    x = _pulse((n + 0.5) / (factor * SR))
    y = np.concatenate([d(x[i:i + 37]) for i in range(0, len(x), 37)])
    assert len(y) == len(m)
    assert np.max(np.abs(y - _pulse((m + 0.5) / SR))) < 1e-4


def _lag(x, ref):
    """Cross-correlation lag (output samples) of x against ref, below 3 kHz."""
    b, a = signal.butter(4, 3000, fs=SR)
    x, ref = signal.lfilter(b, a, x), signal.lfilter(b, a, ref)
    return int(np.argmax(signal.correlate(x, ref, mode="full"))) - (len(ref) - 1)


def _onset(x):
    return int(np.argmax(np.abs(x) > 0.05 * np.max(np.abs(x))))


@pytest.mark.parametrize("factor", [2, 3, 4])
def test_a_pluck_arrives_at_the_same_output_sample_whatever_the_oversampling(factor):
    sc = {**scene([pluck(3, time=0.01, force=1.0, duration=1e-3)], duration=0.1),
          "output": {"body": "none", "normalize": False}}
    plain = engine.render(sc, options=RenderOptions(oversample=1))
    over = engine.render(sc, options=RenderOptions(oversample=factor))
    assert _lag(over, plain) == 0
    assert _onset(over) == _onset(plain)


def test_fingered_and_open_strings_of_one_scene_line_up():
    """In one standard-quality scene string 2 is fingered (oversampled) and string 1 is open (1x);
    the same pluck on both, rendered alone at 1x, sets the reference for each.  The frets stay
    where they are (no calibration): a fret moved differently on each grid changes the waveform
    the lag is measured on."""
    evs = [{"type": "fret", "time": 0.0, "string": 2, "fret": 5}, pluck(2, time=0.02),
           pluck(1, time=0.02)]
    sc = {**scene(evs, duration=0.1), "output": {"body": "none", "normalize": False}}
    same = RenderOptions(calibrate_frets=False)
    eng = engine.render(sc, diagnostics=True, options=same)
    assert eng.oversample[2] > 1 and eng.oversample[1] == 1
    for s in (1, 2):
        alone = {**sc, "events": [e for e in evs if e["string"] == s]}
        x = engine.render(alone, options=same)
        ref = engine.render(alone, options=RenderOptions(oversample=1, calibrate_frets=False))
        assert _lag(x, ref) == 0 and _onset(x) == _onset(ref)
