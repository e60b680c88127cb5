"""Stability soak: thousands of random valid scenes, some of them 60 s long, checked for finite
output, energy balance, stored energy bounded by the work done, non-negative dissipation and the
auxiliary variables of sec. 4.7 (``engine.testing.stability``), on scenes from
``engine.testing.random_scenes``, the generator the tests draw from through hypothesis.

    python -m benchmarks.soak [--minutes 3] [--seed 0] [--jobs 2] [--no-docs]

Case i is generated from seed (--seed, i), so any case can be replayed:

    python -m benchmarks.soak --replay SEED I     # prints the scene JSON and its report

Every case renders with the default options (all skips on).  A case that breaks a check is
rendered again without the skips of contact work (``skip_contacts=False``: no quiet or held
steps, every fret checked) and its violations are attributed: to those skips if
they disappear, to the geometry if the strings start below the
fret tips (``action_12th_m`` below ``action_nut_m``), otherwise left unexplained.  An engine
exception on a valid scene is a finding too, grouped by message.

One case in ``LONG_EVERY`` is a 60-second scene with up to 4 events (draft); the rest last
0.02-0.2 s with up to 16 events (qualities ``QUALITIES``).  The summary is printed and written
to docs/accuracy.md between the ``soak:begin`` / ``soak:end`` markers.
"""

from __future__ import annotations

import argparse
import collections
import json
import math
import sys
import threading
import time
from multiprocessing import Pool

import numpy as np
from pydantic import ValidationError

from benchmarks.pareto import write_docs
from engine.options import RenderOptions
from engine.testing.random_scenes import NumpyDraw, random_scene
from engine.testing.stability import LIMITS, Report, check, violations

LONG_EVERY = 100
LONG_S = 60.0
QUALITIES = ("draft",) * 14 + ("standard",) * 5 + ("high",)


def make_case(seed: int, i: int) -> tuple[str, dict]:
    d = NumpyDraw(np.random.default_rng([seed, i]))
    if i % LONG_EVERY == LONG_EVERY - 1:
        sc = random_scene(d, max_duration=LONG_S, min_duration=LONG_S, max_events=4,
                          qualities=("draft",))
        return "60 s", sc
    return "short", random_scene(d, max_duration=0.2, max_events=16, qualities=QUALITIES)


def kind_of(violation: str) -> str:
    for k in ("energy balance", "stored energy", "negative dissipation", "fretboard psi",
              "finger psi", "non-finite"):
        if violation.startswith(k):
            return k
    return "engine error: " + violation.split(" on string")[0]


def causes(sc: dict, rep: Report, bad: list[str]) -> dict[str, str]:
    """Each broken check -> its known cause, or 'not attributed'."""
    kinds = {kind_of(v) for v in bad}
    g = sc.get("guitar", {})
    if rep.error or not rep.finite:
        return {k: "-" for k in kinds}
    if g.get("action_12th_m", 1.0) < g.get("action_nut_m", 0.0):
        return {k: "strings start below the fret tips (action_12th_m < action_nut_m)"
                for k in kinds}
    out = {}
    again = {kind_of(v) for v in violations(check(sc, RenderOptions(skip_contacts=False)))}
    for k in kinds - again:
        out[k] = "skipped contact work (gone with skip_contacts=False)"
    left = kinds & again
    if any(k.endswith("psi") for k in left):  # psi sampled every PROBE_FRAMES: look closer
        fine = {kind_of(v) for v in violations(check(sc, probe_frames=1))}
        for k in [k for k in left if k.endswith("psi") and k not in fine]:
            out[k] = "a contact between samples (gone when sampled at every output sample)"
    for k in kinds - out.keys():
        out[k] = "not attributed"
    return out


def run_case(args):
    seed, i = args
    kind, sc = make_case(seed, i)
    t = time.perf_counter()
    try:
        rep = check(sc)
    except ValidationError:
        return {"i": i, "kind": kind, "valid": False}
    bad = violations(rep)
    out = {"i": i, "kind": kind, "valid": True, "seconds": rep.seconds, "steps": rep.steps,
           "wall": time.perf_counter() - t, "violations": bad, "rep": rep.__dict__,
           "quality": sc["quality"], "rate": sc["sample_rate"], "preset": sc["guitar"]["preset"]}
    if bad:
        out["causes"] = causes(sc, rep, bad)
    return out


def summarise(results: list[dict], seed: int, wall: float, jobs: int) -> str:
    valid = [r for r in results if r["valid"]]
    long_ = [r for r in valid if r["kind"] == "60 s"]
    lines = [
        f"{len(valid)} valid random scenes in {wall / 60:.1f} minutes on {jobs} processes "
        f"(seed {seed}; {len(results) - len(valid)} drawn scenes failed validation and were "
        f"skipped): {len(long_)} of 60 s and {len(valid) - len(long_)} of 0.02-0.2 s, "
        f"{sum(r['seconds'] for r in valid):.0f} s of audio, "
        f"{sum(r['steps'] for r in valid) / 1e6:.0f} million string-steps with diagnostics; "
        f"qualities " + ", ".join(f"{q} {sum(r['quality'] == q for r in valid)}"
                                  for q in ("draft", "standard", "high"))
        + f"; sample rates {min(r['rate'] for r in valid)}-{max(r['rate'] for r in valid)} Hz; "
        + ", ".join(f"{p} {n}" for p, n in sorted(collections.Counter(
            r["preset"] for r in valid).items())) + ".",
        "",
    ]
    ok = [r for r in valid if not r["rep"]["error"] and r["rep"]["finite"]]
    lines += ["| check | limit | worst value over all cases | worst case | cases over the limit |",
              "|---|---|---|---|---|"]
    nonfinite = sum(not r["rep"]["finite"] for r in valid)
    errors = sum(bool(r["rep"]["error"]) and r["rep"]["finite"] for r in valid)
    lines.append(f"| finite output | - | - | - | {nonfinite} |")
    lines.append(f"| engine raised on a valid scene | - | - | - | {errors} |")
    for key, label, worst in (
            ("balance", "energy balance (relative)", max),
            ("excess", "stored energy above initial + work in (relative)", max),
            ("q_min", "dissipation of one step (relative, most negative)", min),
            ("board_residual", "fretboard psi^2/2 left after contact (relative)", max),
            ("finger_residual", "finger psi^2/2 left after contact (relative)", max)):
        cases = [r for r in ok if math.isfinite(r["rep"][key])]
        vals = [r["rep"][key] for r in cases]
        over = sum((v < LIMITS[key]) if key == "q_min" else (v > LIMITS[key]) for v in vals)
        w = worst(cases, key=lambda r: r["rep"][key])  # (the replay command's seed and case)
        lines.append(f"| {label} | {LIMITS[key]:.0e} | {w['rep'][key]:.2e} | {seed} {w['i']} | "
                     f"{over} |")
    runs = sum(r["rep"]["quiet_runs"] for r in ok)
    lines += ["", f"The psi checks looked at {runs} runs out of contact of at least 1 ms.", ""]
    bad = [r for r in valid if r["violations"]]
    lines.append(f"{len(bad)} of {len(valid)} cases broke at least one check.")
    if bad:
        lines += ["", "| check broken | cause | cases | example (seed case): what broke |",
                  "|---|---|---|---|"]
        by = collections.defaultdict(list)
        for r in bad:
            for k, c in r["causes"].items():
                by[k, c].append(r)
        for (k, c), rs in sorted(by.items(), key=lambda kv: -len(kv[1])):
            ex = min(rs, key=lambda r: (r["seconds"], r["i"]))
            what = "; ".join(v for v in ex["violations"] if kind_of(v) == k)
            lines.append(f"| {k} | {c} | {len(rs)} | {seed} {ex['i']}: {what} |")
        lines += ["", f"Replay a case with `python -m benchmarks.soak --replay {seed} CASE`."]
    return "\n".join(lines) + "\n"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--minutes", type=float, default=3.0)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--no-docs", action="store_true")
    ap.add_argument("--replay", type=int, nargs=2, metavar=("SEED", "CASE"))
    args = ap.parse_args()
    if args.replay:
        kind, sc = make_case(*args.replay)
        print(json.dumps(sc, indent=1))
        try:
            rep = check(sc)
        except ValidationError as e:  # the soak skips these cases too
            print(f"case {args.replay[1]} of seed {args.replay[0]} is not a valid scene (the soak "
                  f"skipped it): {e.errors()[0]['msg']}", file=sys.stderr)
            sys.exit(2)
        print(rep, violations(rep), sep="\n")
        return
    t0 = time.perf_counter()
    deadline = t0 + 60.0 * args.minutes
    results: list[dict] = []
    slots = threading.Semaphore(2 * args.jobs)  # tasks in flight: keeps every worker busy

    def done(r):
        results.append(r)
        slots.release()

    def failed(e):  # an exception outside check() (a bug of this script): report, go on
        print(f"case failed: {type(e).__name__}: {e}", flush=True)
        slots.release()

    with Pool(args.jobs) as pool:
        i = 0
        while time.perf_counter() < deadline:
            slots.acquire()
            pool.apply_async(run_case, ((args.seed, i),), callback=done, error_callback=failed)
            i += 1
        pool.close()
        pool.join()
    wall = time.perf_counter() - t0
    text = summarise(results, args.seed, wall, args.jobs)
    print(text)
    if not args.no_docs:
        write_docs("Stability soak", "soak",
                   f"Printed by `python -m benchmarks.soak --minutes {args.minutes:g}`.\n\n" + text)


if __name__ == "__main__":
    main()
