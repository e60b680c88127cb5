"""The engine's presets with their strings, tunings and physical parameters."""

from __future__ import annotations

from dataclasses import asdict
from functools import cache

from fastapi import APIRouter

import engine

from ..schemas import FingerInfo, PresetInfo, Presets, StringInfo

router = APIRouter(tags=["presets"])

# Tension depends (slightly) on the grid; this is the rate /presets reports it at.
_TENSION_RATE_HZ = 44100


def _string_info(preset, number: int) -> StringInfo:
    spec = preset.strings[number - 1]
    return StringInfo(
        string=number,
        note=spec.note,
        frequency_hz=spec.frequency_hz,
        tension_n=engine.tuned_tension(preset, number, _TENSION_RATE_HZ),
        radius_m=spec.radius_m,
        density_kg_m3=spec.density_kg_m3,
        youngs_modulus_pa=spec.youngs_modulus_pa,
        linear_density_kg_m=spec.linear_density_kg_m,
        t60_fundamental_s=spec.t60_fundamental_s,
        t60_2khz_s=spec.t60_2khz_s,
        saddle_setback_m=spec.saddle_setback_m,
        nut_compensation_m=spec.nut_compensation_m,
    )


def _preset_info(p, default: str) -> PresetInfo:
    return PresetInfo(
        name=p.name,
        description=p.description,
        default=p.name == default,
        scale_length_m=p.scale_length_m,
        frets=p.frets,
        action_nut_m=p.action_nut_m,
        action_12th_m=p.action_12th_m,
        fret_height_m=p.fret_height_m,
        pickup_position=p.pickup_position,
        body=p.body,
        tuning=[s.note for s in p.strings],
        strings=[_string_info(p, i) for i in range(1, p.n_strings + 1)],
        finger=FingerInfo(**asdict(p.finger)),
    )


@cache
def presets_table() -> Presets:
    # Tuning solves each string's dispersion relation: done once per process, not per request.
    default = engine.parse_scene({"duration": 1.0}).guitar.preset  # the schema's default
    return Presets(default=default,
                   presets=[_preset_info(p, default) for p in engine.PRESETS.values()])


@router.get("/presets", response_model=Presets)
async def presets() -> Presets:
    """Every preset: scale length, frets, action, finger and, per string, pitch, tension (N),
    radius, density, Young's modulus and decay times — the values a scene's overrides start from."""
    return presets_table()
