"""What the Guitar Pro and MIDI readers share: limits, the error type, the choice of preset, the
dynamics -> force rule, and the builder that turns the notes planned on one string into the scene's
events (``../shared/API.md``, "The scene" and "Scores in").

A planned note (``Planned``) is what a player does for one sounding note: which string and fret,
when the note starts and ends, how it is attacked (pluck, strum, tap, hammer-on, pull-off, legato
slide) and what is done to it while it sounds (palm mute, bend, vibrato, harmonic touch, slides in
and out).  ``string_events`` writes those as events, ending each note the way a guitarist ends it:
a ``damp`` on the string at the note's end, unless the note lets ring, or the next note on the string
starts there anyway (its attack stops the old vibration), or is played legato from it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from .. import presets as _presets


class ScoreError(ValueError):
    """A score that cannot be read: the message is one line naming the problem."""


# Bounds checked before large structures are built (a hostile file cannot make us allocate more).
MAX_SCORE_BYTES = 16 * 1024 * 1024
MAX_TRACKS = 64
MAX_MEASURES = 4096  # measure headers a Guitar Pro file may declare
MAX_PLAYED_MEASURES = 20000  # after repeats are expanded
MAX_BEATS = 200_000  # beats over all tracks and voices of a Guitar Pro file
MAX_NOTES = 100_000  # notes in a score (MIDI note-ons, Guitar Pro notes)
MAX_SCORE_SECONDS = 3600.0

FRET_LEAD_S = 0.015  # a fretting finger lands this long before the attack, if the string is free
GAP_FOR_DAMP_S = 0.005  # a note that the next note on its string follows within this needs no damp
SLIDE_S = 0.08  # the longest glide of a legato or shift slide
SLIDE_IN_S = 0.06  # a slide into a note from below or above
SLIDE_OUT_S = 0.1
TAIL_S = 1.5  # the scene lasts this long after its last event

# The touch of a dead note: x / L of the speaking length at the golden-ratio point, a node of no
# partial up to the 16th (``labels.HARMONIC_TOLERANCE``), so every partial is damped.
DEAD_TOUCH = 0.381966


def force_for_velocity(velocity: float) -> float:
    """Dynamics -> pluck force: 0.25 N x 16^(v/127) for a MIDI/Guitar Pro velocity v (1..127).

    Geometric, as loudness is: forte (Guitar Pro's default velocity 95) gives 2.0 N, the engine's
    default pluck; fff (127) 4 N; ppp (15) 0.35 N."""
    v = min(max(float(velocity), 1.0), 127.0)
    return 0.25 * 16.0 ** (v / 127.0)


def midi_name(pitch: int) -> str:
    names = ["C", "C#", "D", "D#", "E", "F", "F#", "G", "G#", "A", "A#", "B"]
    return f"{names[pitch % 12]}{pitch // 12 - 1}"


def note_midi(name: str) -> float:
    """A scientific pitch name as a (fractional) MIDI number."""
    return 69.0 + 12.0 * math.log2(_presets.note_frequency(name) / 440.0)


GM_FAMILY = {24: "nylon-classical", 25: "steel-acoustic"}


def preset_for_program(program: int, n_strings: int = 6) -> str:
    """General MIDI program (0-based) -> preset: 24 nylon, 25 steel, 26-31 electric, 32-39 bass;
    any other instrument is played on the default steel-string guitar (four or five strings: bass)."""
    if program in GM_FAMILY:
        return GM_FAMILY[program]
    if 26 <= program <= 31:
        return "electric"
    if 32 <= program <= 39 or n_strings in (4, 5):
        return "bass"
    return _presets.DEFAULT_PRESET


def is_guitar_program(program: int) -> bool:
    """General MIDI programs 24-39 (0-based): the guitars (24-31) and the basses (32-39)."""
    return 24 <= program <= 39


def program_name(program: int) -> str:
    """General MIDI instrument name of a 0-based program ("Acoustic Grand Piano" ...)."""
    try:
        import pretty_midi

        return pretty_midi.program_to_instrument_name(int(program))
    except (ImportError, ValueError):
        return f"program {program}"


def skip_instrument(label: str, program: int, warnings: list[str]) -> None:
    warnings.append(f"{label}: {program_name(program)} (General MIDI program {program}) is not a "
                    "guitar or bass, skipped (options.all_instruments plays it on a guitar)")


def preset_tuning(preset: str) -> list[int]:
    """The preset's open strings as MIDI numbers, string 1 first."""
    return [round(note_midi(s.note)) for s in _presets.get_preset(preset).strings]


@dataclass
class Planned:
    """One sounding note as a player plays it (times in seconds)."""

    track: int  # index into the scene's tracks
    string: int  # 1 = highest
    fret: int
    time: float  # attack
    end: float
    force: float
    pitch: float  # sounding MIDI pitch at the attack (for the report)
    attack: str = "pluck"  # pluck | strum | tap | hammer_on | pull_off | slide
    style: str = "finger"  # pluck style
    let_ring: bool = False
    palm_mute: float = 0.0  # mute amount, 0 = none
    touch: float | None = None  # harmonic touch, x / L of the whole string
    dead: bool = False
    bends: list = field(default_factory=list)  # (time, semitones, rise_s, release time or None)
    vibrato: tuple | None = None  # (depth_cents, rate_hz, start, duration)
    slide_in: int | None = None  # start fret of a slide into the note
    slide_out: int | None = None  # end fret of a slide out of the note
    legato_from: int | None = None  # fret of the previous note (hammer/pull/slide attacks)
    strum: int | None = None  # id of the strum that plucks it
    articulations: list[str] = field(default_factory=list)
    where: str = ""  # "bar 3, beat 2" (for warnings)
    position: float = 0.8  # pluck position x / L
    repeat: bool = False  # a further attack of one score note (trill, tremolo picking)

    def report(self, names: list[str]) -> dict:
        return {"track": self.track, "track_name": names[self.track], "string": self.string,
                "fret": self.fret, "time": _r(self.time), "end": _r(self.end),
                "pitch": round(self.pitch, 4), "dead": self.dead, "repeat": self.repeat,
                "articulations": list(self.articulations),
                "where": self.where}


def _r(x: float) -> float:
    return round(float(x), 6)


def string_events(notes: list[Planned], frets: int) -> list[dict]:
    """The events of the notes planned on one string (sorted by time, no two overlapping: a note
    that another on the same string follows is cut there)."""
    out: list[dict] = []
    notes = sorted(notes, key=lambda n: n.time)
    free_from = 0.0  # when the string's previous note ended (its damp) or its attack, if it rings
    held: dict[int, dict] = {}  # fret -> the event whose finger holds it down on this string
    for i, n in enumerate(notes):
        nxt = notes[i + 1] if i + 1 < len(notes) else None
        end = min(n.end, nxt.time) if nxt is not None else n.end
        end = max(end, n.time + 1e-4)
        s = n.string
        lead = n.time if (n.attack in ("hammer_on", "pull_off", "slide")) else max(
            n.time - FRET_LEAD_S, free_from, 0.0)
        start = len(out)
        # left hand first
        if n.attack == "pluck" or n.attack == "strum" or n.attack == "tap":
            if n.slide_in is not None:
                out.append({"type": "fret", "time": _r(lead), "string": s, "fret": n.slide_in})
                d = min(SLIDE_IN_S, 0.5 * (end - n.time))
                out.append({"type": "slide", "time": _r(n.time), "string": s,
                            "from_fret": n.slide_in, "to_fret": n.fret, "duration": _r(max(d, 1e-3))})
            elif n.attack != "tap":
                out.append({"type": "fret", "time": _r(lead), "string": s, "fret": n.fret})
        if n.touch is not None:
            release = end if n.dead else min(n.time + 0.03, end)
            out.append({"type": "harmonic", "time": _r(lead), "string": s,
                        "position": _r(n.touch), "release": _r(max(release, lead + 1e-3))})
        if n.palm_mute > 0:
            out.append({"type": "mute", "time": _r(lead), "string": s, "amount": _r(n.palm_mute),
                        "release": _r(max(end, lead + 1e-3))})
        for (bt, semis, rise, rel) in n.bends:
            ev = {"type": "bend", "time": _r(max(bt, 0.0)), "string": s, "semitones": _r(semis),
                  "duration": _r(max(rise, 1e-3))}
            if rel is not None and rel > bt:
                ev["release"] = _r(rel)
            out.append(ev)
        # the attack
        vel_scale = min(max(n.force / 2.0, 0.15), 2.5)
        if n.attack == "pluck":
            out.append({"type": "pluck", "time": _r(n.time), "string": s, "force": _r(n.force),
                        "position": _r(n.position), "style": n.style})
        elif n.attack == "tap":
            out.append({"type": "tap", "time": _r(n.time), "string": s, "fret": n.fret,
                        "velocity": _r(2.0 * vel_scale)})
        elif n.attack == "hammer_on":
            out.append({"type": "hammer_on", "time": _r(n.time), "string": s, "fret": n.fret,
                        "velocity": _r(2.0 * vel_scale)})
        elif n.attack == "pull_off":
            prev = n.legato_from
            if n.fret > 0 and n.fret not in held:  # the finger that stays is put down first
                prep = max(n.time - 0.04, notes[i - 1].time + 1e-3 if i else 0.0)
                prep = min(prep, n.time - 1e-4)
                out.append({"type": "hammer_on", "time": _r(prep), "string": s, "fret": n.fret,
                            "velocity": 0.1})
            for f, ev in held.items():  # fingers between the two frets lift with the pull-off
                if n.fret < f < (prev or 0) and ev["time"] < _r(n.time):
                    ev["release"] = _r(n.time)
            out.append({"type": "pull_off", "time": _r(n.time), "string": s, "fret": prev,
                        "force": _r(min(max(0.5 * n.force, 0.1), 20.0))})
        elif n.attack == "slide":
            prev = n.legato_from
            d = min(SLIDE_S, 0.5 * max(n.time - (notes[i - 1].time if i else 0.0), 2e-3))
            ts = _r(n.time - d)  # the glide ends at the note's time, rounded as the labels read it
            out.append({"type": "slide", "time": ts, "string": s, "from_fret": prev,
                        "to_fret": n.fret, "duration": _r(n.time - ts)})
        # strum: its plucks are written once per beat by the caller
        finger = next((e for e in reversed(out[start:]) if e.get("fret", e.get("to_fret")) ==
                       n.fret and e["type"] in ("fret", "tap", "hammer_on", "slide")), None)
        if n.attack in ("pluck", "strum", "tap", "slide"):
            held = {n.fret: finger} if n.fret > 0 and finger is not None else {}
        elif n.attack == "hammer_on" and finger is not None:
            held[n.fret] = finger
        elif n.attack == "pull_off":
            held.pop(n.legato_from, None)
            held = {f: ev for f, ev in held.items() if "release" not in ev}
            if n.fret > 0 and n.fret not in held and finger is not None:
                held[n.fret] = finger
        if n.vibrato is not None:
            depth, rate, start, dur = n.vibrato
            out.append({"type": "vibrato", "time": _r(start), "string": s, "depth_cents": depth,
                        "rate_hz": rate, "duration": _r(max(dur, 1e-3))})
        # the end
        legato_next = nxt is not None and nxt.attack in ("hammer_on", "pull_off", "slide")
        if n.slide_out is not None:
            d = min(SLIDE_OUT_S, 0.5 * (end - n.time))
            out.append({"type": "slide", "time": _r(end - d), "string": s, "from_fret": n.fret,
                        "to_fret": n.slide_out, "duration": _r(max(d, 1e-3))})
        gap = (nxt.time - end) if nxt is not None else math.inf
        ends_here = n.slide_out is not None or not (n.let_ring or legato_next)
        if ends_here and gap > GAP_FOR_DAMP_S:
            out.append({"type": "damp", "time": _r(end), "string": s})
        free_from = end  # the next fret goes down only once this note is over
        n.end = end
    return out


def strum_event(time: float, strings: list[int], direction: str, spread: float, force: float,
                position: float, style: str) -> dict:
    return {"type": "strum", "time": _r(time), "strings": sorted(strings), "direction": direction,
            "spread": _r(spread), "force": _r(force), "position": _r(position), "style": style}
