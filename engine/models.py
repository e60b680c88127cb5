"""The one place that maps a scene's ``model`` to a physical model's instrument.

    >>> inst = models.prepare(scene, options)   # an ``engine.instrument.Instrument``

``"fdtd"``: the finite-difference guitar (``engine.fd``); ``"waveguide"``: the digital waveguide
(``engine.waveguide``).  Both take the engine's ``RenderOptions`` (the waveguide reads the switches
the two share: ``waveguide.options_from``).
"""

from __future__ import annotations

from . import waveguide
from .fd.instrument import prepare as prepare_fd
from .instrument import Instrument
from .options import RenderOptions
from .scene import Scene


def _waveguide(scene: Scene, options: RenderOptions | None) -> Instrument:
    return waveguide.prepare(scene, waveguide.options_from(options))


# ``engine.scene.MODELS`` -> how its instrument is prepared (tests/engine/test_public_api.py: one
# for every model the schema names)
PREPARE = {"fdtd": prepare_fd, "waveguide": _waveguide}


def prepare(scene: Scene, options: RenderOptions | None = None) -> Instrument:
    """The instrument of the model ``scene.model`` names, prepared for ``scene`` (one track)."""
    return PREPARE[scene.model](scene, options)


def entry_points(model: str) -> list:
    """The compiled functions a render of ``model`` calls from Python (``engine.precompile`` loads
    or compiles just these)."""
    if model not in PREPARE:
        raise KeyError(model)
    from .fd import kernels
    from .output import fir_decimate
    from .waveguide import kernel

    return {"fdtd": [kernels.step_block, fir_decimate], "waveguide": [kernel.run_block]}[model]
