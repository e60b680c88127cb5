"""The one place that maps a scene's ``model`` to a physical model's instrument.

    >>> inst = models.prepare(scene, options)   # an ``engine.instrument.Instrument``

``"fdtd"``: the finite-difference guitar (``engine.fd``); ``"waveguide"``: the digital waveguide
(``engine.waveguide``).  Both take the engine's ``RenderOptions`` (the waveguide reads the switches
the two share: ``waveguide.options_from``).

The one thing one model takes from the other is joined here too: the waveguide is handed the
pressed string's statics computed on the finite-difference grid (``PRESSED_STRING``: which notes a
finger seats, a held note's decay by the finger), so the two agree on dead notes and held decays
while neither model's package imports the other's.
"""

from __future__ import annotations

from dataclasses import dataclass

from . import waveguide
from .fd import kernels as fd_kernels
from .fd.instrument import prepare as prepare_fd
from .fd.statics import GRID_STATICS
from .instrument import Instrument
from .options import RenderOptions
from .output import fir_decimate
from .scene import Scene
from .waveguide import kernel as wg_kernel

# ``engine.statics.PressedString`` for the waveguide: the finite-difference string's analyses
PRESSED_STRING = GRID_STATICS


def _waveguide(scene: Scene, options: RenderOptions | None) -> Instrument:
    return waveguide.prepare(scene, waveguide.options_from(options), statics=PRESSED_STRING)


# ``engine.scene.MODELS`` -> how its instrument is prepared (tests/engine/test_public_api.py: one
# for every model the schema names)
PREPARE = {"fdtd": prepare_fd, "waveguide": _waveguide}


def prepare(scene: Scene, options: RenderOptions | None = None) -> Instrument:
    """The instrument of the model ``scene.model`` names, prepared for ``scene`` (one track)."""
    return PREPARE[scene.model](scene, options)


@dataclass(frozen=True)
class Traits:
    """What code above the models may ask of one without its instrument, instead of its name."""

    energy_balance: bool  # a discrete energy balance (``Instrument.energy_error``, diagnostics)
    grid: bool  # strings on a grid oversampled per quality level (``options.Quality``)
    fret_loops: bool  # a loop filter per stopping fret, designed on first use (``Voice.loop``)
    # about how long its kernels take to compile on a machine's first render, s (the CLI says so;
    # on the 2-core development machine ``tools.compile_time`` printed 58.4 s for the
    # finite-difference kernels and 19.0 s for the waveguide's)
    compile_s: int


TRAITS = {"fdtd": Traits(energy_balance=True, grid=True, fret_loops=False, compile_s=60),
          "waveguide": Traits(energy_balance=False, grid=False, fret_loops=True, compile_s=20)}


# The compiled functions a render of each model calls from Python: ``engine.precompile`` loads or
# compiles just these for the models a scene uses.
ENTRY_POINTS = {"fdtd": (fd_kernels.step_block, fir_decimate), "waveguide": (wg_kernel.run_block,)}
