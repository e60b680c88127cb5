"""The physics checks of a render, shared by the tests (``tests/engine/test_stress.py`` and
others) and the soak (``benchmarks/soak.py``, thousands of random scenes from
``engine.testing.random_scenes``).

``check(scene)`` renders it with diagnostics and returns a ``Report``:

* every output sample finite (the kernel raises ``FloatingPointError`` otherwise);
* energy balance (paper sec. 6.1): max_n |H^(n+1/2) - H^(n-1/2) + k Q^n - k P^n| / [max H]_2;
* stored energy never above the initial energy plus the work done on the string:
  max_n (H^(n+1/2) - H^(-1/2) - sum_{m<=n} k P^m) / [max H]_2  (k P: the plucks, the fingers'
  pressing forces, fingers put down or lifted, tension changes; it is <= 0 when every loss Q
  (string damping, finger and damper damping, rigid-fret impacts) is >= 0);
* the dissipation of every step non-negative: min_n k Q^n / [max H]_2;
* auxiliary variables as sec. 4.7 requires: out of contact the gamma rule drives a residual psi
  to zero (and a residual psi^2 / 2 is energy the contact holds with nothing touching).  The
  fretboard's and each finger's psi and contact state are sampled at every block boundary
  (``PROBE_FRAMES`` output samples); for every run of samples out of contact lasting at least
  ``QUIET_S``, the smallest psi^2 / 2 within the run must be ~0 relative to [max H]_2.  (The
  smallest, not the last: a contact between two samples can restart psi unseen.)  The sign of
  psi itself is not checked: the rule bounds M_- psi = (psi^(n+1/2) + psi^(n-1/2)) / 2 >= 0, and
  psi^(n+1/2) alone may change sign.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import numpy as np

from engine.fd import kernels
from engine.fd.instrument import prepare
from engine.options import RenderOptions
from engine.scene import Scene

PROBE_FRAMES = 16


@dataclass
class Report:
    seconds: float = 0.0  # audio seconds
    steps: int = 0  # internal steps over all strings
    finite: bool = True
    error: str = ""  # exception raised by the engine (not a validation error), if any
    balance: float = 0.0  # energy balance, relative
    excess: float = -math.inf  # max (H - H0 - sum k P) / [max H]_2; <= ~0 expected
    q_min: float = math.inf  # min k Q / [max H]_2; >= ~0 expected
    board_residual: float = 0.0  # psi_B^2 / 2 / [max H]_2 left after contact (see PsiProbe)
    finger_residual: float = 0.0  # same for fingers
    quiet_runs: int = 0  # runs out of contact (>= QUIET_S) the residual checks looked at
    peak: float = 0.0  # largest |output| (pickup velocity, m/s)
    details: dict = field(default_factory=dict)


def _pow2(x: float) -> float:
    return 2.0 ** math.floor(math.log2(x)) if x > 0 else 0.0


class PsiProbe:
    """Samples contact and psi of the fretboard and of every finger slot at block boundaries."""

    def __init__(self, voices):
        self.voices = voices
        self.samples: dict = {}  # (string, "board" or finger slot) -> [(step, in contact, psi)]

    def __call__(self):
        for v in self.voices:
            st, g, c, a = v.state, v.geom, v.coefs, v.ctl.arrays
            n = c.n
            contact = bool(np.any(st.u[2:n + 1] < g.board))
            self._record((v.index, "board"), v, contact, float(st.psi[0]))
            for s in range(len(a.fs_on)):
                if st.f_state[s] != kernels.ACTIVE:
                    continue
                x = kernels._finger_x(a.fs_x0[s], a.fs_x1[s], a.fs_ms[s], a.fs_me[s], v.step)
                p, w0, w1 = kernels.interp(x, c.h, n)
                eta = w0 * st.u[p] + w1 * st.u[p + 1] - st.f_w[s]
                self._record((v.index, s), v, eta > 0.0, float(st.f_psi[s]))

    def _record(self, key, voice, contact: bool, psi: float):
        self.samples.setdefault(key, []).append((voice.step, contact, psi))

    def residuals(self, index: int, k: float, quiet_s: float):
        """For every run of consecutive samples out of contact lasting at least quiet_s: the
        smallest psi^2 / 2 within it, as (fretboard values, finger values)."""
        board, finger = [], []
        for (idx, what), samples in self.samples.items():
            if idx != index:
                continue
            run: list = []
            for step, contact, psi in [*samples, (0, True, 0.0)]:
                if not contact:
                    run.append((step, psi))
                    continue
                if run and (run[-1][0] - run[0][0]) * k >= quiet_s:
                    (board if what == "board" else finger).append(
                        min(0.5 * p * p for _, p in run))
                run = []
        return board, finger


QUIET_S = 1e-3  # psi must be back to ~0 within runs out of contact at least this long


def check(scene: dict, options=None, probe_frames: int = PROBE_FRAMES) -> Report:
    """Render ``scene`` with diagnostics and measure everything listed in the module docstring.
    A scene that fails validation raises the validation error (callers filter those)."""
    sc = Scene.model_validate({**scene, "diagnostics": True})
    rep = Report(seconds=sc.duration)
    try:
        eng = prepare(sc, replace(options or RenderOptions(), energy_series=True))
        probe = PsiProbe(eng.voices)
        for block in eng.blocks(probe_frames):
            if not np.all(np.isfinite(block)):
                rep.finite = False
                break
            rep.peak = max(rep.peak, float(np.max(np.abs(block))) if block.size else 0.0)
            probe()
    except FloatingPointError as e:
        rep.finite = False
        rep.error = f"FloatingPointError: {e}"
        return rep
    except Exception as e:  # an engine failure on valid input is a finding, not a crash
        rep.error = f"{type(e).__name__}: {e}"
        return rep
    for v in eng.voices:
        if not v.energy_h:
            continue
        h = np.concatenate(v.energy_h)
        q = np.concatenate(v.energy_q)
        p = np.concatenate(v.energy_p)
        rep.steps += len(h)
        scale = _pow2(float(np.max(np.abs(h))))
        rep.balance = max(rep.balance, v.energy_error())
        if scale == 0.0:
            continue
        rep.excess = max(rep.excess, float(np.max(h - v.h_start - np.cumsum(p)) / scale))
        rep.q_min = min(rep.q_min, float(np.min(q)) / scale)
        board, finger = probe.residuals(v.index, v.coefs.k, QUIET_S)
        rep.quiet_runs += len(board) + len(finger)
        if board:
            rep.board_residual = max(rep.board_residual, max(board) / scale)
        if finger:
            rep.finger_residual = max(rep.finger_residual, max(finger) / scale)
    return rep


# Limits of the checks (the test asserts them; the soak counts violations).  The balance limit is
# the one tests/engine/test_stability.py uses for random scenes; the others allow rounding only.
LIMITS = {
    "balance": 1e-10,  # per-step energy balance, relative to [max H]_2
    "excess": 1e-9,  # stored energy above initial + work in, relative (cumulative rounding)
    "q_min": -1e-12,  # most negative dissipation of one step, relative
    "board_residual": 1e-9,  # psi_B^2/2 out of contact, relative
    "finger_residual": 1e-9,
}


def violations(rep: Report) -> list[str]:
    """What ``rep`` breaks, as readable strings (empty: the scene passed)."""
    out = []
    if rep.error:
        out.append(rep.error)
    if not rep.finite:
        out.append("non-finite output")
    if rep.error or not rep.finite:
        return out
    if rep.balance > LIMITS["balance"]:
        out.append(f"energy balance {rep.balance:.2e} > {LIMITS['balance']:.0e}")
    if rep.excess > LIMITS["excess"]:
        out.append(f"stored energy above initial + work by {rep.excess:.2e} (relative)")
    if rep.q_min < LIMITS["q_min"]:
        out.append(f"negative dissipation {rep.q_min:.2e} (relative)")
    for key, label in (("board_residual", "fretboard"), ("finger_residual", "finger")):
        if getattr(rep, key) > LIMITS[key]:
            out.append(f"{label} psi^2/2 out of contact {getattr(rep, key):.2e} (relative)")
    return out
