"""Run time against error: every knob that trades cost for accuracy, measured on this machine.

    python -m benchmarks.pareto [--jobs 2] [--repeat 3] [--quick] [--no-docs]

For each configuration (the three quality levels, and one knob at a time around them: internal
oversampling, the contact-resolution rule, grid spacing relative to the stability bound, the contact
formulation, the gamma rule of the DAFx24 paper's sec. 4.7, dispersion pre-compensation,
Kirchhoff-Carrier tension modulation), and for the other model, the digital waveguide
(``engine.waveguide``, the row "waveguide", with its default options), it measures, on the
steel-acoustic preset at 44.1 kHz with no body response (the strings' own sound):

cost   ms of compute per second of audio: per string (a finger at fret 5 and an 8 N pluck, the
       ``benchmarks.speed`` scene) and for a six-string scene (an F barre chord, strummed);
       CPU time of the rendering thread (other processes on the machine barely change it), best
       of ``--repeat`` rounds, simulation only, one core.
errors each against an exact or converged reference:
  * partials 1-20 of each open string against the stiff-string formula f_n = n f0 sqrt(1 + B n^2):
    from the scheme's own dispersion relation (exact for the linear scheme), worst over strings;
    and partials 1-10 and the fundamental measured on rendered audio (0.2 N pluck);
  * fretted pitch, all six strings, frets 1-12 (the ``benchmarks.intonation`` scene), cents, and
    the same notes' decay (dB/s of the fundamental, ``engine.analysis.decay_db_per_s``)
    against the converged x8 render;
  * sink: how far a string goes below a fret tip and below the fretboard (um), sampled at every
    output sample, in pressed notes (the engine's pressing force at frets 5 and 12), slams (10 N
    taps at 5 m/s) and a fret-buzz scene;
  * rendered signal against a reference render of the same scene at 16x oversampling: relative
    error of the STFT magnitude (2048-sample Hann frames, 20 Hz - 14 kHz, where the decimation
    filter is flat), dB, for a hard pluck, a fretted note, a tap and a fret-buzz scene;
  * energy balance (paper sec. 6.1) on a scene with every nonlinearity.

The waveguide is measured on the same scenes against the same finite-difference references, with
its own counterparts where a measure reads the model's state: its partials from the loop's phase
relation (``WaveguideVoice.partial_frequencies``), its sinks at its collision points (a fret's
crown or the fretboard under each grid point of the neck, on the sounding string); it has no
discrete energy balance (n/a).  The conclusions say where each model is better and how much
cheaper the waveguide is on the chord.

It prints the tables, draws the Pareto fronts to docs/img/pareto.png and rewrites the generated
section of docs/accuracy.md (between the ``pareto:begin`` / ``pareto:end`` markers) with the table
of all configurations, the targets and the conclusions; the per-string, per-scene and per-fret
tables and the fronts are printed only (``make bench`` keeps them in benchmarks/out/pareto.txt).
A run of chosen configurations (``--only``, ``--grids``) only prints.

The gamma rule and the dispersion compensation are ``RenderOptions`` switches (``gamma_rule``:
``joint`` is the engine's, ``own`` the same rule on each column's own prediction, ``paper`` eq. (61)
as printed, ``none`` no correction; ``compensate_dispersion``).
"""

from __future__ import annotations

import argparse
import math
import pathlib
import sys
import time
from dataclasses import dataclass, replace
from multiprocessing import Pool

import numpy as np
from scipy import signal

import engine
import engine.fd.instrument
import engine.fd.kernels
import engine.fd.string
import engine.models
import engine.waveguide
from benchmarks.accuracy import ENERGY_SCENES
from benchmarks.intonation import FRETS, worst
from engine.analysis import cents, decay_db_per_s, partials, spectrum_peak
from engine.fd.voice import string_model
from engine.options import QUALITY, Quality, RenderOptions
from engine.presets import PRESETS, get_preset
from engine.scene import SAMPLE_RATE_MAX, SAMPLE_RATE_MIN, Scene
from engine.testing import scenes as shared
from engine.testing.scenes import fret, pluck, tap
from engine.waveguide.collision import FRET_RESTITUTION

ROOT = pathlib.Path(__file__).resolve().parents[1]
OUT = pathlib.Path(__file__).parent / "out"
DOCS = ROOT / "docs" / "accuracy.md"
IMG = ROOT / "docs" / "img"
SR = 44100  # the study's sample rate and preset (``--sample-rate``, ``--preset``: another)
PRESET = "steel-acoustic"
BAND_HZ = (20.0, 14000.0)

# ------------------------------------------------------------------------------------------------
# configurations


@dataclass(frozen=True)
class Config:
    name: str
    knob: str
    quality: str | Quality = "standard"  # a QUALITY key (read at run time) or a Quality
    oversample: int | None = None  # force this factor on every string
    fret_mode: str | None = None
    kirchhoff_carrier: bool = True
    gamma: str = "joint"
    compensate: bool = True
    rigid_board: bool = True
    model: str = "fdtd"  # or "waveguide": the same scenes on engine.waveguide (the row "waveguide")

    @property
    def reference(self) -> bool:
        """A forced factor on every string (the x8 and x16 references and the oversampling knob):
        the live grid (``Study.live_grid``) leaves them as they are."""
        return self.oversample is not None

    def options(self, **kw) -> RenderOptions:
        q = QUALITY[self.quality] if isinstance(self.quality, str) else self.quality
        if self.fret_mode is not None:
            q = replace(q, fret_mode=self.fret_mode)
        return RenderOptions(quality=q, oversample=self.oversample,
                             kirchhoff_carrier=self.kirchhoff_carrier, gamma_rule=self.gamma,
                             compensate_dispersion=self.compensate,
                             rigid_board=self.rigid_board, **kw)


def _forced(os_: int, grid_scale: float = 1.0, **kw) -> Quality:
    return Quality(max_h_m=1.0, max_oversample=os_, grid_scale=grid_scale, **kw)


LEVEL = "quality level"
# the contact grid rules tried around standard's (the one equal to standard's is left out of the
# full study, which has standard itself; ``--only`` can still name it)
CONTACT_H_MM = (7.0, 5.5, 4.5, 3.5)
CONTACT_RULES = [Config(f"fingered h <= {h:g} mm", "contact grid rule",
                        replace(QUALITY["standard"], max_h_m=h * 1e-3)) for h in CONTACT_H_MM]
CONFIGS = [
    Config("draft", LEVEL, "draft"),
    Config("standard", LEVEL, "standard"),
    Config("high", LEVEL, "high"),
    *[Config(f"x{k} everywhere", "oversampling", _forced(k), oversample=k) for k in (2, 3, 4, 6, 8)],
    # standard and high with one knob turned (their other knobs as they are: Kirchhoff-Carrier's
    # skip tolerance, the fret calibration)
    *[c for c in CONTACT_RULES if c.quality != QUALITY["standard"]],
    Config("high, open strings too (dispersion <= 0.004 c)", "dispersion bound",
           replace(QUALITY["high"], max_dispersion_cents=0.004)),
    Config("x1, h = 1.25 h_min", "grid spacing", _forced(1, 1.25), oversample=1),
    Config("x2, h = 1.5 h_min", "grid spacing", _forced(2, 1.5), oversample=2),
    Config("x4, h = 2 h_min", "grid spacing", _forced(4, 2.0), oversample=4),
    Config("standard, penalty frets", "contact formulation", fret_mode="penalty"),
    Config("standard, penalty frets + eq. 61", "contact formulation", fret_mode="penalty",
           gamma="paper"),
    Config("x4, penalty frets", "contact formulation", _forced(4), oversample=4,
           fret_mode="penalty"),
    Config("standard, Hertzian fretboard", "contact formulation", rigid_board=False),
    Config("x4, Hertzian fretboard", "contact formulation", _forced(4), oversample=4,
           rigid_board=False),
    Config("standard, gamma eq. 61 (lambda)", "gamma rule (sec. 4.7)", gamma="paper"),
    Config("standard, gamma per column", "gamma rule (sec. 4.7)", gamma="own"),
    Config("standard, gamma = 1", "gamma rule (sec. 4.7)", gamma="none"),
    Config("standard, uncompensated", "dispersion compensation", compensate=False),
    Config("standard, no Kirchhoff-Carrier", "tension modulation", kirchhoff_carrier=False),
    Config("waveguide", "model", model="waveguide"),
]
QUICK = ("draft", "standard", "high", "x4 everywhere", "standard, gamma = 1",
         "standard, penalty frets", "waveguide")
REFERENCE = Config("reference x16", "reference", _forced(16), oversample=16)
FINE = "x8 everywhere"  # the converged reference for fretted pitch (x16 would cost 4x more)
BY_NAME = {c.name: c for c in [*CONFIGS, *CONTACT_RULES, REFERENCE]}

# ------------------------------------------------------------------------------------------------
# scenes


LOW_ACTION = {"action_nut_m": 1e-4, "action_12th_m": 5e-4}
F_BARRE = {6: 1, 5: 3, 4: 3, 3: 2, 2: 1, 1: 1}  # on six strings, 6 the lowest


@dataclass(frozen=True)
class Study:
    """The study's scenes on one preset at one sample rate.  They were chosen on the six-string
    steel-acoustic; on a guitar with fewer strings each keeps its role counted from the lowest
    string: the chord is the F barre's lowest strings (on the four-string bass E A D G at frets 1,
    3, 3, 2), the hard pluck is on the lowest string and fret buzz on the next (the A string on
    both); the fretted note, the tap and the energy scene keep strings 2 and 3 (the lowest string
    for the energy scene's string 6), the slams strings 1, 3 and the lowest.  ``live_grid``: the
    configurations (not the forced-factor references) build every string on a live session's grid
    (``RenderOptions.live_grid``: fingered, with the largest bend's headroom)."""

    preset: str = PRESET
    rate: int = SR
    live_grid: bool = False

    @property
    def strings(self) -> tuple[int, ...]:
        return tuple(range(1, get_preset(self.preset).n_strings + 1))

    def scene(self, events: list, duration: float, guitar: dict | None = None) -> dict:
        """The shared builders (engine.testing.scenes), with this study's values passed wherever
        they differ from the builders' defaults: plucks of 2 N, fingers with the engine's default
        force (None), taps of 3 N at 1.5 m/s; every scene names the preset and leaves the output at
        the fixed gain."""
        return {**shared.scene(events, duration, guitar={"preset": self.preset, **(guitar or {})},
                               output={"body": "none", "normalize": False}),
                "sample_rate": self.rate}

    def options(self, cfg: Config, **kw) -> RenderOptions:
        return cfg.options(live_grid=self.live_grid and not cfg.reference, **kw)

    @property
    def chord(self) -> dict:
        """The F barre chord, strummed (every string fingered)."""
        n = len(self.strings)
        return self.scene([fret(s, F_BARRE[s + 6 - n], force=None) for s in self.strings]
                          + [pluck(n + 1 - i, 0.05 + 0.02 * i, force=2.0)
                             for i in range(1, n + 1)], 1.0)

    @property
    def spectral(self) -> dict:
        n = len(self.strings)
        return {
            "hard pluck": self.scene([pluck(n, force=10.0, position=0.9)], 0.5),
            "fretted note": self.scene([fret(2, 5, force=None), pluck(2, 0.05, force=2.0)], 0.5),
            "tap": self.scene([tap(3, 7, force=3.0, velocity=1.5)], 0.5),
            "fret buzz": self.scene([fret(n - 1, 2, force=None),
                                     pluck(n - 1, 0.02, force=12.0, position=0.85)], 0.5,
                                    LOW_ACTION),
        }

    @property
    def sink(self) -> dict:
        n = len(self.strings)
        return {
            **{f"pressed s{s} f{q}": self.scene([fret(s, q, force=None),
                                                 pluck(s, 0.05, force=2.0)], 0.2)
               for s in self.strings for q in (5, 12)},
            **{f"slam s{s}": self.scene([tap(s, 5, force=10.0, velocity=5.0)], 0.1)
               for s in (1, 3, n)},
            "fret buzz": self.spectral["fret buzz"],
        }

    @property
    def energy(self) -> dict:
        n = len(self.strings)
        evs = ENERGY_SCENES["fret + 8 N pluck + tap (every nonlinearity)"]
        return self.scene([{**e, "string": min(e["string"], n)} for e in evs], 0.5)

    def per_string_scene(self, s: int) -> dict:
        """benchmarks.speed's full-model scene: a finger at fret 5 and an 8 N pluck."""
        return self.scene([fret(s, 5, force=None), pluck(s, 0.05, force=8.0)], 1.0)

    def label(self) -> str:
        live = ", every string on the live grid" if self.live_grid else ""
        return f"{self.preset}, {self.rate / 1000:g} kHz, no body{live}"


# ------------------------------------------------------------------------------------------------
# measurements (each one a pool job)


def prepare_for(st: Study, cfg: Config, sc: dict, **kw):
    """The scene's guitar on the configuration's model (``engine.models.prepare``; the waveguide
    reads the options the two models share, ``engine.waveguide.options_from``)."""
    scene = Scene.model_validate({**sc, "model": cfg.model})
    return engine.models.prepare(scene, st.options(cfg, **kw))


def render(st: Study, cfg: Config, sc: dict, probe=None, diagnostics: bool = False):
    eng = prepare_for(st, cfg, {**sc, "diagnostics": diagnostics}, skip_decayed=False)
    parts = []
    for block in eng.blocks(1 if probe else None):
        parts.append(block)
        if probe:
            probe(eng)
    return np.concatenate(parts), eng


def job_fretted(name: str, s: int, q: int, st: Study):
    """The benchmarks.intonation scene: finger pressed behind fret q, pluck; pitch from 0.2 s and
    the fundamental's decay."""
    cfg = BY_NAME[name]
    audio, _ = render(st, cfg, st.scene([fret(s, q, force=None), pluck(s, 0.05, force=1.0)], 1.2))
    target = get_preset(st.preset).strings[s - 1].frequency_hz * 2 ** (q / 12)
    sr = st.rate
    f = spectrum_peak(audio[int(0.2 * sr):], sr, target, 0.08)
    return ("fretted", name, (s, q)), (float(cents(f, target)), decay_db_per_s(audio, sr, f))


def job_open(name: str, s: int, st: Study):
    """Open string, 0.2 N pluck (benchmarks.accuracy's scene): the fundamental against nominal and
    partials 1-10 measured; partials 1-20 from the scheme's dispersion relation."""
    cfg = BY_NAME[name]
    sc = st.scene([{**pluck(s, force=0.2, position=0.83)}], 2.0)
    sc["output"]["pickup_position"] = 0.913
    audio, eng = render(st, cfg, sc)
    v = eng.voices[0]
    sr = st.rate
    x = audio[int(0.05 * sr):]
    if cfg.model == "waveguide":  # the loop's phase relation, its stiff string's formula
        f0, b = v.spec.frequency_hz, v.phys.inharmonicity(v.phys.length_m)
        k = np.arange(1, 21)
        target = k * f0 * np.sqrt(1.0 + b * k * k) / math.sqrt(1.0 + b)
        exact = cents(v.partial_frequencies(20), target)
        n = v.n
    else:
        m = v.model
        f0, b = m.spec.frequency_hz, m.inharmonicity()
        target = np.array([m.target_frequency(i) for i in range(1, 21)])
        exact = np.array([cents(m.frequency(i), target[i - 1]) for i in range(1, 21)])
        n = v.coefs.n
    meas = partials(x, sr, f0, 10, b)
    want = target[:10]
    return ("open", name, s), {
        "f0": float(cents(spectrum_peak(x, sr, f0), f0)),
        "p10_measured": float(np.max(np.abs(cents(meas, want)))),
        "p10": float(np.max(np.abs(exact[:10]))),
        "p20": float(np.max(np.abs(exact))),
        "oversample": v.oversample,
        "n": n,
    }


class SinkProbe:
    """Largest depth of any node below the fretboard and of any fret interpolant below its tip."""

    def __init__(self):
        self.fret = 0.0
        self.board = 0.0

    def __call__(self, eng):
        if isinstance(eng, engine.waveguide.WaveguideInstrument):
            self.waveguide(eng)
            return
        for v in eng.voices:
            g, u, n = v.geom, v.state.u, v.coefs.n
            if g.nfret:
                f = slice(0, g.nfret)  # the frets (a rigid board's nodes follow them)
                pos = g.fret_w0[f] * u[g.fret_p[f]] + g.fret_w1[f] * u[g.fret_p[f] + 1]
                self.fret = max(self.fret, float(np.max(g.fret_m0[f] - pos)))
            self.board = max(self.board, float(np.max(g.board - u[2:n + 1])))

    def waveguide(self, eng):
        """The waveguide's collision points (a fret's crown or the fretboard under each grid
        point of the neck, heights from the string's rest line) on the sounding string, between
        its termination and the bridge: how far below its obstacle each is after the step."""
        for v in eng.voices:
            if not len(v.col_n):
                continue
            s, mask, nt = v.step - 1, len(v.R) - 1, int(v.st["n_t"])
            live = (v.col_n > nt) & (v.col_n < v.n)
            n = v.col_n[live]
            depth = v.col_ref[live] - (v.R[(s - n) & mask] + v.Mb[(s + n) & mask])
            on_fret = v.col_cr[live] == FRET_RESTITUTION
            if np.any(on_fret):
                self.fret = max(self.fret, float(np.max(depth[on_fret])))
            if np.any(~on_fret):
                self.board = max(self.board, float(np.max(depth[~on_fret])))


def job_sink(name: str, key: str, st: Study):
    probe = SinkProbe()
    render(st, BY_NAME[name], st.sink[key], probe=probe)
    return ("sink", name, key), (probe.fret * 1e6, probe.board * 1e6)


def job_spectral(name: str, key: str, st: Study):
    audio, eng = render(st, BY_NAME[name], st.spectral[key])
    return ("audio", name, key), (audio, eng.voices[0].oversample)


def job_energy(name: str, st: Study):
    if not engine.models.TRAITS[BY_NAME[name].model].energy_balance:
        return ("energy", name, None), math.nan
    r = engine.render(st.energy, diagnostics=True, options=st.options(BY_NAME[name]))
    return ("energy", name, None), r.energy_error


def _run(job):
    fn, args = job
    return fn(*args)


def spectral_error_db(x: np.ndarray, ref: np.ndarray, sr: int = SR) -> float:
    """20 log10 of || |X| - |R| || / || |R| || over STFT frames, BAND_HZ only."""
    f, _, X = signal.stft(x, sr, nperseg=2048, noverlap=1536)
    _, _, R = signal.stft(ref, sr, nperseg=2048, noverlap=1536)
    band = (f >= BAND_HZ[0]) & (f <= BAND_HZ[1])
    num = np.linalg.norm(np.abs(X[band]) - np.abs(R[band]))
    return float(20.0 * np.log10(num / np.linalg.norm(np.abs(R[band])) + 1e-300))


def cpu_time(st: Study, cfg: Config, sc: dict) -> tuple[float, object]:
    """CPU seconds of the rendering thread for one render (scene preparation excluded).  CPU time
    rather than wall time: other processes on the machine then barely change it."""
    eng = prepare_for(st, cfg, sc, skip_decayed=False)
    t = time.thread_time()
    for _block in eng.blocks():
        pass
    return time.thread_time() - t, eng


def costs(st: Study, configs: list[Config], repeat: int, seconds: float) -> dict:
    """ms of compute per second of audio, per string (``Study.per_string_scene``) and for the chord
    on every string ("six"); the best of ``repeat`` rounds, each round timing every configuration
    once, after one untimed round that fills the per-process caches."""
    scenes = [(s, {**st.per_string_scene(s), "duration": seconds}) for s in st.strings]
    scenes.append(("six", {**st.chord, "duration": seconds}))
    res = {c.name: {key: math.inf for key, _ in scenes} for c in configs}
    for c in configs:
        res[c.name]["six_rounds"] = []
        for _key, sc in scenes:  # untimed: what a process computes once (the waveguide designs
            cpu_time(st, c, sc)  # a stopped loop, and analyses a finger's damping, on first use)
    for _ in range(repeat):
        for c in configs:
            for key, sc in scenes:
                t, eng = cpu_time(st, c, sc)
                res[c.name][key] = min(res[c.name][key], t / seconds * 1e3)
                if key == "six":
                    res[c.name]["os"] = {v.index: v.oversample for v in eng.voices}
                    res[c.name]["six_rounds"].append(t / seconds * 1e3)
    return res


def timing_noise(cost: dict) -> float:
    """Median over configurations of (second best - best) / best of the six-string timings: how
    far two measurements of the same work differ in this run."""
    spread = [sorted(v["six_rounds"])[1] / min(v["six_rounds"]) - 1.0
              for v in cost.values() if len(v["six_rounds"]) > 1]
    return float(np.median(spread)) if spread else 0.0


# ------------------------------------------------------------------------------------------------
# analysis


METRICS = [  # key, label, tolerance below which two values count as equal
    ("fretted", "fretted pitch vs 12-TET, worst |cents|", 0.05),
    ("fretted_vs_fine", "fretted pitch vs x8, worst |cents|", 0.05),
    ("decay_vs_fine", "fretted decay vs x8, worst |dB/s|", 0.5),
    ("p20", "partials 1-20, worst |cents|", 0.005),
    ("spectral", "spectral error, mean of 4 scenes (dB)", 0.1),
    ("fret_sink", "sink below a fret tip, playing (um)", 0.5),
    ("board_sink", "sink below the fretboard, playing (um)", 0.5),
]
SLAM = [("slam_fret_sink", "sink below a fret tip, 5 m/s taps (um)", 0.5),
        ("slam_board_sink", "sink below the fretboard, 5 m/s taps (um)", 0.5)]


def fretted_table(st: Study, res, name, i: int = 0) -> np.ndarray:
    """Cents from 12-TET (i = 0) or decay in dB/s (i = 1) of the fretted notes."""
    return np.array([[res["fretted", name, (s, q)][i] for q in FRETS] for s in st.strings])


def summarise(st: Study, names, res, cost) -> dict:
    rows = {}
    fine = fretted_table(st, res, FINE)
    fine_decay = fretted_table(st, res, FINE, 1)
    for name in names:
        fr = fretted_table(st, res, name)
        decay = fretted_table(st, res, name, 1) - fine_decay
        op = [res["open", name, s] for s in st.strings]
        sinks = [res["sink", name, k] for k in st.sink if not k.startswith("slam")]
        slams = [res["sink", name, k] for k in st.sink if k.startswith("slam")]
        spec = {k: res["spectral", name, k] for k in st.spectral}
        rows[name] = {
            "cost_six": cost[name]["six"],
            "cost_string": float(np.mean([cost[name][s] for s in st.strings])),
            "cost_strings": [cost[name][s] for s in st.strings],
            "os": cost[name]["os"],
            "fretted_table": fr,
            "fretted": float(np.max(np.abs(fr))),
            "fretted_rms": float(np.sqrt(np.mean(fr**2))),
            "fretted_vs_fine": float(np.max(np.abs(fr - fine))),
            "decay_table": decay,
            "decay_vs_fine": float(np.max(np.abs(decay))),
            "f0": max(abs(o["f0"]) for o in op),
            "p10_measured": max(o["p10_measured"] for o in op),
            "p10": max(o["p10"] for o in op),
            "p20": max(o["p20"] for o in op),
            "fret_sink": max(s[0] for s in sinks),
            "board_sink": max(s[1] for s in sinks),
            "slam_fret_sink": max(s[0] for s in slams),
            "slam_board_sink": max(s[1] for s in slams),
            "spectral_scenes": spec,
            "spectral": float(np.mean(list(spec.values()))),
            "energy": res["energy", name, None],
        }
    return rows


FASTER = 0.05  # "faster" means cheaper by more than this fraction, or by twice the timing noise


def dominates(a: dict, b: dict, margin: float, metrics=METRICS) -> bool:
    """a is faster than b (cheaper by more than ``margin``, a fraction) and more accurate: no error
    larger and at least one smaller, each beyond its tolerance."""
    if not a["cost_six"] < (1.0 - margin) * b["cost_six"]:
        return False
    return (all(a[k] <= b[k] + tol for k, _, tol in metrics)
            and any(a[k] < b[k] - tol for k, _, tol in metrics))


def front(rows: dict, key: str) -> list[str]:
    """Configurations on the (cost_six, key) Pareto front, cheapest first."""
    out, best = [], math.inf
    for name in sorted(rows, key=lambda n: (rows[n]["cost_six"], rows[n][key])):
        if rows[name][key] < best:
            out.append(name)
            best = rows[name][key]
    return out


def fmt_sink(x: float) -> str:
    return "0" if x < 1e-3 else f"{x:.1f}" if x < 100 else f"{x:.0f}"


def fmt_energy(x: float) -> str:
    """The energy balance, or n/a for a model that has none (the waveguide)."""
    return "n/a" if math.isnan(x) else f"{x:.1e}"


def md_table(head: list[str], rows: list[list[str]]) -> str:
    """A markdown table; a '|' in a cell (the labels' |cents|) is escaped, or it splits the cell."""
    def line(cells: list[str]) -> str:
        return "| " + " | ".join(c.replace("|", "\\|") for c in cells) + " |"

    return "\n".join([line(head), "|" + "---|" * len(head)] + [line(r) for r in rows])


def targets(r: dict) -> list[tuple[str, float, float]]:
    """The engine's targets for a default level (issue 27's for the fretted notes): (what, measured,
    limit)."""
    return [("open strings within +-1 cent", r["f0"], 1.0),
            ("partials 1-10 within 1 cent of the stiff-string formula",
             max(r["p10"], r["p10_measured"]), 1.0),
            ("fretted notes, frets 1-12, every string, within +-3 cents of 12-TET", r["fretted"],
             3.0),
            (f"fretted notes' decay within 3 dB/s of {FINE}'s", r["decay_vs_fine"], 3.0),
            *([] if math.isnan(r["energy"]) else [("energy balance <= 1e-11", r["energy"], 1e-11)])]


def comparison(rows: dict, a: str, b: str) -> list[str]:
    """a against b, error by error: larger, smaller or equal within the tolerances of ``dominates``."""
    out = []
    for key, label, tol in METRICS + SLAM:
        x, y = rows[a][key], rows[b][key]
        verdict = "larger" if x > y + tol else "smaller" if x < y - tol else "equal"
        out.append(f"{label}: {x:.3g} against {y:.3g}, {verdict} (tolerance {tol:g})")
    x, y = rows[a]["energy"], rows[b]["energy"]
    out.append(f"energy balance: {fmt_energy(x)} against {fmt_energy(y)}")
    x, y = rows[a]["cost_six"], rows[b]["cost_six"]
    out.append(f"cost, every string fingered: {x:.1f} against {y:.1f} ms/s ({x / y:.2f}x)")
    return [f"{a} against {b}:", *[f"  * {line}" for line in out]]


def models(rows: dict, a: str, b: str, strings: int) -> list[str]:
    """The two models side by side: where each is better (beyond the tolerances of
    ``dominates``) and how much cheaper ``a`` is on the chord with every string fingered."""
    ra, rb = rows[a], rows[b]
    better = {a: [], b: []}
    for key, label, tol in METRICS + SLAM:
        if ra[key] < rb[key] - tol:
            better[a].append(f"{label} ({ra[key]:.3g} against {rb[key]:.3g})")
        elif rb[key] < ra[key] - tol:
            better[b].append(f"{label} ({rb[key]:.3g} against {ra[key]:.3g})")
    out = [f"{a} against {b}: {rb['cost_six'] / ra['cost_six']:.1f}x cheaper on the "
           f"{strings}-string chord with every string fingered ({ra['cost_six']:.1f} against "
           f"{rb['cost_six']:.1f} ms/s), {rb['cost_string'] / ra['cost_string']:.1f}x per "
           "fingered string."]
    for who in (a, b):
        out.append(f"where {who} is better: " + ("; ".join(better[who]) or "nowhere") + ".")
    return out


def per_fret(rows: dict, configs: list[Config], key: str,
             strings: tuple[int, ...]) -> list[list[str]]:
    """Table rows of ``rows[name][key]`` (a string's frets 1-12) for each configuration and string,
    each with its worst entry."""
    return [[c.name, str(s), *[f"{x:+.1f}" for x in row], f"{worst(row):+.1f}"]
            for c in configs for s in strings for row in [rows[c.name][key][s - 1]]]


def spectral_table(st: Study, rows: dict, configs: list[Config], ref_check: dict) -> list[str]:
    spec = [[c.name, *[f"{rows[c.name]['spectral_scenes'][k]:.1f}" for k in st.spectral]]
            for c in configs]
    spec.append([f"*reference check: {FINE} against x16*", *[f"{ref_check[k]:.1f}"
                                                            for k in st.spectral]])
    return ["### Spectral error against the x16 reference, per scene (dB)",
            md_table(["configuration", *st.spectral], spec)]


def detail_tables(st: Study, rows: dict, configs: list[Config], ref_check: dict,
                  detail: bool) -> list[str]:
    """Cost per string, spectral error per scene, fretted pitch and decay per string and fret (the
    levels', or with ``detail`` every configuration's), the Pareto fronts."""
    kind = "six-string" if len(st.strings) == 6 else f"{len(st.strings)}-string"
    out = ["### Cost per string (ms per second of audio; finger at fret 5, 8 N pluck)",
           md_table(["configuration", *[f"string {s}" for s in st.strings]],
                    [[c.name, *[f"{x:.1f}" for x in rows[c.name]["cost_strings"]]]
                     for c in configs])]

    out += spectral_table(st, rows, configs, ref_check)

    fr = per_fret(rows, configs if detail else [c for c in configs if c.knob == LEVEL],
                  "fretted_table", st.strings)
    which = "configurations" if detail else "quality levels"
    out += [f"### Fretted pitch per string and fret, {which} (cents from 12-TET)",
            md_table(["configuration" if detail else "level", "string",
                      *[f"fret {q}" for q in FRETS], "worst"], fr)]

    decay_strings = st.strings if detail else st.strings[:3]
    dec = per_fret(rows, configs if detail else
                   [c for c in configs if c.knob in (LEVEL, "contact grid rule")],
                   "decay_table", decay_strings)
    out += [f"### Fretted decay per string and fret, strings {decay_strings[0]}-{decay_strings[-1]}"
            f" (dB/s of the fundamental against {FINE}; negative: dies faster)",
            md_table(["configuration", "string", *[f"fret {q}" for q in FRETS], "worst"], dec)]

    out += [f"### Pareto fronts ({kind} cost against each error, cheapest first)",
            md_table(["error", "configurations on the front"],
                     [[label, " -> ".join(front(rows, key))] for key, label, _ in METRICS + SLAM])]
    return out


def tables(st: Study, rows: dict, configs: list[Config], ref_check: dict, noise: float,
           detail: bool = False, brief: bool = False) -> str:
    """The markdown tables and the conclusions about standard (printed; ``brief`` for docs).
    ``detail`` (a run of chosen configurations): every configuration's targets, fretted pitch and
    decay on every string, and the first two compared error by error; ``brief``: only the table
    of all configurations, standard's targets and the conclusions."""
    out = []
    n = len(st.strings)
    chord = "six strings" if n == 6 else f"{n} strings"
    head = ["configuration", "knob", "x per string (fingered)", "ms/s per string",
            f"ms/s {chord}", "partials 1-20 (c)", "partials 1-10 meas. (c)", "open f0 (c)",
            "fretted vs 12-TET (c)", "fretted rms (c)", "fretted vs x8 (c)",
            "fretted decay vs x8 (dB/s)", "spectral (dB)", "fret sink (um)", "board sink (um)",
            "slam: fret sink (um)", "slam: board sink (um)", "energy"]
    body = []
    for c in configs:
        r = rows[c.name]
        body.append([
            c.name, c.knob, ",".join(str(r["os"].get(s, "-")) for s in st.strings),
            f"{r['cost_string']:.1f}", f"{r['cost_six']:.1f}", f"{r['p20']:.3f}",
            f"{r['p10_measured']:.3f}", f"{r['f0']:.3f}", f"{r['fretted']:.2f}",
            f"{r['fretted_rms']:.2f}", f"{r['fretted_vs_fine']:.2f}",
            f"{r['decay_vs_fine']:.1f}", f"{r['spectral']:.1f}", fmt_sink(r["fret_sink"]),
            fmt_sink(r["board_sink"]), fmt_sink(r["slam_fret_sink"]),
            fmt_sink(r["slam_board_sink"]), fmt_energy(r["energy"])])
    out += ["### All configurations", md_table(head, body)]

    levels = []
    for c in [c for c in configs if c.knob == LEVEL]:
        r, q = rows[c.name], QUALITY[c.name]
        params = (f"max_h_m {q.max_h_m:g}, max_dispersion_cents {q.max_dispersion_cents:g}, "
                  f"max_oversample {q.max_oversample}, fret_mode {q.fret_mode}, "
                  f"grid_scale {q.grid_scale:g}")
        levels.append([c.name, params, ",".join(str(r["os"].get(s, "-")) for s in st.strings),
                       f"{r['cost_six']:.1f}", f"{r['cost_string']:.1f}", f"{r['f0']:.3f}",
                       f"{r['p10']:.3f} / {r['p10_measured']:.3f}", f"{r['p20']:.3f}",
                       f"{r['fretted']:.2f}", f"{r['fretted_vs_fine']:.2f}",
                       f"{r['decay_vs_fine']:.1f}", f"{r['spectral']:.1f}", f"{r['energy']:.1e}"])
    out += [] if not levels or brief else [
            "### Quality levels (the scene's `quality`; `engine.options.QUALITY`)",
            md_table(["level", "Quality", "x per string (fingered)", f"ms/s {chord}",
                      "ms/s per string", "open f0 (c)", "partials 1-10 exact / measured (c)",
                      "partials 1-20 (c)", "fretted vs 12-TET (c)", "fretted vs x8 (c)",
                      "fretted decay vs x8 (dB/s)", "spectral (dB)", "energy"], levels)]
    for c in configs if detail else [c for c in configs if c.name == "standard"]:
        out += [f"Engine targets, {c.name} ({st.label()}):",
                md_table(["target", "measured", "limit", "met"],
                         [[t, f"{v:.3g}", f"{lim:g}", "yes" if v <= lim else "NO"]
                          for t, v, lim in targets(rows[c.name])])]

    if not brief:
        out += detail_tables(st, rows, configs, ref_check, detail)

    margin = max(FASTER, 2.0 * noise)
    notes = [f"timing noise in this run: two measurements of the same work differ by "
             f"{100 * noise:.1f} % (median); 'faster' below means cheaper by more than "
             f"{100 * margin:.0f} %, 'more accurate' no error larger and one smaller (beyond "
             f"the tolerances: 0.05 cents for fretted pitch, 0.5 dB/s for fretted decay, 0.005 "
             "cents for partials, 0.1 dB, 0.5 um)."]
    std = rows.get("standard")
    if std is not None:
        notes.append(
            f"standard: {std['cost_six']:.1f} ms per second of audio for the "
            f"{'six' if n == 6 else n}-string scene, "
            f"{std['cost_string']:.1f} per fingered string; fretted notes within "
            f"{std['fretted']:.2f} cents of 12-TET ({std['fretted_vs_fine']:.2f} from {FINE}) "
            f"and their decay within {std['decay_vs_fine']:.1f} dB/s of {FINE}'s, "
            f"partials 1-20 within {std['p20']:.3f} cents (1-10: {std['p10']:.3f} exact, "
            f"{std['p10_measured']:.3f} measured), open strings within {std['f0']:.3f} cents, "
            f"spectral error {std['spectral']:.1f} dB, sink {fmt_sink(std['fret_sink'])} um at "
            f"the frets and {fmt_sink(std['board_sink'])} um at the fretboard in playing scenes "
            f"({fmt_sink(std['slam_fret_sink'])} and {fmt_sink(std['slam_board_sink'])} um in "
            f"5 m/s taps), energy balance {std['energy']:.1e}.")
        for label, metrics in (("the errors above except the 5 m/s taps", METRICS),
                               ("the errors above including the 5 m/s taps", METRICS + SLAM)):
            doms = [c.name for c in configs
                    if c.name != "standard" and dominates(rows[c.name], std, margin, metrics)]
            notes.append(f"configurations both faster and more accurate than standard on {label}: "
                         f"{', '.join(doms) if doms else 'none'}.")
        cheaper = [c.name for c in configs
                   if c.name != "standard" and dominates(rows[c.name], std, 0.0)]
        notes.append("configurations cheaper than standard by any amount and more accurate "
                     f"(5 m/s taps excluded): {', '.join(cheaper) if cheaper else 'none'}.")
    for c in configs if not brief else []:  # the docs' copy leaves out who dominates whom
        by = [d.name for d in configs
              if d.name != c.name and dominates(rows[d.name], rows[c.name], margin)]
        if by:
            notes.append(f"{c.name} is dominated by {', '.join(by)} (5 m/s taps excluded).")
    if detail and len(configs) >= 2:
        notes += comparison(rows, configs[0].name, configs[1].name)
    wg = rows.get("waveguide")
    if std is not None and wg is not None:
        notes += models(rows, "waveguide", "standard", n)
    out += ["### Conclusions printed by the script",
            "\n".join(x if x.startswith("  ") else f"* {x}" for x in notes)]
    return "\n\n".join(out) + "\n"


def plot(rows: dict, configs: list[Config], path: pathlib.Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    panels = [("fretted", "fretted pitch vs 12-TET, worst |cents|", "linear"),
              ("fretted_vs_fine", f"fretted pitch vs {FINE}, worst |cents|", "linear"),
              ("decay_vs_fine", f"fretted decay vs {FINE}, worst |dB/s|", "linear"),
              ("p20", "partials 1-20 vs stiff string, worst |cents|", "log"),
              ("spectral", "spectral error vs x16, mean of 4 scenes (dB)", "linear"),
              ("fret_sink", "sink below a fret tip, playing (um)", "symlog"),
              ("board_sink", "sink below the fretboard, playing (um)", "symlog"),
              ("slam_fret_sink", "sink below a fret tip, 5 m/s taps (um)", "symlog"),
              ("slam_board_sink", "sink below the fretboard, 5 m/s taps (um)", "symlog")]
    knobs = list(dict.fromkeys(c.knob for c in configs))
    colours = dict(zip(knobs, plt.rcParams["axes.prop_cycle"].by_key()["color"] * 2, strict=False))
    fig, axes = plt.subplots(3, 3, figsize=(18, 13))
    for ax, (key, label, scale) in zip(axes.flat, panels, strict=True):
        for c in configs:
            r = rows[c.name]
            y = max(r[key], 1e-16) if scale == "log" else r[key]
            lvl = c.knob == LEVEL
            ax.scatter(r["cost_six"], y, color=colours[c.knob], s=90 if lvl else 30,
                       marker="*" if lvl else "o", zorder=3,
                       label=c.knob if c.name == next(d.name for d in configs if d.knob == c.knob)
                       else None)
            if lvl or c.knob == "model":
                ax.annotate(c.name, (r["cost_six"], y), textcoords="offset points", xytext=(5, 5))
        fr = front(rows, key)
        ax.step([rows[n]["cost_six"] for n in fr], [rows[n][key] for n in fr], where="post",
                color="k", lw=0.8, alpha=0.6)
        ax.set_xscale("log")
        if scale == "symlog":
            ax.set_yscale("symlog", linthresh=1.0)
            ax.set_ylim(0.0, 3.0 * max(rows[c.name][key] for c in configs) + 1.0)
        else:
            ax.set_yscale(scale)
        ax.set_xlabel("ms of compute per second of audio (six-string scene)")
        ax.set_title(label)
        ax.grid(True, which="both", alpha=0.3)
    axes.flat[0].legend(fontsize=8)
    fig.suptitle("Run time against error (steel-acoustic, 44.1 kHz; black: Pareto front)")
    fig.tight_layout(rect=(0.0, 0.0, 1.0, 0.97))  # room for the title
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=80)
    plt.close(fig)


def write_docs(section: str, marker: str, text: str) -> None:
    """Replace the text between <!-- {marker}:begin --> and <!-- {marker}:end --> in DOCS."""
    begin, end = f"<!-- {marker}:begin -->", f"<!-- {marker}:end -->"
    doc = DOCS.read_text() if DOCS.exists() else "# Accuracy and cost\n"
    block = f"{begin}\n{text.rstrip()}\n{end}"
    if begin in doc and end in doc:
        doc = doc[:doc.index(begin)] + block + doc[doc.index(end) + len(end):]
    else:
        doc = doc.rstrip() + f"\n\n## {section}\n\n{block}\n"
    DOCS.write_text(doc)


def grids(configs: list[Config], rates=(22050, 32000, 44100, 48000, 88200, 96000)) -> str:
    """Each configuration's oversampling factor for every string with a finger on it, on every
    preset at each rate, plain and on the live grid: where two configurations' rows are equal,
    they render the same samples (no scene of the study bends a string).  No rendering."""
    configs = [c for c in configs if engine.models.TRAITS[c.model].grid]  # a grid factor
    head = ["preset", "sample rate", "grid", *[c.name for c in configs], "same"]
    body = []
    for preset in sorted(PRESETS):
        for rate in rates:
            for live in (False, True):
                st = Study(preset, rate, live)
                sc = Scene.model_validate(st.chord)
                factors = [",".join(str(string_model(
                    sc.preset(), s, [e for e in sc.events if e.string == s], rate,
                    st.options(c).quality, st.options(c))[0]) for s in st.strings)
                    for c in configs]
                body.append([preset, str(rate), "live" if live else "offline", *factors,
                             "yes" if len(set(factors)) == 1 else "no"])
    return ("Oversampling factor of every fingered string (string 1 first), from the grid rule "
            "alone:\n\n" + md_table(head, body) + "\n")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--repeat", type=int, default=3, help="timing: best of this many runs")
    ap.add_argument("--seconds", type=float, default=1.0, help="timing: seconds of audio")
    ap.add_argument("--quick", action="store_true", help="a few configurations only")
    ap.add_argument("--only", nargs="+", metavar="NAME", choices=sorted(BY_NAME),
                    help="these configurations only (the first two compared error by error); "
                         "prints only")
    ap.add_argument("--preset", default=PRESET, choices=sorted(PRESETS))
    ap.add_argument("--sample-rate", type=int, default=SR)
    ap.add_argument("--live-grid", action="store_true",
                    help="the configurations on the live grid (RenderOptions.live_grid)")
    ap.add_argument("--grids", action="store_true",
                    help="print the --only configurations' grids on every preset and rate (no "
                         "rendering)")
    ap.add_argument("--no-docs", action="store_true", help="print only; leave docs/ alone")
    args = ap.parse_args()
    if not SAMPLE_RATE_MIN <= args.sample_rate <= SAMPLE_RATE_MAX:
        ap.error(f"--sample-rate: {args.sample_rate} is outside {SAMPLE_RATE_MIN}-{SAMPLE_RATE_MAX}")
    if args.jobs < 1 or args.repeat < 1 or not args.seconds > 0:
        ap.error("--jobs and --repeat must be at least 1, --seconds above 0")
    t0 = time.perf_counter()
    st = Study(args.preset, args.sample_rate, args.live_grid)
    if args.only:
        configs = [BY_NAME[n] for n in args.only]
    else:
        configs = [c for c in CONFIGS if not args.quick or c.name in QUICK]
    command = "python -m benchmarks.pareto " + " ".join(
        f'"{a}"' if " " in a else a for a in sys.argv[1:])
    if args.grids:
        print(grids(configs))
        return
    full = st == Study() and not args.only
    names = [c.name for c in configs]
    engine.warmup()  # compile once, before forking
    jobs = [(job_spectral, (REFERENCE.name, k, st)) for k in st.spectral]
    if FINE not in names:  # the fine configuration is the fretted reference and the x16 check
        jobs += [(job_spectral, (FINE, k, st)) for k in st.spectral]
        jobs += [(job_fretted, (FINE, s, q, st)) for s in st.strings for q in FRETS]
    for n in names:
        jobs += [(job_fretted, (n, s, q, st)) for s in st.strings for q in FRETS]
        jobs += [(job_open, (n, s, st)) for s in st.strings]
        jobs += [(job_sink, (n, k, st)) for k in st.sink]
        jobs += [(job_spectral, (n, k, st)) for k in st.spectral]
        jobs += [(job_energy, (n, st))]
    jobs.sort(key=lambda j: 0 if BY_NAME[j[1][0]].oversample in (8, 16) else 1)  # long ones first
    res = {}
    with Pool(args.jobs) as pool:
        for key, value in pool.imap_unordered(_run, jobs):
            res[key] = value
    t_acc = time.perf_counter() - t0
    for n in [*names, FINE]:
        for k in st.spectral:
            if ("audio", n, k) not in res:
                continue
            x, _ = res["audio", n, k]  # every factor lines up in time (output.Decimator)
            ref, _ = res["audio", REFERENCE.name, k]
            res["spectral", n, k] = spectral_error_db(x, ref, st.rate)
    ref_check = {k: res["spectral", FINE, k] for k in st.spectral}
    cost = costs(st, configs, args.repeat, args.seconds)
    rows = summarise(st, names, res, cost)
    body = tables(st, rows, configs, ref_check, timing_noise(cost), detail=bool(args.only))
    print(f"{st.label()}; {len(configs)} configurations; costs are the CPU "
          f"time of the rendering thread, best of {args.repeat} rounds on this machine "
          f"({args.seconds:g} s of audio)\n")
    print(body)
    elapsed = time.perf_counter() - t0
    print(f"\n({t_acc:.0f} s of error measurements on {args.jobs} processes, "
          f"{elapsed - t_acc:.0f} s of timing, {elapsed:.0f} s in all)")
    if full and not args.no_docs:
        plot(rows, configs, IMG / "pareto.png")
        brief = tables(st, rows, configs, ref_check, timing_noise(cost), brief=True)
        write_docs("Measured: run time against error", "pareto",
                   f"Printed by `{command.strip()}` ({len(configs)} configurations, "
                   f"costs: CPU time, best of {args.repeat} rounds; {elapsed:.0f} s on this "
                   "machine; the per-string, per-scene and per-fret tables are in its printed "
                   "output).\n\n![Pareto fronts](img/pareto.png)\n\n" + brief)


if __name__ == "__main__":
    main()
