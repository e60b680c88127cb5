"""The pressed string at rest, as both models need it: the force that seats a finger's string on
its fret (below it the note is dead), and the decay that the finger's contact gives the note it
holds.  Both are static analyses that only the finite-difference string has the grid for
(``engine.fd.statics``), so that the two models agree on which notes are dead and how a held note
decays.  This module is the face of those analyses, below both models: the waveguide is handed
an implementation (``engine.models.PRESSED_STRING``, the one place that joins the models) and
never imports ``fd``.
"""

from __future__ import annotations

from typing import Protocol

from .presets import Preset


class PressedString(Protocol):
    """The statics of a preset's string ``string`` pressed on ``fret``, at ``rate`` Hz.  An
    implementation is hashable (the waveguide caches per implementation) and names the modules
    whose code computes it (``sources``, relative to the engine's folder: the calibration store's
    keys hold their code)."""

    sources: tuple[str, ...]

    def seating_force_n(self, preset: Preset, string: int, rate: float, fret: int) -> float:
        """N a finger must press with to rest the string on ``fret``."""
        ...

    def held_note_decay_db_s(self, preset: Preset, string: int, rate: float, fret: int) -> float:
        """dB/s of the note a finger holds at ``fret``, decaying by the finger's contact damping;
        not finite where the analysis finds no note."""
        ...
