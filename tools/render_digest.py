"""Fingerprints of a fixed set of renders, to check that a refactor changed no sample.

    python -m tools.render_digest > before.json      # on the old tree
    python -m tools.render_digest --check before.json  # on the new tree: exit 1 on any change

Each scene is rendered through the public API (``engine.render``) as a user renders it, and with
diagnostics both with every step path on and with the specialised loops off (quiet and held steps
through the general path); the SHA-256 of the float64 samples is printed with the energy-balance
figure and the number of warnings.  The scenes cover fretted, tapped,
hammered, pulled, slid, bent, muted and harmonic strings, a strum, a hard pluck, several pickups,
stereo, both built-in bodies and none, the three qualities and an oversampled rate.

    python -m tools.render_digest --waveguide > before.json   # the waveguide's scenes only

``--waveguide`` renders the waveguide's scenes (``WAVEGUIDE``, ``"model": "waveguide"``) instead:
each as a user renders it (the decay stop on), with the decay stop off, and cut into blocks of
1000 frames (``RenderOptions.block_frames``; the samples must not depend on the blocks).  They
cover every path of ``engine/waveguide/kernel.py``: open and fretted plucks, a strum of hard
plucks that glide, bends, vibrato, slides, hammer-ons, pull-offs, taps, harmonics, palm mutes,
dead notes, damps, slap and pop against the frets, one, several and cut-off pickups, stereo and
a body, another rate, and strings that decay to the stop.

    python -m tools.render_digest --first-process [--waveguide]

Compare digests only between processes that load the kernels from numba's cache.  The process
that compiles them (an empty or outdated cache) renders with code that rounds otherwise than
the code it writes to the cache and every later process loads, so its digests differ from theirs
in every scene.  ``--first-process`` shows it: each scene as a user renders it, in a child process
that compiles the kernels into an empty cache and then in one that loads them from it, and the
largest difference between the two per scene, against the scene's peak.  (The product's paths do
not meet it: ``engine.prepare_kernels`` and ``engine.warmup``, which the CLI, the service, the
batches and the tests call before they render, compile in a child process and load what it
cached.  This tool's children call ``engine.render`` alone, so the first compiles in-process.)
"""

from __future__ import annotations

import argparse
import hashlib
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

import engine

SCENES: dict[str, dict] = {
    "api-example": {
        "duration": 1.0, "events": [
            {"type": "fret", "time": 0.0, "string": 5, "fret": 3, "force": 2.0},
            {"type": "pluck", "time": 0.05, "string": 5, "position": 0.8, "force": 2.0},
            {"type": "tap", "time": 0.5, "string": 3, "fret": 7, "force": 0.9}]},
    "c-chord": {
        "duration": 1.0, "output": {"body": "none"}, "events": [
            {"type": "fret", "time": 0, "string": 5, "fret": 3},
            {"type": "fret", "time": 0, "string": 4, "fret": 2},
            {"type": "fret", "time": 0, "string": 2, "fret": 1},
            {"type": "strum", "time": 0.05, "direction": "down", "spread": 0.04}]},
    "open-strum-electric": {
        "duration": 1.0, "guitar": {"preset": "electric"},
        "output": {"normalize": False, "channels": 2},
        "events": [{"type": "strum", "time": 0.0, "spread": 0.03, "force": 3.0}]},
    "hard-pluck": {
        "duration": 0.6, "events": [{"type": "pluck", "time": 0, "string": 6, "force": 8.0}]},
    "legato": {
        "duration": 0.8, "events": [
            {"type": "fret", "time": 0.0, "string": 4, "fret": 2},
            {"type": "pluck", "time": 0.01, "string": 4, "style": "pick"},
            {"type": "hammer_on", "time": 0.2, "string": 4, "fret": 4},
            {"type": "pull_off", "time": 0.4, "string": 4, "fret": 4},
            {"type": "slide", "time": 0.5, "string": 4, "from_fret": 2, "to_fret": 7,
             "duration": 0.1}]},
    "bend-vibrato-nylon": {
        "duration": 0.8, "guitar": {"preset": "nylon-classical"},
        "output": {"pickups": [{"position": 0.9}, {"position": 0.7, "gain": 0.5}]},
        "events": [
            {"type": "fret", "time": 0.0, "string": 2, "fret": 5},
            {"type": "pluck", "time": 0.01, "string": 2},
            {"type": "bend", "time": 0.2, "string": 2, "semitones": 1.0, "duration": 0.1,
             "release": 0.5},
            {"type": "pluck", "time": 0.0, "string": 6},
            {"type": "vibrato", "time": 0.1, "string": 6, "duration": 0.5}]},
    "harmonic-mute-slap": {
        "duration": 0.6, "quality": "draft", "events": [
            {"type": "harmonic", "time": 0.0, "string": 1, "fret": 12, "release": 0.3},
            {"type": "pluck", "time": 0.01, "string": 1},
            {"type": "mute", "time": 0.0, "string": 3},
            {"type": "pluck", "time": 0.01, "string": 3, "style": "slap"},
            {"type": "pluck", "time": 0.02, "string": 2, "style": "pop"}]},
    "tap-high-96k": {
        "duration": 0.3, "sample_rate": 96000, "quality": "high", "events": [
            {"type": "tap", "time": 0.0, "string": 3, "fret": 7, "force": 3.0, "velocity": 2.0}]},
}


def _wg(duration: float, events: list, **extra) -> dict:
    return {"model": "waveguide", "duration": duration, "events": events,
            "output": {"body": "none", "normalize": False, **extra.pop("output", {})}, **extra}


C_G = [{"type": "fret", "time": 0.0, "string": s, "fret": q}
       for s, q in ((6, 3), (5, 3), (4, 2), (2, 1))]
WAVEGUIDE: dict[str, dict] = {
    "wg-open-pluck": _wg(1.0, [{"type": "pluck", "time": 0.0, "string": 1, "force": 1.0}]),
    "wg-damped-stops": _wg(1.5, [{"type": "pluck", "time": 0.0, "string": 1, "force": 0.5},
                                  {"type": "damp", "time": 0.05, "string": 1}]),
    "wg-fretted-damped-stops": _wg(2.5, [
        {"type": "fret", "time": 0.0, "string": 3, "fret": 5},
        {"type": "pluck", "time": 0.01, "string": 3},
        {"type": "damp", "time": 0.1, "string": 3}]),
    # benchmarks.waveguide's strum (tools.instructions --waveguide counts it)
    "wg-fretted-strum": _wg(4.0, C_G + [{"type": "strum", "time": 0.05, "force": 2.0,
                                         "spread": 0.03}]),
    "wg-hard-strum-glide": _wg(1.5, [{"type": "strum", "time": 0.0, "force": 12.0,
                                      "spread": 0.02, "style": "pick"}]),
    "wg-hard-fretted-glide": _wg(1.0, [
        {"type": "fret", "time": 0.0, "string": 6, "fret": 5},
        {"type": "pluck", "time": 0.01, "string": 6, "force": 15.0, "position": 0.9}]),
    "wg-bend-release": _wg(1.0, [
        {"type": "fret", "time": 0.0, "string": 2, "fret": 7},
        {"type": "pluck", "time": 0.01, "string": 2, "force": 3.0},
        {"type": "bend", "time": 0.15, "string": 2, "semitones": 2.0, "duration": 0.2,
         "release": 0.6}]),
    "wg-vibrato-two-pickups": _wg(1.0, [
        {"type": "pluck", "time": 0.0, "string": 3, "force": 4.0},
        {"type": "vibrato", "time": 0.1, "string": 3, "depth_cents": 60.0, "rate_hz": 7.0,
         "duration": 0.8}], output={"pickups": [{"position": 0.9}, {"position": 0.7,
                                                                    "gain": 0.5}]}),
    "wg-slide-hammer-pull": _wg(1.5, [
        {"type": "fret", "time": 0.0, "string": 4, "fret": 2},
        {"type": "pluck", "time": 0.01, "string": 4, "force": 3.0, "style": "pick"},
        {"type": "hammer_on", "time": 0.25, "string": 4, "fret": 4},
        {"type": "pull_off", "time": 0.5, "string": 4, "fret": 4},
        {"type": "slide", "time": 0.75, "string": 4, "from_fret": 2, "to_fret": 9,
         "duration": 0.2},
        {"type": "fret", "time": 1.2, "string": 4, "fret": 0}]),
    "wg-tap-lift": _wg(1.0, [
        {"type": "tap", "time": 0.0, "string": 3, "fret": 7, "force": 3.0, "velocity": 2.0},
        {"type": "fret", "time": 0.5, "string": 3, "fret": 0}]),
    "wg-harmonic-mute": _wg(1.0, [
        {"type": "harmonic", "time": 0.0, "string": 1, "fret": 12, "release": 0.3},
        {"type": "pluck", "time": 0.01, "string": 1, "force": 2.0},
        {"type": "mute", "time": 0.0, "string": 4, "amount": 1.0},
        {"type": "pluck", "time": 0.02, "string": 4, "force": 3.0},
        {"type": "harmonic", "time": 0.0, "string": 5, "position": 0.2},
        {"type": "pluck", "time": 0.02, "string": 5}]),
    "wg-dead-note-damp": _wg(1.0, [
        {"type": "fret", "time": 0.0, "string": 3, "fret": 5, "force": 0.05},
        {"type": "pluck", "time": 0.02, "string": 3},
        {"type": "pluck", "time": 0.0, "string": 1, "force": 2.0},
        {"type": "damp", "time": 0.3, "string": 1}]),
    "wg-slap-pop": _wg(1.0, [
        {"type": "pluck", "time": 0.0, "string": 5, "force": 15.0, "style": "slap",
         "position": 0.85},
        {"type": "pluck", "time": 0.1, "string": 2, "force": 15.0, "style": "pop",
         "position": 0.85},
        {"type": "fret", "time": 0.0, "string": 6, "fret": 12, "force": 5.0},
        {"type": "pluck", "time": 0.2, "string": 6, "force": 15.0, "style": "slap"}]),
    "wg-cut-off-pickups": _wg(1.0, [
        {"type": "fret", "time": 0.0, "string": 2, "fret": 12},
        {"type": "pluck", "time": 0.01, "string": 2, "force": 3.0, "position": 0.9},
        {"type": "fret", "time": 0.6, "string": 2, "fret": 0}],
        output={"pickups": [{"position": 0.3}]}),
    "wg-cut-off-pickups-two": _wg(1.0, [
        {"type": "fret", "time": 0.0, "string": 5, "fret": 12},
        {"type": "pluck", "time": 0.01, "string": 5, "force": 3.0, "position": 0.9},
        {"type": "pluck", "time": 0.0, "string": 1, "force": 3.0}],
        output={"pickups": [{"position": 0.3}, {"position": 0.85, "gain": 0.7}]}),
    "wg-palm-muted-strum": _wg(2.5, [{"type": "mute", "time": 0.0, "amount": 1.0},
                                     {"type": "strum", "time": 0.01, "direction": "up"}]),
    "wg-electric-stereo-body": {**_wg(0.8, C_G + [
        {"type": "strum", "time": 0.0, "force": 5.0, "spread": 0.02}],
        output={"channels": 2, "body": "acoustic"}), "guitar": {"preset": "electric"}},
    "wg-nylon-48k-legato": {**_wg(0.8, [
        {"type": "fret", "time": 0.0, "string": 1, "fret": 5},
        {"type": "pluck", "time": 0.01, "string": 1, "force": 4.0},
        {"type": "hammer_on", "time": 0.2, "string": 1, "fret": 7, "velocity": 3.0},
        {"type": "bend", "time": 0.3, "string": 1, "semitones": 1.0, "duration": 0.1,
         "release": 0.5},
        {"type": "pluck", "time": 0.0, "string": 6, "force": 6.0},
        {"type": "damp", "time": 0.6}]),
        "guitar": {"preset": "nylon-classical"}, "sample_rate": 48000},
}


def digest(audio: np.ndarray) -> str:
    return hashlib.sha256(np.ascontiguousarray(audio, dtype=np.float64).tobytes()).hexdigest()


def run_waveguide() -> dict[str, dict]:
    """Each waveguide scene as a user renders it, with the decay stop off, and in blocks of
    1000 frames."""
    out = {}
    variants = {"plain": engine.RenderOptions(),
                "no-stop": engine.RenderOptions(skip_decayed=False),
                "blocks-1000": engine.RenderOptions(block_frames=1000)}
    for name, scene in WAVEGUIDE.items():
        for v, opts in variants.items():
            r = engine.render_result(scene, options=opts)
            out[f"{name}/{v}"] = {"sha256": digest(r.audio), "warnings": len(r.warnings)}
            print(f"{name}/{v}: {out[f'{name}/{v}']['sha256'][:16]}", file=sys.stderr)
    return out


def run() -> dict[str, dict]:
    out = {}
    for name, scene in SCENES.items():
        # plain: as a user renders it (the decayed-string skip is on only without diagnostics)
        out[f"{name}/plain"] = {"sha256": digest(engine.render(scene))}
        for paths in ("all", "general"):
            opts = (engine.RenderOptions() if paths == "all"
                    else engine.RenderOptions(held_steps=False, skip_contacts=False))
            r = engine.render({**scene, "diagnostics": True}, options=opts)
            out[f"{name}/{paths}"] = {"sha256": digest(r.audio), "energy_error": r.energy_error,
                                      "warnings": len(r.warnings)}
        for key in [k for k in out if k.startswith(name + "/")]:
            print(f"{key}: {out[key]['sha256'][:16]} {out[key].get('energy_error', '')}",
                  file=sys.stderr)
    return out


FIRST_PROCESS = r"""
import sys
import numpy as np
import engine
from tools.render_digest import SCENES, WAVEGUIDE
scenes = WAVEGUIDE if sys.argv[2] == "1" else SCENES
np.savez(sys.argv[1], **{k: np.asarray(engine.render(sc)) for k, sc in scenes.items()})
"""


def first_process(waveguide: bool) -> None:
    """The ``--first-process`` table (the module's docstring)."""
    root = Path(__file__).resolve().parent.parent
    with tempfile.TemporaryDirectory(prefix="guitar-first-") as tmp:
        env = {**os.environ, "NUMBA_CACHE_DIR": tmp, "PYTHONPATH": str(root)}
        runs = []
        for name in ("compiling", "loading"):
            out = os.path.join(tmp, f"{name}.npz")
            subprocess.run([sys.executable, "-c", FIRST_PROCESS, out, str(int(waveguide))],
                           env=env, cwd=root, check=True)
            runs.append(np.load(out))
        print("| scene | identical | largest difference / peak |")
        print("| --- | --- | ---: |")
        for k in runs[0].files:
            a, b = runs[0][k], runs[1][k]
            peak = float(np.max(np.abs(b))) or 1.0
            print(f"| {k} | {'yes' if np.array_equal(a, b) else 'no'} | "
                  f"{float(np.max(np.abs(a - b))) / peak:.1e} |")


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--check", metavar="JSON", help="compare with a digest printed earlier")
    ap.add_argument("--waveguide", action="store_true",
                    help="the waveguide's scenes (WAVEGUIDE) instead of the default set")
    ap.add_argument("--first-process", action="store_true",
                    help="the compiling process against one that loads the cache (the docstring)")
    args = ap.parse_args()
    if args.first_process:
        first_process(args.waveguide)
        return 0
    before = None
    if args.check:
        with open(args.check) as f:
            before = json.load(f)
    # a digest of the waveguide's scenes is checked against them with or without the flag
    wg = args.waveguide or (before is not None and all(k.startswith("wg-") for k in before))
    now = run_waveguide() if wg else run()
    if before is None:
        json.dump(now, sys.stdout, indent=1)
        return 0
    changed = [k for k in before if before[k] != now.get(k)]
    for k in changed:
        print(f"CHANGED {k}: {before[k]} -> {now.get(k)}")
    print(f"{len(before) - len(changed)} of {len(before)} renders identical")
    return 1 if changed else 0


if __name__ == "__main__":
    sys.exit(main())
