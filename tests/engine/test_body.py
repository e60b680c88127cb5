"""The modal body (``engine.output.Body``): after a long silence its resonators' states are set to
zero instead of decaying into the subnormal numbers (on which the filter ran some sixty times
slower), without moving a sample by more than 1e-190 and with the same samples however the
output is cut into blocks."""

from __future__ import annotations

import numpy as np
import pytest

from engine.output import BODIES, Body

RATE = 44100.0


def _signal(silence_s: float, channels: int) -> np.ndarray:
    """A loud burst, ``silence_s`` of silence, another burst."""
    rng = np.random.default_rng(7)
    burst = rng.standard_normal((4410, channels)) * 0.3
    return np.concatenate([burst, np.zeros((int(silence_s * RATE), channels)), burst])


@pytest.mark.parametrize("name", sorted(BODIES))
def test_a_long_silence_flushes_the_states_and_moves_no_sample(name):
    x = _signal(70.0, 1)[:, 0]  # long enough for the modes to reach the subnormals (asserted)
    end_of_silence = len(x) - 4410
    flushed, exact = Body(name, RATE, 1), Body(name, RATE, 1)
    exact.flush_below = 0.0
    a = flushed(x[:end_of_silence])
    b = exact(x[:end_of_silence])
    tiny = np.abs(exact.state[exact.state != 0.0])
    print(f"{name}: states after the silence: without the flush {tiny.min():.1e} .. "
          f"{tiny.max():.1e}, with it {np.abs(flushed.state).max():.1e}")
    assert np.all(flushed.state == 0.0)
    assert np.any(tiny < np.finfo(float).tiny)  # without it: subnormal
    a = np.concatenate([a, flushed(x[end_of_silence:])])
    b = np.concatenate([b, exact(x[end_of_silence:])])
    assert np.max(np.abs(a - b)) < 1e-190
    assert np.max(np.abs(b)) > 0.1


def test_any_blocks_give_the_same_samples():
    """The flush acts on the grid of the output's own sample count, not of the blocks (here it
    sets some of the states to zero during the silence, the slow modes' not yet)."""
    x = _signal(20.0, 2)
    silent = len(x) - 4410
    whole = Body("acoustic", RATE, 2)
    y = whole(x[:silent])
    flushed = whole.state == 0.0
    assert flushed.any() and not flushed.all()
    y = np.concatenate([y, whole(x[silent:])])
    body = Body("acoustic", RATE, 2)
    rng = np.random.default_rng(3)
    cuts = np.sort(rng.choice(np.arange(1, len(x)), 60, replace=False))
    parts = [body(x[i:j]) for i, j in zip(np.r_[0, cuts], np.r_[cuts, len(x)], strict=True)]
    assert np.array_equal(np.concatenate(parts), y)
