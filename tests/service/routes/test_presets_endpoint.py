"""GET /presets: every engine preset with its strings, tunings and physical parameters."""

from __future__ import annotations

import pytest

import engine


def test_presets_list_every_engine_preset(harness) -> None:
    body = harness.get("/presets").json()
    assert body["default"] == "steel-acoustic"
    assert {p["name"] for p in body["presets"]} == set(engine.PRESETS)
    assert [p["name"] for p in body["presets"] if p["default"]] == ["steel-acoustic"]


def test_steel_acoustic_strings(harness) -> None:
    steel = next(p for p in harness.get("/presets").json()["presets"]
                 if p["name"] == "steel-acoustic")
    assert steel["tuning"] == ["E4", "B3", "G3", "D3", "A2", "E2"]
    assert [s["string"] for s in steel["strings"]] == [1, 2, 3, 4, 5, 6]
    assert steel["strings"][5]["frequency_hz"] == pytest.approx(82.41, abs=0.01)
    assert steel["strings"][0]["frequency_hz"] == pytest.approx(329.63, abs=0.01)
    assert steel["scale_length_m"] == pytest.approx(0.645)
    assert steel["frets"] == 20
    for s in steel["strings"]:
        # A light acoustic set runs at roughly 100-140 N a string.
        assert 60 < s["tension_n"] < 200, s
        # Ideal-string check: f0 = sqrt(T / mu) / 2L, to within the stiffness correction.
        f_ideal = (s["tension_n"] / s["linear_density_kg_m"]) ** 0.5 / (2 * steel["scale_length_m"])
        assert f_ideal == pytest.approx(s["frequency_hz"], rel=0.02)
        assert s["radius_m"] > 0 and s["t60_fundamental_s"] > s["t60_2khz_s"] > 0
    assert steel["finger"]["mass_kg"] > 0


def test_presets_name_their_body(harness) -> None:
    bodies = {p["name"]: p["body"] for p in harness.get("/presets").json()["presets"]}
    assert bodies == {name: p.body for name, p in engine.PRESETS.items()}
    assert bodies["steel-acoustic"] == "acoustic" and bodies["electric"] == "none"


def test_presets_carry_their_intonation_compensation(harness) -> None:
    """Each string's saddle setback and nut compensation, as a scene's overrides start from: the
    open string speaks over scale + setback - nut compensation."""
    for p in harness.get("/presets").json()["presets"]:
        preset = engine.get_preset(p["name"])
        for s in p["strings"]:
            spec = preset.strings[s["string"] - 1]
            assert s["saddle_setback_m"] == spec.saddle_setback_m
            assert s["nut_compensation_m"] == spec.nut_compensation_m
            assert p["scale_length_m"] + s["saddle_setback_m"] - s["nut_compensation_m"] == \
                pytest.approx(preset.string_length_m(s["string"]), abs=1e-15)
