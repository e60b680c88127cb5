"""What the ``guitar-synth`` subcommands share: the input suffixes, the one-line error and its
exit status, and the edits every subcommand makes to a scene in its JSON form."""

from __future__ import annotations

import argparse
from typing import Any, NoReturn

import engine

SCENE_SUFFIXES = (".json",)
SCORE_SUFFIXES = engine.SCORE_SUFFIXES  # every score format the engine reads
EXIT_BAD_INPUT = 2


class BadInput(Exception):
    """A problem with what the user gave; its message is the one line printed (exit 2)."""


class OneLineParser(argparse.ArgumentParser):
    """argparse, but a usage error is one line (the usage is one ``--help`` away)."""

    def error(self, message: str) -> NoReturn:
        self.exit(EXIT_BAD_INPUT, f"{self.prog}: error: {message} (see {self.prog} --help)\n")


def set_model(scene: dict[str, Any], model: str) -> None:
    """Every track on ``model``: a track's own model would otherwise win over the scene's."""
    scene["model"] = model
    for track in scene["tracks"] if isinstance(scene.get("tracks"), list) else []:
        if isinstance(track, dict):
            track.pop("model", None)
