"""The pressed string at rest on the finite-difference grid, for both models
(``engine.statics.PressedString``): the force that seats a finger's string on its fret
(``intonation.seating_force`` on the grid ``string.tune`` builds at the scene's rate) and the decay
that the finger's contact gives the note it holds (``intonation.held_note`` on the converged grid).
``engine.models`` hands ``GRID_STATICS`` to the waveguide, which imports nothing of ``fd``.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

from threadpoolctl import threadpool_limits

from ..presets import Preset
from .intonation import held_note, reference_model, seating_force
from .string import tune


@lru_cache(maxsize=4096)
def seating_force_n(preset: Preset, string: int, rate: float, fret: int) -> float:
    """N a finger must press with to rest string ``string`` on ``fret`` (``seating_force`` on the
    string tuned at ``rate``; cached per process)."""
    spec = preset.strings[string - 1]
    return seating_force(tune(spec, preset.string_length_m(string), rate), preset, fret)


def held_note_decay_db_s(preset: Preset, string: int, rate: float, fret: int) -> float:
    """dB/s of the note a finger holds at ``fret``, decaying by the finger's contact damping:
    the held-note analysis (``held_note``) on the converged grid (``reference_model``); not
    finite where it finds no mode near the note."""
    spec = preset.strings[string - 1]
    model = reference_model(tune(spec, preset.string_length_m(string), rate))
    # BLAS on one thread, as the fret calibrations (``intonation._each_fret``): the value does not
    # depend on the machine's thread count, nor on who computed it first
    with threadpool_limits(limits=1, user_api="blas"):
        return held_note(model, preset, fret, spec.frequency_hz * 2 ** (fret / 12)).decay_db_s


@dataclass(frozen=True)
class GridStatics:
    """``engine.statics.PressedString`` on the finite-difference grid (this module's functions)."""

    sources: tuple[str, ...] = ("fd/statics.py",)

    def seating_force_n(self, preset: Preset, string: int, rate: float, fret: int) -> float:
        return seating_force_n(preset, string, rate, fret)

    def held_note_decay_db_s(self, preset: Preset, string: int, rate: float, fret: int) -> float:
        return held_note_decay_db_s(preset, string, rate, fret)


GRID_STATICS = GridStatics()
