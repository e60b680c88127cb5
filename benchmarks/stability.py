"""Random valid scenes and the stability checks shared by ``tests/engine/test_stress.py`` (a short
hypothesis run in CI) and ``benchmarks/soak.py`` (a long soak).

``random_scene(draw, ...)`` builds a scene dict inside the documented ranges of ``engine.scene``:
any preset, any event type, forces and speeds up to the allowed maxima (the extremes are drawn
often), extreme but valid physical overrides, any sample rate.  ``draw`` is a ``NumpyDraw`` (soak)
or the test's hypothesis adapter, so both explore the same space and hypothesis can shrink.

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

from engine import kernels
from engine.guitar import prepare
from engine.options import RenderOptions
from engine.presets import PRESETS, get_preset, note_frequency
from engine.scene import (
    MAX_BEND_SEMITONES,
    MAX_FINGER_FORCE_N,
    MAX_PLUCK_FORCE_N,
    MAX_TAP_VELOCITY_M_S,
    SAMPLE_RATE_MAX,
    SAMPLE_RATE_MIN,
    Scene,
)

PROBE_FRAMES = 16
COMMON_RATES = (22050, 32000, 44100, 48000, 88200, 96000)
STYLES = ("finger", "pick", "slap", "pop")
NOTES = tuple(f"{n}{o}" for o in range(0, 7) for n in
              ("C", "C#", "D", "D#", "E", "F", "F#", "G", "G#", "A", "A#", "B")
              if 25.0 <= note_frequency(f"{n}{o}") <= 1400.0)
# field: (low, high, drawn on a log scale)
OVERRIDES = {
    "radius_m": (5e-5, 2e-3, True),
    "density_kg_m3": (500.0, 25000.0, True),
    "youngs_modulus_pa": (1e8, 4e11, True),
    "t60_fundamental_s": (0.05, 60.0, True),
    "t60_2khz_s": (0.02, 60.0, True),
    "saddle_setback_m": (0.0, 0.02, False),
}


class NumpyDraw:
    """The draw interface over a numpy Generator (the soak)."""

    def __init__(self, rng: np.random.Generator):
        self.rng = rng

    def integer(self, lo: int, hi: int) -> int:
        return int(self.rng.integers(lo, hi + 1))

    def real(self, lo: float, hi: float) -> float:
        return float(self.rng.uniform(lo, hi))

    def choice(self, seq):
        return seq[int(self.rng.integers(len(seq)))]

    def chance(self, p: float) -> bool:
        return bool(self.rng.random() < p)


def edge(d, lo: float, hi: float, log: bool = False, p_edge: float = 0.3) -> float:
    """A value in [lo, hi], exactly lo or hi with probability p_edge."""
    if d.chance(p_edge):
        return d.choice((lo, hi))
    if log and lo > 0:
        return min(max(math.exp(d.real(math.log(lo), math.log(hi))), lo), hi)
    return d.real(lo, hi)


def _force(d, hi: float) -> float:
    return edge(d, 1e-3, hi, log=True, p_edge=0.4) if not d.chance(0.1) else hi


def random_event(d, n_strings: int, frets: int, duration: float) -> dict:
    t = d.real(0.0, duration) if d.chance(0.8) else 0.0
    t = min(t, duration * 0.999)
    s = d.integer(1, n_strings)

    def release() -> dict:
        return {"release": t + edge(d, 1e-4, duration, log=True)} if d.chance(0.3) else {}

    kind = d.choice(("pluck", "pluck", "fret", "tap", "hammer_on", "pull_off", "slide", "bend",
                     "vibrato", "harmonic", "mute", "strum"))
    if kind == "pluck":
        ev = {"position": edge(d, 0.02, 0.98), "force": _force(d, MAX_PLUCK_FORCE_N),
              "style": d.choice(STYLES)}
        if d.chance(0.5):
            ev["duration"] = edge(d, 1e-4, 0.05, log=True)
        return {"type": kind, "time": t, "string": s, **ev}
    if kind in ("fret", "tap", "hammer_on"):
        ev = {"type": kind, "time": t, "string": s,
              "fret": d.integer(0 if kind == "fret" else 1, frets), **release()}
        if d.chance(0.7):
            ev["force"] = _force(d, MAX_FINGER_FORCE_N)
        if kind != "fret":
            ev["velocity"] = edge(d, 0.01, MAX_TAP_VELOCITY_M_S, log=True, p_edge=0.4)
        return ev
    if kind == "pull_off":
        return {"type": kind, "time": t, "string": s, "fret": d.integer(1, frets),
                "force": _force(d, MAX_PLUCK_FORCE_N)}
    if kind == "slide":
        ev = {"type": kind, "time": t, "string": s, "from_fret": d.integer(1, frets),
              "to_fret": d.integer(1, frets), "duration": edge(d, 1e-3, 10.0, log=True),
              **release()}
        if d.chance(0.7):
            ev["force"] = _force(d, MAX_FINGER_FORCE_N)
        return ev
    if kind == "bend":
        return {"type": kind, "time": t, "string": s,
                "semitones": edge(d, 0.01, MAX_BEND_SEMITONES, log=True),
                "duration": edge(d, 1e-3, 10.0, log=True), **release()}
    if kind == "vibrato":
        return {"type": kind, "time": t, "string": s, "depth_cents": edge(d, 0.1, 100.0, log=True),
                "rate_hz": edge(d, 0.5, 15.0), "duration": edge(d, 1e-3, duration, log=True)}
    if kind == "harmonic":
        where = ({"fret": d.integer(1, frets)} if d.chance(0.6)
                 else {"position": d.real(0.021, 0.979)})
        return {"type": kind, "time": t, "string": s, **where, **release()}
    if kind == "mute":
        ev = {"type": kind, "time": t, "position": edge(d, 0.7, 0.99),
              "amount": edge(d, 0.0, 1.0), **release()}
        return {**ev, "string": s} if d.chance(0.6) else ev
    strings = sorted({d.integer(1, n_strings) for _ in range(d.integer(1, n_strings))})
    ev = {"type": "strum", "time": t, "direction": d.choice(("down", "up")),
          "spread": edge(d, 0.0, 1.0), "force": _force(d, MAX_PLUCK_FORCE_N),
          "position": edge(d, 0.02, 0.98), "style": d.choice(STYLES)}
    return {**ev, "strings": strings} if d.chance(0.5) else ev


def random_scene(d, max_duration: float = 0.2, max_events: int = 12,
                 qualities=("draft",), overrides: bool = True, min_duration: float = 0.02) -> dict:
    """A scene inside the documented input ranges (it may still fail cross-field validation,
    e.g. a fret beyond a reduced fret count is never drawn, but callers should validate)."""
    name = d.choice(sorted(PRESETS))
    base = get_preset(name)
    n = base.n_strings
    guitar: dict = {"preset": name}
    if overrides and d.chance(0.6):
        strings = []
        for s in range(1, n + 1):
            if d.chance(0.4):
                o: dict = {"string": s}
                for key, (lo, hi, log) in OVERRIDES.items():
                    if d.chance(0.5):
                        o[key] = edge(d, lo, hi, log)
                if d.chance(0.3):
                    o["note"] = d.choice(NOTES)
                strings.append(o)
        if strings:
            guitar["strings"] = strings
        if d.chance(0.3):
            guitar["action_nut_m"] = edge(d, 1e-4, 3e-3, log=True)
        if d.chance(0.3):
            guitar["action_12th_m"] = edge(d, 3e-4, 8e-3, log=True)
        if d.chance(0.2):
            guitar["frets"] = d.integer(1, 24)
    frets = guitar.get("frets", base.frets)
    rate = (d.choice(COMMON_RATES) if d.chance(0.7)
            else d.integer(SAMPLE_RATE_MIN, SAMPLE_RATE_MAX))
    duration = edge(d, min_duration, max_duration, log=True, p_edge=0.2)
    events = [random_event(d, n, frets, duration) for _ in range(d.integer(1, max_events))]
    return {"duration": duration, "sample_rate": rate, "guitar": guitar, "events": events,
            "quality": d.choice(qualities), "output": {"body": "none", "normalize": False}}


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
