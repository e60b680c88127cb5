"""Stability soak: thousands of random valid scenes, some of them 60 s long, checked for finite
output, energy balance, stored energy bounded by the work done, non-negative dissipation and the
auxiliary variables of sec. 4.7 (``engine.testing.stability``), on scenes from
``engine.testing.random_scenes``, the generator the tests draw from through hypothesis.

    python -m benchmarks.soak [--minutes 3] [--seed 0] [--jobs 2] [--no-docs] [--model waveguide]

Case i is generated from seed (--seed, i), so any case can be replayed:

    python -m benchmarks.soak --replay SEED I     # prints the scene JSON and its report

Every case renders with the default options (all skips on).  A case that breaks a check is
rendered again without the skips of contact work (``skip_contacts=False``: no quiet or held
steps, every fret checked) and its violations are attributed: to those skips if
they disappear, to the geometry if the strings start below the
fret tips (``action_12th_m`` below ``action_nut_m``), otherwise left unexplained.  An engine
exception on a valid scene is a finding too, grouped by message.

The cases (``engine.testing.random_scenes.soak_case``): one in ``LONG_EVERY`` is a 60-second
scene with up to 4 events (draft); the rest last 0.02-0.2 s with up to 16 events (qualities
``QUALITIES``).  The summary is printed and written to docs/accuracy.md between the
``soak:begin`` / ``soak:end`` markers.

With ``--model waveguide`` every case is rendered on the waveguide model and judged by its own
check (``engine.testing.waveguide_stability``: finite output, and the rails' windowed energy after
each string's last event never growing by more than ``GROWTH`` with the tension modulation off,
never rising above its first window with it on), since that model has no discrete energy balance.
Its cases are drawn longer (``WG_SHORT_S`` with up to 12 events, so that the energy has windows
after the last event; one in ``WG_LONG_EVERY`` a 60-second scene with up to 4 events, checked in
0.2 s windows) from a stream of their own (``--replay`` with ``--model waveguide`` replays them),
and written between the ``soak-waveguide`` markers.  A broken check is attributed as the default
model's are (``causes_waveguide``): a growth gone in windows twice as long to partials beating
slower than the window, a rise with the glide on to a glide past an octave.
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
from engine.models import TRAITS
from engine.options import RenderOptions
from engine.testing import waveguide_stability
from engine.testing.random_scenes import WG_SHORT_S
from engine.testing.random_scenes import soak_case as make_case
from engine.testing.stability import LIMITS, Report, check, violations

WG_LONG_WINDOW_S = 0.2
OCTAVE = 2.0  # a glide's pitch ratio past which a rise with the glide on is attributed to it


def check_waveguide(kind: str, sc: dict, stretch: float = 1.0) -> waveguide_stability.Report:
    window = WG_LONG_WINDOW_S if kind == "60 s" else waveguide_stability.WINDOW_S
    return waveguide_stability.check(sc, window_s=stretch * window)


def causes_waveguide(kind: str, sc: dict, rep: waveguide_stability.Report) -> str:
    """A broken waveguide check's known cause, or 'not attributed'.  A growth with the glide
    off that is gone in windows twice as long is the beating of partials slower than the window
    (the rails' energy leaves out what the termination's filters hold, which beats against it);
    a rise with the glide on past an octave of glide is the tension modulation's: the loop
    realises it by moving its termination, which does work on the waves (``glide``)."""
    out = []
    if not rep.finite:
        return "non-finite output"
    if rep.growth > waveguide_stability.GROWTH:
        longer = check_waveguide(kind, sc, stretch=2.0)
        out.append("growth: beats slower than the window (gone in windows twice as long)"
                   if longer.growth <= waveguide_stability.GROWTH else
                   "growth: not attributed")
    if rep.rise > waveguide_stability.GROWTH:
        out.append("rise: the glide went past an octave" if rep.glide_max > OCTAVE else
                   "rise: not attributed")
    return "; ".join(out)


def run_case_waveguide(args):
    seed, i = args
    kind, sc = make_case(seed, i, "waveguide")
    try:
        rep = check_waveguide(kind, sc)
    except ValidationError:
        return {"i": i, "kind": kind, "valid": False}
    except Exception as e:  # noqa: BLE001 - an engine error on a valid scene is a finding
        return {"i": i, "kind": kind, "valid": True, "error": f"{type(e).__name__}: {e}",
                "seconds": sc["duration"], "rate": sc["sample_rate"],
                "preset": sc["guitar"]["preset"]}
    return {"i": i, "kind": kind, "valid": True, "error": "", "seconds": rep.seconds,
            "wall": rep.wall, "finite": rep.finite, "growth": rep.growth, "rise": rep.rise,
            "glide_max": rep.glide_max, "ok": rep.ok, "rate": sc["sample_rate"],
            "preset": sc["guitar"]["preset"],
            "cause": "" if rep.ok else causes_waveguide(kind, sc, rep)}


def summarise_waveguide(results: list[dict], seed: int, wall: float, jobs: int) -> str:
    valid = [r for r in results if r["valid"]]
    long_ = [r for r in valid if r["kind"] == "60 s"]
    lo, hi = WG_SHORT_S
    lines = [
        f"{len(valid)} valid random scenes on the waveguide model in {wall / 60:.1f} minutes on "
        f"{jobs} processes (seed {seed}; {len(results) - len(valid)} drawn scenes failed "
        f"validation and were skipped): {len(long_)} of 60 s and {len(valid) - len(long_)} of "
        f"{lo:g}-{hi:g} s, {sum(r['seconds'] for r in valid):.0f} s of audio, each rendered "
        f"twice (tension modulation off and on); sample rates "
        f"{min(r['rate'] for r in valid)}-{max(r['rate'] for r in valid)} Hz; "
        + ", ".join(f"{p} {n}" for p, n in sorted(collections.Counter(
            r["preset"] for r in valid).items())) + ".",
        "",
        "| check | limit | worst value over all cases | worst case | cases over the limit |",
        "|---|---|---|---|---|",
    ]
    ran = [r for r in valid if not r["error"]]
    lines.append(f"| finite output | - | - | - | {sum(not r['finite'] for r in ran)} |")
    lines.append(f"| engine raised on a valid scene | - | - | - | "
                 f"{sum(bool(r['error']) for r in valid)} |")
    for key, label in (("growth", "energy growth, window to window, glide off (relative)"),
                       ("rise", "energy above its first window, glide on (relative)")):
        cases = [r for r in ran if r["finite"]]
        if cases:
            w = max(cases, key=lambda r: r[key])
            over = sum(r[key] > waveguide_stability.GROWTH for r in cases)
            lines.append(f"| {label} | {waveguide_stability.GROWTH:.0e} | {w[key]:.2e} | "
                         f"{seed} {w['i']} | {over} |")
    if ran:
        g = np.array([r["glide_max"] for r in ran])
        semitone = 2.0 ** (1.0 / 12.0)
        lines += ["", f"The tension modulation's pitch ratio (its largest in each case): median "
                      f"{np.median(g):.4g}, largest {g.max():.4g}; {int((g > semitone).sum())} "
                      f"cases glided by more than a semitone, {int((g > OCTAVE).sum())} by more "
                      f"than an octave."]
    bad = [r for r in valid if r["error"] or not r["ok"]]
    lines += ["", f"{len(bad)} of {len(valid)} cases broke at least one check."]
    if bad:
        lines += ["", "| case (seed case) | what broke | cause |", "|---|---|---|"]
        for r in sorted(bad, key=lambda r: r["i"])[:20]:
            what = r["error"] or (f"growth {r['growth']:.2e}, rise {r['rise']:.2e} (the "
                                  f"glide's pitch ratio up to {r['glide_max']:.3g})")
            lines.append(f"| {seed} {r['i']} | {what} | {r.get('cause') or '-'} |")
        lines += ["", f"Replay a case with `python -m benchmarks.soak --model waveguide --replay "
                      f"{seed} CASE`."]
    return "\n".join(lines) + "\n"


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
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--minutes", type=float, default=3.0)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--no-docs", action="store_true")
    ap.add_argument("--replay", type=int, nargs=2, metavar=("SEED", "CASE"))
    ap.add_argument("--model", choices=("fdtd", "waveguide"), default="fdtd",
                    help="the string model every case is rendered on (default fdtd)")
    args = ap.parse_args()
    if args.minutes <= 0 or args.jobs < 1:
        ap.error("--minutes must be > 0 and --jobs >= 1")
    # a model with no discrete energy balance is judged by its rails' energy (the waveguide's)
    waveguide = not TRAITS[args.model].energy_balance
    if args.replay and waveguide:
        kind, sc = make_case(*args.replay, args.model)
        print(json.dumps(sc, indent=1))
        try:
            rep = check_waveguide(kind, sc)
        except ValidationError as e:  # the soak skips these cases too
            print(f"case {args.replay[1]} of seed {args.replay[0]} is not a valid scene (the soak "
                  f"skipped it): {e.errors()[0]['msg']}", file=sys.stderr)
            sys.exit(2)
        print(rep, "ok" if rep.ok else "broke a check", sep="\n")
        return
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
            pool.apply_async(run_case_waveguide if waveguide else run_case, ((args.seed, i),),
                             callback=done, error_callback=failed)
            i += 1
        pool.close()
        pool.join()
    wall = time.perf_counter() - t0
    if waveguide:
        text = summarise_waveguide(results, args.seed, wall, args.jobs)
        command = f"python -m benchmarks.soak --model waveguide --minutes {args.minutes:g}"
        section, marker = "Stability soak of the waveguide model", "soak-waveguide"
    else:
        text = summarise(results, args.seed, wall, args.jobs)
        command = f"python -m benchmarks.soak --minutes {args.minutes:g}"
        section, marker = "Stability soak", "soak"
    print(text)
    if not args.no_docs:
        write_docs(section, marker, f"Printed by `{command}`.\n\n" + text)


if __name__ == "__main__":
    main()
