"""Fingerprints of a fixed set of renders, to check that a refactor changed no sample.

    python -m tools.render_digest > before.json      # on the old tree
    python -m tools.render_digest --check before.json  # on the new tree: exit 1 on any change

Each scene is rendered through the public API (``engine.render``) as a user renders it, and with
diagnostics both with every step path on and with the specialised loops off (quiet and held steps
through the general path); the SHA-256 of the float64 samples is printed with the energy-balance
figure and the number of warnings.  The scenes cover fretted, tapped,
hammered, pulled, slid, bent, muted and harmonic strings, a strum, a hard pluck, several pickups,
stereo, both built-in bodies and none, the three qualities and an oversampled rate.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import sys

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


def digest(audio: np.ndarray) -> str:
    return hashlib.sha256(np.ascontiguousarray(audio, dtype=np.float64).tobytes()).hexdigest()


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


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--check", metavar="JSON", help="compare with a digest printed earlier")
    args = ap.parse_args()
    now = run()
    if not args.check:
        json.dump(now, sys.stdout, indent=1)
        return 0
    with open(args.check) as f:
        before = json.load(f)
    changed = [k for k in before if before[k] != now.get(k)]
    for k in changed:
        print(f"CHANGED {k}: {before[k]} -> {now.get(k)}")
    print(f"{len(before) - len(changed)} of {len(before)} renders identical")
    return 1 if changed else 0


if __name__ == "__main__":
    sys.exit(main())
