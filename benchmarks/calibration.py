"""What opening a live session's guitar costs: every fret of every string calibrated (the
finite-difference model: each fret's pitch and finger damping on the string's grid,
``RenderOptions.live_grid``; the waveguide model: the finger's damping of a note held at each fret,
``engine.waveguide.fingering.finger_decay_db_s``), in a fresh process, with an empty calibration
store and with the calibrations on disk (``engine.calibration_store``).

    python -m benchmarks.calibration

Each figure is the wall time of ``engine.models.prepare`` (the scene's model) in a new Python
process (the numba kernels already compiled and cached, as in a warm service). A store that starts
empty is filled by the first run, a single one; the warm runs read it, and their figure is the best
of ``--repeat``. A live worker prepares a guitar, rate and quality (and model) it has not seen
before in its loop, so the empty-store figure is how long its other sessions stall when a session
opens on one on a new machine. """

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile

from engine.options import QUALITY
from engine.presets import PRESETS
from engine.scene import MODELS, SAMPLE_RATE_MAX, SAMPLE_RATE_MIN

CHILD = r"""
import sys, time
from engine.models import prepare
from engine.scene import Scene
from engine.options import RenderOptions
preset, rate, quality, model = sys.argv[1], int(sys.argv[2]), sys.argv[3], sys.argv[4]
sc = Scene.model_validate({"duration": 0.1, "sample_rate": rate, "events": [],
                           "quality": quality, "guitar": {"preset": preset}, "model": model})
opts = RenderOptions(live_grid=True, skip_silent=False)
t = time.perf_counter()
prepare(sc, opts)  # engine.models: the scene's model
print(time.perf_counter() - t)
"""


def prepare_seconds(store: str, preset: str, rate: int, quality: str, model: str) -> float:
    env = {**os.environ, "GUITAR_CACHE_DIR": store, "GUITAR_CALIBRATION_CACHE": "1"}
    out = subprocess.run([sys.executable, "-c", CHILD, preset, str(rate), quality, model],
                         env=env, capture_output=True, text=True, check=True)
    return float(out.stdout.split()[-1])


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--presets", nargs="+", default=["steel-acoustic", "bass"],
                    choices=sorted(PRESETS))
    ap.add_argument("--rate", type=int, default=44100)
    ap.add_argument("--quality", default="draft", choices=sorted(QUALITY))
    ap.add_argument("--repeat", type=int, default=2)
    ap.add_argument("--models", nargs="+", default=list(MODELS), choices=MODELS)
    a = ap.parse_args()
    if not SAMPLE_RATE_MIN <= a.rate <= SAMPLE_RATE_MAX:
        ap.error(f"--rate: {a.rate} is outside {SAMPLE_RATE_MIN}-{SAMPLE_RATE_MAX}")
    if a.repeat < 1:
        ap.error("--repeat must be at least 1")
    print(f"a live session's guitar prepared (every fret calibrated), quality '{a.quality}' "
          f"(the finite-difference model's; the waveguide has none), {a.rate} Hz, wall time of "
          "one new process (s)")
    print("preset | model | empty store | calibrations on disk")
    print("--- | --- | --- | ---")
    for preset in a.presets:
        for model in a.models:
            with tempfile.TemporaryDirectory() as store:
                cold = prepare_seconds(store, preset, a.rate, a.quality, model)
                warm = min(prepare_seconds(store, preset, a.rate, a.quality, model)
                           for _ in range(a.repeat))
            print(f"{preset} | {model} | {cold:.2f} | {warm:.2f}", flush=True)


if __name__ == "__main__":
    main()
