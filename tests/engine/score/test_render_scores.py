"""Converted scores rendered by the engine (needs the engine side of issue 22: ``tracks``, the
``damp`` event and presets extended to a score's string count; these tests pass once it is
merged).  Kept short with ``max_seconds``."""

from __future__ import annotations

import os

import numpy as np
import pytest

import engine
from engine.score import score_to_scene

from .conftest import corpus

FILES = ["Demo v5.gp5", "Effects.gp5", "Harmonics.gp5", "Slides.gp5", "Strokes.gp5",
         "001_Funky_Guy.gp5"]


@pytest.mark.parametrize("name", FILES)
def test_gp_scores_render(name):
    path = next(p for p in corpus("gp", "*.gp5") if os.path.basename(p) == name)
    scene = score_to_scene(path, max_seconds=2.0)
    scene["quality"] = "draft"
    audio = engine.render(scene)
    assert audio.shape[0] == pytest.approx(2.0 * 44100, abs=2)
    assert np.all(np.isfinite(audio)) and np.max(np.abs(audio)) > 0


@pytest.mark.parametrize("name", ["test02.mid", "1390.mid"])
def test_midi_scores_render(name):
    path = next(p for p in corpus("midi", "*.mid") if os.path.basename(p) == name)
    scene = score_to_scene(path, max_seconds=2.0)
    scene["quality"] = "draft"
    audio = engine.render(scene)
    assert np.all(np.isfinite(audio)) and np.max(np.abs(audio)) > 0
