"""Pitch glide of hard plucks: tension modulation (E&E sec. IV-A, after Tolonen, Valimaki & Karjalainen
2000).

A displaced string is longer than at rest, so its tension rises (Kirchhoff-Carrier):

    T(t) = T0 + (E A / (2 L)) * integral_0^L u_x^2 dx                              (TVK (7))

and the wave speed, hence the pitch, with sqrt(T / T0). The paper modulates first-order allpass
delays near the bridge by the elongation; here the termination's fractional delay D is the modulated
delay (``string``): every ``GLIDE_EVERY`` samples (5.8 ms at 44.1 kHz; a glide lasts tens of
milliseconds and more) the kernel sums the squared slope over the live grid, sum_n (u(n+1) - u(n))^2
/ X (the integral above for the sounding length; the few samples of loop inside the termination's
filters are left out), and the loop period becomes P / sqrt(1 + dT / T0). E A is the preset's (the
finite-difference model's Kirchhoff-Carrier term uses the same value); ``benchmarks.waveguide``
prints both models' glides after hard plucks.

The sum leaves out the steps that touch a point of a junction whose contact has let go but whose
perturbation still leaks away (``pluck``: for 8 time constants of ``LEAK_HZ``).  That perturbation
is a dent at one or a few grid points, a spike the grid cannot resolve into the string's shape, and
its squared slope is no elongation of the string: counted, it reads a 20 N slap as more than
doubling the string's tension, and the slap's first 20 ms sound hundreds of cents sharp where the
finite-difference string glides by about ten
(``test_a_hard_slap_glides_as_the_finite_difference_string_does``).

It moves D only, whose filter is passive for every D (``string``); the modulation itself trades
energy between the waves and the string's stretch, which the rails' energy does not count
(tests/engine/waveguide/test_passivity.py checks the two apart). The cost is N operations every
``GLIDE_EVERY`` samples, and the period moves linearly in between (``kernel``). Bends and vibrato
act on the same delay (``controls``).
"""

from __future__ import annotations

import numpy as np
from numba import njit

from ..config import JIT_INLINE

GLIDE_EVERY = 256


@njit(**JIT_INLINE)
def _slope_sum(R, Mb, mask, s, n_lo, n_hi, act, nact, js_off, js_rel, js_idx, js_np, tail):
    """sum (u(n+1) - u(n))^2 over n_lo <= n < n_hi at step s, and u(n_hi)^2 (the step from n_hi
    to the bridge, where u = 0), leaving out the steps that touch a point of a junction leaking
    at s (``_leaking``).  Only the junctions listed in ``act[:nact]`` (the kernel's junctions
    whose window, onset to the end of the leak, holds s) can be leaking: a song's string has
    hundreds of junctions, a step a few."""
    leaking = False
    for a in range(nact):
        leaking |= _leaking(act[a], s, js_off, js_rel, tail)
    acc = 0.0
    prev = R[(s - n_lo) & mask] + Mb[(s + n_lo) & mask]
    if not leaking:
        for n in range(n_lo + 1, n_hi + 1):
            u = R[(s - n) & mask] + Mb[(s + n) & mask]
            d = u - prev
            prev = u
            acc += d * d
        return acc + prev * prev  # the last step, to the bridge (u = 0 there)
    # the steps that touch a leaking point, marked once: from n - 1 to n and from n to n + 1 for a
    # point n (a song's string has several junctions leaking at once)
    touched = np.zeros(n_hi + 2, np.bool_)
    for a in range(nact):
        j = act[a]
        if _leaking(j, s, js_off, js_rel, tail):
            for k in range(js_np[j]):
                p = js_idx[j, k]
                if n_lo < p <= n_hi:
                    touched[p] = True
                if n_lo <= p < n_hi:
                    touched[p + 1] = True
    for n in range(n_lo + 1, n_hi + 1):
        u = R[(s - n) & mask] + Mb[(s + n) & mask]
        d = u - prev
        prev = u
        if touched[n]:
            continue
        acc += d * d
    return acc + prev * prev


@njit(**JIT_INLINE)
def _leaking(j, s, js_off, js_rel, tail):
    """Is junction j's contact gone at step s (released) while what it put on the string still
    leaks away (``pluck``: for ``tail`` steps, 8 time constants of ``LEAK_HZ``)?"""
    gone = js_off[j] + js_rel[j]
    return gone <= s < gone + tail
