"""Warnings grouped for people (engine/score/warnings.py): the per-beat warnings of a score folded
into one line per message and track, with its bars."""

from __future__ import annotations

import pytest

from engine.score.warnings import MODES, bar_ranges, group, select

from .conftest import corpus

LEAD = "track 'Lead' (1)"
FADE = "fade-in (volume swell) not playable, ignored"


def test_per_beat_warnings_become_one_line_with_bar_ranges_and_beats() -> None:
    warnings = [f"bar {bar}, beat {beat}, {LEAD}: {FADE}" for bar in (9, 10, 11, 12)
                for beat in (1, 3)]
    warnings.insert(3, "track 'Drums' (5): a percussion track, left out")
    assert group(warnings) == [f"{LEAD}: {FADE}: bars 9–12 (8 beats)",
                               "track 'Drums' (5): a percussion track, left out"]


def test_tracks_and_messages_stay_apart_and_repeats_count_once() -> None:
    other = "track 'Solo' (2)"
    warnings = [f"bar 3, beat 1, {LEAD}: {FADE}", f"bar 3, beat 1, {other}: {FADE}",
                f"bar 5, beat 2, {LEAD}: {FADE}", f"bar 3, beat 1, {LEAD}: {FADE}",  # a repeat
                f"bar 7, beat 4, {LEAD}: SemiHarmonic not playable, played as a plain note"]
    assert group(warnings) == [
        f"{LEAD}: {FADE}: bars 3, 5 (2 beats)",
        f"bar 3, beat 1, {other}: {FADE}",  # once: its own words
        f"bar 7, beat 4, {LEAD}: SemiHarmonic not playable, played as a plain note",
    ]


def test_midi_positions_group_too_and_plain_repeats_are_counted() -> None:
    bend = "downward pitch bends (this one and any later) not playable, ignored"
    warnings = [f"1.500 s (bar 1, beat 4), {LEAD}: {bend}", f"4.000 s (bar 3, beat 1), {LEAD}: {bend}",
                "string 3: the tap at 0 s presses 0.9 N", "string 3: the tap at 0 s presses 0.9 N"]
    assert group(warnings) == [f"{LEAD}: {bend}: bars 1, 3 (2 beats)",
                               "string 3: the tap at 0 s presses 0.9 N (×2)"]


def test_bar_ranges() -> None:
    assert bar_ranges([23, 9, 10, 11, 12, 20, 22, 12]) == "9–12, 20, 22–23"
    assert bar_ranges([]) == ""


def test_modes() -> None:
    warnings = [f"bar {b}, beat 1, {LEAD}: {FADE}" for b in (1, 2)]
    assert MODES == ("summary", "all", "none")
    assert select(warnings, "all") == warnings
    assert select(warnings, "none") == []
    assert select(warnings) == [f"{LEAD}: {FADE}: bars 1–2 (2 beats)"]
    with pytest.raises(ValueError, match="summary, all, none"):
        select(warnings, "some")


def test_a_corpus_score_sends_fewer_lines_and_loses_no_kind() -> None:
    """On Guitar Pro files of PyGuitarPro's corpus: every message survives grouping, and no line
    is repeated."""
    from engine.score import ScoreError, score_to_scene

    for path in corpus("gp", "*.gp[345]"):
        try:
            warnings = list(score_to_scene(path).warnings)
        except ScoreError:  # a file with nothing to play (tested in test_gp_corpus.py)
            continue
        grouped = group(warnings)
        assert len(grouped) <= len(warnings) and len(set(grouped)) == len(grouped)
        for w in warnings:
            what = w.rsplit(": ", 1)[-1]
            assert any(what in g for g in grouped), (path, w)
