"""Strings and frets for notes that come without them (MIDI): a Viterbi search over chord shapes.

The notes are cut into *slices*: notes whose onsets lie within ``CHORD_S`` of each other sound as
one chord.  Before the search, a note outside the instrument (below its lowest open string or above
its highest fret) is moved by octaves into it, and a pitch repeated within one slice is played once;
a slice with more notes than strings keeps its lowest and highest notes and those between spread
most evenly.  Both are compromises, and are counted and reported.

**Shapes.**  For each slice every assignment of its notes to (string, fret) is enumerated such that

* every note has its own string (one note per string at a time),
* the fretted notes span at most ``MAX_SPAN`` frets (max fret - min fret <= 5),
* at most four fingers are needed: one per fretted note, except that the notes at the lowest fret
  can share one finger as a barre.

If no shape holds all notes, the fewest notes are left out that make one possible (each counted).

**Cost** of a path of shapes (minimised exactly by dynamic programming, the state being the shape
and the hand's position, which an all-open shape carries over from the shape before it):

    sum over slices of   MOVE x |h_i - h_{i-1}|            the hand's move, in frets
                       + SPAN x max(0, span_i - 3)          a stretch beyond four frets
                       + FRETTED x (fretted notes_i)        an open string needs no finger
                       + HEIGHT x h_i                       a slight preference for low positions
                       + CUT x (notes still sounding from slice i-1 whose string slice i takes)
                       + DROP x (notes left out of slice i)

where h is the hand's position, the lowest fretted fret of the shape (unchanged over an all-open
shape), with MOVE = 1, SPAN = 0.5, FRETTED = 0.1, HEIGHT = 0.03, CUT = 2 and DROP = 10.  After the
search, a note still sounding when a later note takes its string is cut there (a compromise when
more than ``CUT_GRACE_S`` is lost).

``greedy`` is the baseline: each note of a slice, highest first, takes the lowest fret on a string
still free in the slice, with no span or movement rule.  ``measure`` scores either the same way
(``benchmarks/fingering.py`` prints both).
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass, field
from typing import NamedTuple

CHORD_S = 0.02
MAX_SPAN = 5
MAX_FINGERS = 4
MOVE, SPAN, FRETTED, HEIGHT, CUT, DROP = 1.0, 0.5, 0.1, 0.03, 2.0, 10.0
CUT_GRACE_S = 0.05
MAX_SHAPES = 24


@dataclass
class Fingered:
    """The result for a list of notes (same order as given)."""

    position: list  # (string, fret) or None (left out)
    pitch: list[int]  # the pitch played (moved by octaves into range where needed)
    end: list[float]  # the end, cut where a later note takes the string
    moved: set[int] = field(default_factory=set)
    dropped: set[int] = field(default_factory=set)
    cut: set[int] = field(default_factory=set)
    wide: set[int] = field(default_factory=set)  # notes of chords wider than MAX_SPAN (greedy)


def _slices(times: list[float]) -> list[list[int]]:
    order = sorted(range(len(times)), key=lambda i: times[i])
    out: list[list[int]] = []
    for i in order:
        if out and times[i] - times[out[-1][0]] <= CHORD_S:
            out[-1].append(i)
        else:
            out.append([i])
    return out


def _prepare(pitches, tuning, frets):
    lo, hi = min(tuning), max(tuning) + frets
    played, moved = [], set()
    for i, p in enumerate(pitches):
        q = p
        while q < lo:
            q += 12
        while q > hi:
            q -= 12
        if q != p:
            moved.add(i)
        played.append(q)
    return played, moved


def _thin(idx: list[int], pitch: list[int], n_strings: int, dropped: set[int]) -> list[int]:
    """One note per pitch, and at most ``n_strings`` notes: lowest, highest, the rest spread."""
    seen, keep = {}, []
    for i in sorted(idx, key=lambda i: pitch[i]):
        if pitch[i] in seen:
            dropped.add(i)
        else:
            seen[pitch[i]] = i
            keep.append(i)
    if len(keep) > n_strings:
        picks = {round(k * (len(keep) - 1) / (n_strings - 1)) for k in range(n_strings)}
        for k, i in enumerate(keep):
            if k not in picks:
                dropped.add(i)
        keep = [i for k, i in enumerate(keep) if k in picks]
    return keep


def _fingers(frets: list[int]) -> int:
    fretted = [f for f in frets if f > 0]
    if not fretted:
        return 0
    low = min(fretted)
    return len(fretted) - max(fretted.count(low) - 1, 0)


class _Shape(NamedTuple):
    """A shape with what the search asks of it, worked out once."""

    position: tuple  # (string, fret) per note, in the chord's order
    hand: int | None  # the lowest fretted fret; None for an all-open shape
    cost: float  # the terms of the cost that depend on this shape alone (``_static``)
    strings: frozenset[int]  # the strings it takes


def _shape(position: tuple) -> _Shape:
    return _Shape(position, _hand(position), _static(position), frozenset(s for s, _ in position))


def _shapes(chord: list[int], tuning, frets) -> list[_Shape]:
    """Shapes (``_Shape.position`` in ``chord`` order) that a hand can hold for the pitches
    ``chord``, at most ``MAX_SHAPES``, the lowest ``_static`` cost first."""
    out: list[tuple] = []
    opts = [[(s + 1, p - tuning[s]) for s in range(len(tuning)) if 0 <= p - tuning[s] <= frets]
            for p in chord]

    def rec(k, used, chosen, lo, hi):
        if len(out) >= 4 * MAX_SHAPES:
            return
        if k == len(chord):
            if _fingers([f for _, f in chosen]) <= MAX_FINGERS:
                out.append(tuple(chosen))
            return
        for s, f in opts[k]:
            if s in used:
                continue
            nlo, nhi = (min(lo, f), max(hi, f)) if f > 0 else (lo, hi)
            if nhi - nlo > MAX_SPAN:
                continue
            rec(k + 1, used | {s}, chosen + [(s, f)], nlo, nhi)

    rec(0, frozenset(), [], math.inf, -math.inf)
    shapes = sorted(map(_shape, out), key=lambda sh: sh.cost)
    return shapes[:MAX_SHAPES]


def _hand(shape) -> int | None:
    fretted = [f for _, f in shape if f > 0]
    return min(fretted) if fretted else None


def _static(shape) -> float:
    fretted = [f for _, f in shape if f > 0]
    if not fretted:
        return 0.0
    span = max(fretted) - min(fretted)
    return SPAN * max(0, span - 3) + FRETTED * len(fretted) + HEIGHT * min(fretted)


def _best_shapes(chord: tuple[int, ...], tuning, frets) -> tuple[list[int], list[_Shape]]:
    """The shapes for the most notes of the pitches ``chord`` that any shape can hold: (the
    indices into ``chord`` of the notes kept, their shapes); the other notes are left out."""
    notes = range(len(chord))
    by_pitch = sorted(notes, key=lambda i: chord[i])
    prefer = by_pitch[1:-1] + by_pitch[-1:] + by_pitch[:1] if len(chord) > 1 else by_pitch
    for k in range(0, len(chord)):
        found = []
        for gone in itertools.combinations(prefer, k):
            keep = [i for i in notes if i not in gone]
            sh = _shapes([chord[i] for i in keep], tuning, frets)
            if sh:
                found.append((keep, sh))
            if k and len(found) >= 3:
                break
        if found:
            return min(found, key=lambda ks: ks[1][0].cost)
    return [], [_shape(())]


def viterbi(times, ends, pitches, tuning, frets) -> Fingered:
    """Strings and frets for notes (onset ``times``, ``ends``, MIDI ``pitches``) on strings tuned
    ``tuning`` (MIDI, string 1 first) with ``frets`` frets, by the cost in the module's docstring."""
    pitch, moved = _prepare(pitches, tuning, frets)
    dropped: set[int] = set()
    slices = []
    shapes_of: dict[tuple[int, ...], tuple] = {}  # pitches -> _best_shapes (songs repeat chords)
    for idx in _slices(times):
        keep = _thin(idx, pitch, len(tuning), dropped)
        chord = tuple(pitch[i] for i in keep)
        if chord not in shapes_of:
            shapes_of[chord] = _best_shapes(chord, tuning, frets)
        kept, shapes = shapes_of[chord]
        dropped.update(i for j, i in enumerate(keep) if j not in kept)
        slices.append(([keep[j] for j in kept], shapes))
    # DP over (shape index, hand position)
    prev: dict[tuple[int, int | None], tuple[float, tuple | None]] = {}
    back: list[dict] = []
    for si, (keep, shapes) in enumerate(slices):
        cur: dict[tuple[int, int | None], tuple[float, tuple | None]] = {}
        if prev:
            # per shape of the slice before: the strings of its notes still sounding when this
            # slice starts, which this slice cuts if it takes them (a slice of no notes takes none)
            pkeep, pshapes = slices[si - 1]
            t_cut = times[keep[0]] + CUT_GRACE_S if keep else math.inf
            sounding = [j for j, i in enumerate(pkeep) if ends[i] > t_cut]
            ringing = [{p.position[j][0] for j in sounding} for p in pshapes]
        for k, shape in enumerate(shapes):
            h, local = shape.hand, shape.cost
            if not prev:
                cur[(k, h)] = (local, None)
                continue
            cuts = [CUT * len(shape.strings & r) for r in ringing]
            for pkey, (pc, _) in prev.items():
                pk, ph = pkey
                move = MOVE * abs(h - ph) if (h is not None and ph is not None) else 0.0
                c = pc + move + local + cuts[pk]
                key = (k, h if h is not None else ph)
                if key not in cur or c < cur[key][0]:
                    cur[key] = (c, pkey)
        back.append(cur)
        prev = cur
    chosen = [0] * len(slices)
    if back:
        key = min(back[-1], key=lambda k: back[-1][k][0])
        for si in range(len(slices) - 1, -1, -1):
            chosen[si] = key[0]
            bp = back[si][key][1]
            if bp is None:
                break
            key = bp
    position: list = [None] * len(pitches)
    for si, (keep, shapes) in enumerate(slices):
        for i, pos in zip(keep, shapes[chosen[si]].position, strict=False):
            position[i] = pos
    return _finish(times, ends, pitch, position, moved, dropped)


def greedy(times, ends, pitches, tuning, frets) -> Fingered:
    """The baseline: the lowest fret on a free string, note by note (highest note first)."""
    pitch, moved = _prepare(pitches, tuning, frets)
    dropped: set[int] = set()
    position: list = [None] * len(pitches)
    wide: set[int] = set()
    for idx in _slices(times):
        used: set[int] = set()
        for i in sorted(idx, key=lambda i: -pitch[i]):
            opts = [(pitch[i] - tuning[s], s + 1) for s in range(len(tuning))
                    if s + 1 not in used and 0 <= pitch[i] - tuning[s] <= frets]
            if not opts:
                dropped.add(i)
                continue
            f, s = min(opts)
            used.add(s)
            position[i] = (s, f)
        fretted = [position[i][1] for i in idx if position[i] and position[i][1] > 0]
        if fretted and max(fretted) - min(fretted) > MAX_SPAN:
            wide.update(i for i in idx if position[i])
    out = _finish(times, ends, pitch, position, moved, dropped)
    out.wide = wide
    return out


def _finish(times, ends, pitch, position, moved, dropped) -> Fingered:
    end = list(ends)
    cut: set[int] = set()
    by_string: dict[int, list[int]] = {}
    for i, pos in enumerate(position):
        if pos is not None:
            by_string.setdefault(pos[0], []).append(i)
    for idx in by_string.values():
        idx.sort(key=lambda i: times[i])
        for a, b in itertools.pairwise(idx):
            if end[a] > times[b]:
                if end[a] - times[b] > CUT_GRACE_S:
                    cut.add(a)
                end[a] = times[b]
    return Fingered(position, pitch, end, moved, dropped, cut)


def measure(f: Fingered, times) -> dict:
    """Mean fret movement of the hand per note (|change of the lowest fretted fret| between
    consecutive slices that fret something), and the notes that needed a compromise (moved by an
    octave, left out, cut short, or in a chord wider than ``MAX_SPAN``)."""
    moves, last = 0.0, None
    n = sum(1 for p in f.position if p is not None)
    for idx in _slices(times):
        fretted = [f.position[i][1] for i in idx if f.position[i] and f.position[i][1] > 0]
        if not fretted:
            continue
        h = min(fretted)
        if last is not None:
            moves += abs(h - last)
        last = h
    comp = f.moved | f.dropped | f.cut | f.wide
    return {"notes": len(times), "placed": n, "mean_move": moves / max(n, 1),
            "compromises": len(comp), "moved": len(f.moved), "dropped": len(f.dropped),
            "cut": len(f.cut), "wide": len(f.wide)}
