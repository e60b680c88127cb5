"""The playable guitar's targets, measured on rendered audio (steel-acoustic, 44.1 kHz, no body).

    python -m benchmarks.articulations

Prints one row per target of the articulation issue: what is measured, the value, the limit.
The measurements are ``engine.testing.articulations``, which ``tests/engine/test_articulations.py``
asserts on, so the table and the tests cannot disagree.
"""

from __future__ import annotations

from engine.testing.articulations import (
    bend,
    bend_release,
    dead_note,
    hammer_on,
    harmonic,
    palm_mute,
    pull_off,
    slide,
    vibrato,
)


def main() -> None:
    rows = []
    b = bend()
    rows.append(("bend 2 semitones, held (cents from target)", f"{b['held']:+.2f}", "±10"))
    r = bend_release()
    rows.append(("bend 1 semitone held / released (cents)",
                 f"{r['held']:+.2f} / {r['released']:+.2f}", "±10"))
    v = vibrato()
    rows.append(("vibrato 5 Hz, 30 cents: rate (Hz) / depth (cents)",
                 f"{v['rate_hz']:.2f} / {v['depth_cents']:.1f}", "±20 %"))
    s = slide()
    rows.append(("slide 5 -> 7, string 3: before / after (cents)",
                 f"{s['before']:+.2f} / {s['after']:+.2f}", "±10"))
    h = hammer_on()
    rows.append(("hammer-on 5 -> 7 (cents from fret 7)", f"{h['after']:+.2f}", "±10"))
    p = pull_off()
    rows.append(("pull-off 7 -> 5: before / after (cents)",
                 f"{p['before']:+.2f} / {p['after']:+.2f}", "±10"))
    h12, h7 = harmonic(12), harmonic(7)
    lv = h12["levels"]
    rows.append(("harmonic at fret 12: partial 1 below partial 2 (dB)",
                 f"{lv[2] - lv[1]:.1f}", ">= 20"))
    rows.append(("harmonic at fret 7: loudest partial", str(h7["loudest"]), "3"))
    rows.append(("palm mute: level 0.5 s after the pluck, below open (dB)",
                 f"{palm_mute()['drop_db']:.1f}", ">= 20"))
    rows.append(("dead note: level 0.5 s after the pluck, below fretted (dB)",
                 f"{dead_note()['drop_db']:.1f}", ">= 20"))
    worst = max(x["energy"] for x in (b, r, v, s, h, p, h12, h7))
    rows.append(("energy balance, worst of the scenes above", f"{worst:.1e}", "<= 1e-11"))
    w = max(len(r[0]) for r in rows)
    print(f"{'target':{w}s} | {'measured':>13s} | limit")
    for name, val, lim in rows:
        print(f"{name:{w}s} | {val:>13s} | {lim}")


if __name__ == "__main__":
    main()
