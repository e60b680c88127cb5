"""How carefully to render: the quality levels a scene picks by name, and the engine-level switches
that tests and benchmarks turn (``RenderOptions``).  Plain data: nothing here computes, and the
choices of a formulation are names, which ``engine.fd`` maps to its kernels' constants (so the
cost estimate reads ``QUALITY`` in a process that never loads the kernels)."""

from __future__ import annotations

import math
from dataclasses import dataclass

# how the frets act: not at all, as one-sided rigid constraints (the stiffness -> infinity limit),
# or as the paper's penalty contacts (``engine.fd.string.FRET_MODE_CODES``)
FRET_MODES = ("none", "rigid", "penalty")
# the gradient correction of the paper's sec. 4.7 (``engine.fd.kernels.sav``: its ``GAMMA_*``)
GAMMA_RULES = ("joint", "own", "paper", "none")


@dataclass(frozen=True)
class Quality:
    """Accuracy/cost knobs; the scene's ``quality`` picks one of ``QUALITY``."""

    max_h_m: float  # strings are oversampled until their grid spacing is at most this
    max_dispersion_cents: float = math.inf  # ... and partials 1-10 are this close to f_n
    max_oversample: int = 8
    fret_mode: str = "rigid"  # one of ``FRET_MODES``
    grid_scale: float = 1.0
    # quiet steps leave Kirchhoff-Carrier out while its tension rise is below this share of T0:
    # the pitch it would add is then below about 866 x this many cents (``string.kc_skip_level``)
    kc_tolerance: float = 0.0
    # the interpolants of the frets a scene's fingers stop are calibrated on the string's grid
    # (``engine.fd.intonation``): the held note gets the fine grid's pitch.  On at draft and standard,
    # where it takes most of the grid's error out of the fretted pitch; off at high, where it cost
    # more spectral accuracy (tap, fret buzz) than it bought (docs/accuracy.md, "Quality levels")
    calibrate_frets: bool = False
    # with the frets: the contact damping of the finger stopping each one calibrated, so that the
    # held note decays as on the fine grid (``intonation.finger_damping``: on a coarse grid the
    # finger's damping reaches the sounding string and drains it)
    calibrate_damping: bool = False
    # with rigid frets: the fretboard a rigid constraint at each node over it, in the frets'
    # active set (``string.geometry``), instead of the Hertzian contact of eq. (7), which a hard
    # tap drives through by a millimetre or more at the grids of the quality levels
    rigid_board: bool = True


QUALITY = {
    "draft": Quality(max_h_m=1.0, kc_tolerance=1e-3, calibrate_frets=True,
                     calibrate_damping=True),
    "standard": Quality(max_h_m=5.5e-3, max_dispersion_cents=0.8, kc_tolerance=1e-4,
                        calibrate_frets=True, calibrate_damping=True),
    "high": Quality(max_h_m=2.5e-3, max_dispersion_cents=0.3, max_oversample=16),
}


@dataclass
class RenderOptions:
    """Engine-level switches (the benchmarks and tests turn them; users pick ``quality``)."""

    quality: Quality | None = None
    oversample: int | None = None  # force one internal factor for every string
    kirchhoff_carrier: bool = True
    fretboard: bool = True
    frets: bool = True
    skip_silent: bool = True
    skip_decayed: bool = True
    # quiet steps and the unreachable-fret skip (False: every fret is within reach in every step,
    # and every step takes the general path)
    skip_contacts: bool = True
    # held steps of a fretted note in a loop of their own (``kernels._held_run``), the same
    # arithmetic as the general path: False sends them through the general path
    held_steps: bool = True
    decay_velocity: float = 1e-7  # m/s; -140 dB below the fixed-gain full scale
    # overrides ``Quality.kc_tolerance`` (0: Kirchhoff-Carrier in every step)
    kc_tolerance: float | None = None
    block_frames: int = 2048
    # knobs of the accuracy study (benchmarks/pareto.py): the gradient correction of sec. 4.7
    # (``GAMMA_RULES``) and the tuning of tension and stiffness against the grid's dispersion
    gamma_rule: str = "joint"
    compensate_dispersion: bool = True
    calibrate_frets: bool | None = None  # overrides ``Quality.calibrate_frets``
    calibrate_damping: bool | None = None  # overrides ``Quality.calibrate_damping``
    rigid_board: bool | None = None  # overrides ``Quality.rigid_board``
    # keep each voice's per-step energy series (``Voice.energy_h`` ...; tests and benchmarks read
    # them); off, a render with diagnostics keeps only running figures, in memory that does not
    # grow with the scene's duration
    energy_series: bool = False
    # build every string on the grid a live session needs (``engine.live``), which cannot know its
    # events in advance: as fingered (the finer contact grid), for the largest bend the schema
    # allows (``scene.MAX_BEND_SEMITONES``, the highest tension and stability bound), with every
    # fret calibrated.  An offline render with this option gives a session's samples
    live_grid: bool = False

