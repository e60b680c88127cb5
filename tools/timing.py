"""The best CPU time of a scene's simulation, with the fewest cycles and instructions where the
machine gives hardware counters: what ``benchmarks.speed`` tabulates and ``tools.compare`` times
across revisions."""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from engine.fd.instrument import Guitar, prepare
from engine.options import RenderOptions
from engine.scene import Scene
from tools.counters import Counters


@dataclass
class Timing:
    """The best of several renders: CPU seconds, and the fewest cycles and instructions (None
    without hardware counters)."""

    seconds: float
    cycles: float | None
    instructions: float | None
    engine: Guitar | None


def _fewest(a: float | None, b: int | None) -> float | None:
    if b is None:
        return None
    return float(b) if a is None else min(a, float(b))


def best_time(scene: dict, options: RenderOptions, repeat: int) -> Timing:
    """Best CPU time of the simulation (scene preparation excluded) over ``repeat`` runs: thread
    time rather than wall time, so that other processes on the machine change it less."""
    sc = Scene.model_validate(scene)
    best = Timing(np.inf, None, None, None)
    for _ in range(repeat):
        eng = prepare(sc, options)
        with Counters() as ctr:
            t = time.thread_time()
            for _block in eng.blocks():
                pass
            t = time.thread_time() - t
        best = Timing(min(best.seconds, t), _fewest(best.cycles, ctr.cycles),
                      _fewest(best.instructions, ctr.instructions), eng)
    return best
