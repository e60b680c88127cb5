"""How well ``engine.estimate_cost`` predicts the render time: renders scenes of every kind and
prints, per scene, the estimated work (node-steps), the wall time and the throughput (work per
second).  The service turns a cost into seconds with the median throughput printed here
(``GUITAR_WORK_PER_SECOND``), and its budget (``GUITAR_MAX_WORK``) is in the same unit.

    python -m benchmarks.cost [--seconds 1.0]
"""

from __future__ import annotations

import argparse
import statistics
import time

import engine
from engine.fd.instrument import prepare
from engine.scene import Scene


def scenes(duration: float) -> dict[str, dict]:
    open6 = [{"type": "strum", "time": 0.0}]
    fretted6 = [{"type": "fret", "time": 0.0, "string": s, "fret": 5} for s in range(1, 7)] + [
        {"type": "strum", "time": 0.01}]
    out = {}
    for q in ("draft", "standard", "high"):
        for rate in (22050, 44100, 96000):
            out[f"{q} {rate} open strum"] = {"duration": duration, "sample_rate": rate,
                                             "quality": q, "events": open6}
            out[f"{q} {rate} fretted strum"] = {"duration": duration, "sample_rate": rate,
                                                "quality": q, "events": fretted6}
    out["standard 44100 one pluck"] = {"duration": duration, "events": [
        {"type": "pluck", "time": 0.0, "string": 1}]}
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seconds", type=float, default=1.0, help="audio seconds per scene")
    args = ap.parse_args()
    engine.warmup()
    rates, setups = [], []
    print(f"{'scene':32} {'work':>10} {'set-up s':>9} {'steps s':>8} {'work/s':>10}")
    for name, sc in scenes(args.seconds).items():
        scene = Scene.model_validate({**sc, "output": {"normalize": False}})
        work = engine.estimate_cost(scene).work
        t0 = time.perf_counter()
        guitar = prepare(scene)
        t1 = time.perf_counter()
        for _ in guitar.blocks():
            pass
        t2 = time.perf_counter()
        rates.append(work / (t2 - t1))
        setups.append(t1 - t0)
        print(f"{name:32} {work:10.3g} {t1 - t0:9.3f} {t2 - t1:8.3f} {work / (t2 - t1):10.3g}")
    q = statistics.quantiles(rates, n=10)
    print(f"work per second of stepping: median {statistics.median(rates):.3g}, "
          f"10th percentile {q[0]:.3g}, 90th {q[-1]:.3g}, min {min(rates):.3g}, max {max(rates):.3g}")
    print(f"set-up: median {statistics.median(setups):.3f} s, max {max(setups):.3f} s")


if __name__ == "__main__":
    main()
