"""Warnings grouped for people: one line per thing that cannot be played, with where it happens.

A score importer warns once per beat ("bar 9, beat 1, track 'Lead' (1): fade-in (volume swell) not
playable, ignored", then the same for bar 9 beat 3, bar 10 beat 1, ...); a song can send the same
message dozens of times.  ``group`` folds the warnings that say the same thing about the same
track into one line naming the bars (ranges contracted) and the number of beats:

    track 'Lead' (1): fade-in (volume swell) not playable, ignored: bars 9–12 (8 beats)

A message that occurs at one beat only keeps its own words; a warning with no bar and beat
("track 'Drums' (5): a percussion track, left out", a render's "string 3: ...") is kept as it is,
its exact repeats folded into one with a count.  Pure Python (no numpy, no numba): the service, the
command line and the demo page's API answers all use it.
"""

from __future__ import annotations

import re
from collections.abc import Iterable
from dataclasses import dataclass, field

# Guitar Pro: "bar 9, beat 1, <who>: <what>"; MIDI: "12.500 s (bar 9, beat 1), <who>: <what>"
_GP = re.compile(r"^bar (\d+), beat (\d+), (.*)$", re.S)
_MIDI = re.compile(r"^\d+(?:\.\d+)? s \(bar (\d+), beat (\d+)\), (.*)$", re.S)
_WHO = re.compile(r"^(track '.*?' \(\d+\)): (.*)$", re.S)

MODES = ("summary", "all", "none")


@dataclass
class _Group:
    first: str  # the first warning's own text
    beats: dict[tuple[int, int], None] = field(default_factory=dict)  # distinct (bar, beat)
    count: int = 0


def _split(warning: str) -> tuple[tuple[str, str], tuple[int, int]] | None:
    """((who, what), (bar, beat)) of a warning that names a bar and a beat, else None."""
    m = _GP.match(warning) or _MIDI.match(warning)
    if m is None:
        return None
    bar, beat, rest = int(m.group(1)), int(m.group(2)), m.group(3)
    who = _WHO.match(rest)
    key = (who.group(1), who.group(2)) if who else ("", rest)
    return key, (bar, beat)


def bar_ranges(bars: Iterable[int]) -> str:
    """``[9, 10, 11, 12, 20, 22, 23]`` -> ``"9–12, 20, 22–23"``."""
    out: list[str] = []
    ordered = sorted(set(bars))
    i = 0
    while i < len(ordered):
        j = i
        while j + 1 < len(ordered) and ordered[j + 1] == ordered[j] + 1:
            j += 1
        out.append(str(ordered[i]) if i == j else f"{ordered[i]}–{ordered[j]}")
        i = j + 1
    return ", ".join(out)


def group(warnings: Iterable[str]) -> list[str]:
    """The warnings with the ones that say the same thing folded into one line each, in the order
    each first occurs."""
    groups: dict[tuple[str, str], _Group] = {}
    for w in warnings:
        split = _split(w)
        key, where = split if split else (("=", w), None)
        g = groups.setdefault(key, _Group(first=w))
        g.count += 1
        if where is not None:
            g.beats[where] = None
    out = []
    for (who, what), g in groups.items():
        if who == "=":  # no bar and beat: the text itself, repeats counted
            out.append(g.first if g.count == 1 else f"{g.first} (×{g.count})")
        elif len(g.beats) == 1:
            out.append(g.first)
        else:
            bars = {bar for bar, _ in g.beats}
            plural = "s" if len(bars) > 1 else ""
            where = f"bar{plural} {bar_ranges(bars)} ({len(g.beats)} beats)"
            out.append(f"{who}: {what}: {where}" if who else f"{what}: {where}")
    return out


def select(warnings: list[str], mode: str = "summary") -> list[str]:
    """The warnings to show for ``mode``: ``summary`` (grouped), ``all`` (every one as it came)
    or ``none``."""
    if mode not in MODES:
        raise ValueError(f"warnings mode {mode!r}: one of {', '.join(MODES)}")
    if mode == "none":
        return []
    return list(warnings) if mode == "all" else group(warnings)
