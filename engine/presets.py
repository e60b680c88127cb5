"""Instruments: string sets, action, frets and the fretting finger, in SI units.

Each preset is a set of physical strings (the parameters of eq. (3) of the DAFx24 paper, Bilbao,
Russo, Webb & Ducceschi 2024) plus the geometry the collision terms of eqs. (7)-(10) need.  Tensions
are *not* stored: every string is tuned by solving the numerical scheme's own dispersion relation for
the tension that puts its fundamental at the nominal pitch (see ``engine.fd.string``), so grid error and
bending stiffness do not detune the open strings.

Sources and reasoning
---------------------
* Steel acoustic: 645 mm (25.4") scale, light gauge .012-.053 phosphor-bronze set.  Plain strings are
  steel (rho 7850 kg/m^3, E 200 GPa).  A wound string is described by its outer radius, its mass per
  length (from the maker's published tension at pitch, mu = T / (2 L f0)^2) and an *effective* Young's
  modulus E_eff = E_steel (r_core / r)^4, so that E_eff * I(r) equals the core's bending stiffness: the
  wrap adds mass but almost no stiffness.  (The single-modulus model then under-states the wound
  strings' axial stiffness EA in the Kirchhoff-Carrier term; documented, not hidden.)
* Nylon classical: 650 mm scale, normal-tension set; nylon rho 1140 kg/m^3, E 5 GPa for the trebles;
  basses are silver-plated copper on a multifilament nylon core, whose stiffness is mostly the core's.
* Decay: T60 at the fundamental and at 2 kHz, typical of measured guitar partial decays (several
  seconds at the fundamental, a second or less at 2 kHz; nylon shorter than steel).  sigma_0 and
  sigma_1 follow from these by the two-frequency calibration of Bilbao 2009, sec. 7.1.
* Action: clearance between the string and the fret crowns at the nut and at the 12th fret (the
  string's rest line rises linearly towards the bridge); fret crowns stand ``fret_height_m`` above the
  fretboard.  Values are those of a comfortable factory set-up.
* Finger: a fingertip pad of a few grams effective mass, a linear (alpha = 1) contact stiffness of a
  fleshy pad and contact damping (real fingertips are lossy; an undamped finger mass rings, see
  ``../shared/papers/NOTES.md``).
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, field, replace

import numpy as np

STEEL_DENSITY = 7850.0
STEEL_E = 2.0e11
NYLON_DENSITY = 1140.0
NYLON_E = 5.0e9
INCH = 0.0254


def note_frequency(name: str) -> float:
    """Scientific pitch name ('E2', 'F#3', 'Bb4') to Hz with A4 = 440 Hz."""
    name = name.strip()
    letters = {"C": -9, "D": -7, "E": -5, "F": -4, "G": -2, "A": 0, "B": 2}
    if not name or name[0].upper() not in letters:
        raise ValueError(f"not a note name: {name!r}")
    semis = letters[name[0].upper()]
    rest = name[1:]
    while rest and rest[0] in "#b":
        semis += 1 if rest[0] == "#" else -1
        rest = rest[1:]
    # an octave of one or two digits (-9..99): "E99999" is not a pitch, and 2 ** huge overflows
    if not re.fullmatch(r"-?\d{1,2}", rest):
        raise ValueError(f"not a note name: {name!r} (a letter A-G, optional # or b, and an "
                         "octave of one or two digits, e.g. 'E2', 'F#3', 'Bb4')")
    octave = int(rest)
    return 440.0 * 2.0 ** ((semis + 12 * (octave - 4)) / 12.0)


@dataclass(frozen=True)
class StringSpec:
    """One string's physical parameters (SI units)."""

    note: str  # nominal open-string pitch, scientific notation
    radius_m: float  # outer radius r; A = pi r^2, I = pi r^4 / 4
    density_kg_m3: float  # effective rho, so that rho A is the mass per length
    youngs_modulus_pa: float  # effective E (bending stiffness E I)
    t60_fundamental_s: float  # 60 dB decay time at the fundamental
    t60_2khz_s: float  # 60 dB decay time at 2 kHz
    saddle_setback_m: float = 0.0  # intonation compensation at the saddle: length beyond the scale
    # intonation compensation at the nut: the nut moved this far towards the bridge (the frets stay
    # where the scale puts them), so the open string is this much shorter
    nut_compensation_m: float = 0.0

    @property
    def frequency_hz(self) -> float:
        return note_frequency(self.note)

    @property
    def area_m2(self) -> float:
        return float(np.pi * self.radius_m**2)

    @property
    def linear_density_kg_m(self) -> float:
        return self.density_kg_m3 * self.area_m2

    @property
    def bending_stiffness_nm2(self) -> float:
        """E I of a solid round section, I = pi r^4 / 4."""
        return self.youngs_modulus_pa * math.pi * self.radius_m**4 / 4.0

    def pitch_tension_n(self, length_m: float) -> float:
        """4 L^2 rho A f0^2: the tension an ideal (flexible) string needs for its pitch."""
        return 4.0 * length_m**2 * self.linear_density_kg_m * self.frequency_hz**2

    def stiffness_tension_n(self, length_m: float) -> float:
        """pi^2 E I / L^2: the part of the stiff string's f_1^2 (4 L^2 rho A) that stiffness
        supplies; the tension is ``pitch_tension_n`` minus this, so a string is playable only
        below that."""
        return math.pi**2 * self.bending_stiffness_nm2 / length_m**2


@dataclass(frozen=True)
class FingerSpec:
    """The fretting/tapping finger of eqs. (9)-(10), with contact damping added."""

    mass_kg: float = 0.005
    stiffness: float = 2.0e4  # K_FG, N/m^alpha
    alpha: float = 1.0
    damping_n_s_m: float = 8.0  # contact damping while touching (counted in the loss Q)
    # Default pressing force.  Where a string needs more to rest on its fret (fret 1, next to the
    # nut, and the high frets, where the action is highest), a finger with no force of its own
    # presses harder: ``intonation.press_force``; benchmarks/seating.py prints both.
    press_force_n: float = 3.0


@dataclass(frozen=True)
class Preset:
    name: str
    description: str
    scale_length_m: float
    strings: tuple[StringSpec, ...]  # index 0 is string 1 (the highest)
    frets: int = 20
    action_nut_m: float = 0.25e-3
    action_12th_m: float = 2.0e-3
    fret_height_m: float = 1.0e-3
    fretboard_stiffness: float = 1.0e10  # K_B, N/m^(alpha+1) per metre of string
    fretboard_alpha: float = 1.5
    fret_stiffness: float = 1.0e10  # K_F for the penalty fret model, N/m^alpha
    fret_alpha: float = 1.5
    finger: FingerSpec = field(default_factory=FingerSpec)
    pickup_position: float = 0.92  # output point, fraction of the length from the nut
    body: str = "none"  # built-in body response (engine.output.BODIES) or "none"

    @property
    def n_strings(self) -> int:
        return len(self.strings)

    def fret_x_m(self, fret: int | np.ndarray, spec: StringSpec | None = None) -> np.ndarray | float:
        """x_q = L_scale (1 - 2^(-q/12)), metres from the nut (API.md, Coordinates), less the nut
        compensation of string ``spec`` (its nut sits that much nearer the frets); fret 0 is the
        nut itself, at 0.  Without ``spec``: from an uncompensated nut."""
        q = np.asarray(fret)
        x = self.scale_length_m * (1.0 - 2.0 ** (-q / 12.0))
        if spec is None or spec.nut_compensation_m == 0.0:
            return x
        return np.where(q > 0, x - spec.nut_compensation_m, 0.0)[()]  # a scalar for a scalar

    def string_length_m(self, string: int) -> float:
        """Speaking length of string ``string`` (1-based): ``speaking_length_m`` of its spec."""
        return self.speaking_length_m(self.strings[string - 1])

    def speaking_length_m(self, spec: StringSpec) -> float:
        """Speaking length of a string ``spec`` on this scale: the scale plus its saddle setback,
        less its nut compensation."""
        return self.scale_length_m + spec.saddle_setback_m - spec.nut_compensation_m

    def clearance_m(self, x_m: float | np.ndarray) -> np.ndarray | float:
        """Height of the string's rest line above the fret crowns at x_m metres from the nut."""
        x12 = self.scale_length_m / 2.0
        return self.action_nut_m + (self.action_12th_m - self.action_nut_m) * (np.asarray(x_m) / x12)


def _wound(note, gauge_in, core_in, tension_n, scale, t60_f0, t60_2k) -> StringSpec:
    """A wound string from its gauge, core gauge and the maker's tension at pitch."""
    r = gauge_in * INCH / 2
    f0 = note_frequency(note)
    mu = tension_n / (2 * scale * f0) ** 2
    rho = mu / (np.pi * r**2)
    e_eff = STEEL_E * ((core_in / gauge_in) ** 4)
    return StringSpec(note, r, rho, e_eff, t60_f0, t60_2k)


def _plain(note, gauge_in, rho, e, t60_f0, t60_2k) -> StringSpec:
    return StringSpec(note, gauge_in * INCH / 2, rho, e, t60_f0, t60_2k)


def _compensated(strings, setbacks, nuts) -> tuple[StringSpec, ...]:
    """The strings with their saddle setbacks and nut compensations (metres)."""
    return tuple(replace(s, saddle_setback_m=d, nut_compensation_m=c)
                 for s, d, c in zip(strings, setbacks, nuts, strict=True))


_STEEL_SCALE = 0.645
STEEL_ACOUSTIC = Preset(
    name="steel-acoustic",
    description="Steel-string acoustic, 645 mm scale, light .012-.053 set, standard tuning",
    scale_length_m=_STEEL_SCALE,
    strings=_compensated(
        (
            _plain("E4", 0.012, STEEL_DENSITY, STEEL_E, 4.0, 1.2),
            _plain("B3", 0.016, STEEL_DENSITY, STEEL_E, 5.0, 1.2),
            _wound("G3", 0.024, 0.0110, 134.0, _STEEL_SCALE, 6.0, 1.0),
            _wound("D3", 0.032, 0.0135, 133.0, _STEEL_SCALE, 7.0, 0.9),
            _wound("A2", 0.042, 0.0160, 130.0, _STEEL_SCALE, 8.0, 0.8),
            _wound("E2", 0.053, 0.0180, 107.0, _STEEL_SCALE, 9.0, 0.7),
        ),
        # saddle setbacks and nut compensations fitted by `python -m benchmarks.intonation`
        # (reference grid, frets 1-20); the B string needs the most, as on real compensated
        # acoustic saddles
        (1.10e-3, 2.25e-3, 0.65e-3, 0.85e-3, 0.95e-3, 1.40e-3),
        (1.05e-3, 1.45e-3, 0.40e-3, 0.50e-3, 0.80e-3, 1.10e-3),
    ),
    frets=20,
    action_nut_m=0.25e-3,
    action_12th_m=2.0e-3,
    body="acoustic",
)

_NYLON_SCALE = 0.650
NYLON_CLASSICAL = Preset(
    name="nylon-classical",
    description="Nylon-string classical, 650 mm scale, normal tension, standard tuning",
    scale_length_m=_NYLON_SCALE,
    strings=(
        _plain("E4", 0.028, NYLON_DENSITY, NYLON_E, 2.5, 0.6),
        _plain("B3", 0.032, NYLON_DENSITY, NYLON_E, 3.0, 0.6),
        _plain("G3", 0.040, NYLON_DENSITY, NYLON_E, 3.5, 0.5),
        _wound("D3", 0.029, 0.020, 71.0, _NYLON_SCALE, 4.0, 0.5),
        _wound("A2", 0.035, 0.024, 70.0, _NYLON_SCALE, 4.5, 0.4),
        _wound("E2", 0.043, 0.028, 72.0, _NYLON_SCALE, 5.0, 0.4),
    ),
    frets=19,
    action_nut_m=0.35e-3,
    action_12th_m=3.2e-3,
    fret_height_m=1.1e-3,
    body="classical",
)
# The nylon basses' cores are multifilament nylon: their bending stiffness is that of a nylon rod
# of the core's size, not steel.
NYLON_CLASSICAL = replace(
    NYLON_CLASSICAL,
    strings=NYLON_CLASSICAL.strings[:3]
    + tuple(
        replace(s, youngs_modulus_pa=s.youngs_modulus_pa * NYLON_E / STEEL_E)
        for s in NYLON_CLASSICAL.strings[3:]
    ),
)
# saddle setbacks and nut compensations fitted by `python -m benchmarks.intonation --preset
# nylon-classical` (frets 1-19); the G string needs the most, as on real classical guitars
NYLON_CLASSICAL = replace(
    NYLON_CLASSICAL,
    strings=_compensated(NYLON_CLASSICAL.strings,
                         (0.90e-3, 1.10e-3, 2.40e-3, 0.55e-3, 0.55e-3, 0.55e-3),
                         (0.55e-3, 1.20e-3, 1.60e-3, 0.20e-3, 0.40e-3, 0.70e-3)),
)

# Electric: 648 mm (25.5") scale, nickel-wound .010-.046 set (tensions from the maker's charts),
# low action, 22 medium-jumbo frets, bridge pickup about 40 mm from the saddle, no body (solid).
# Decays are long (a solid body takes little energy from the strings).
_ELECTRIC_SCALE = 0.648
ELECTRIC = Preset(
    name="electric",
    description="Solid-body electric, 648 mm scale, .010-.046 nickel set, bridge pickup",
    scale_length_m=_ELECTRIC_SCALE,
    strings=_compensated(
        (
            _plain("E4", 0.010, STEEL_DENSITY, STEEL_E, 6.0, 1.5),
            _plain("B3", 0.013, STEEL_DENSITY, STEEL_E, 7.0, 1.5),
            _plain("G3", 0.017, STEEL_DENSITY, STEEL_E, 8.0, 1.4),
            _wound("D3", 0.026, 0.0130, 82.0, _ELECTRIC_SCALE, 9.0, 1.2),
            _wound("A2", 0.036, 0.0160, 87.0, _ELECTRIC_SCALE, 10.0, 1.1),
            _wound("E2", 0.046, 0.0190, 78.0, _ELECTRIC_SCALE, 11.0, 1.0),
        ),
        # fitted by `python -m benchmarks.intonation --preset electric` (frets 1-22); the plain G
        # needs the most
        (0.80e-3, 1.55e-3, 2.55e-3, 0.90e-3, 1.45e-3, 2.00e-3),
        (0.85e-3, 1.55e-3, 2.20e-3, 0.85e-3, 0.75e-3, 1.40e-3),
    ),
    frets=22,
    action_nut_m=0.2e-3,
    action_12th_m=1.6e-3,
    fret_height_m=1.2e-3,
    pickup_position=0.94,
    body="none",
)

# Bass: 864 mm (34") scale, E1 A1 D2 G2 roundwound .045-.105, higher action; the strings are
# heavy enough that slaps and pops make them rattle on the frets (waveguide paper sec. IV-C).
_BASS_SCALE = 0.864
BASS = Preset(
    name="bass",
    description="Four-string electric bass, 864 mm scale, .045-.105 roundwound, E1 A1 D2 G2",
    scale_length_m=_BASS_SCALE,
    strings=_compensated(
        (
            _wound("G2", 0.045, 0.0220, 178.0, _BASS_SCALE, 8.0, 0.6),
            _wound("D2", 0.065, 0.0280, 200.0, _BASS_SCALE, 9.0, 0.5),
            _wound("A1", 0.080, 0.0330, 196.0, _BASS_SCALE, 10.0, 0.45),
            _wound("E1", 0.105, 0.0400, 190.0, _BASS_SCALE, 11.0, 0.4),
        ),
        # fitted by `python -m benchmarks.intonation --preset bass` (frets 1-20)
        (1.85e-3, 2.75e-3, 4.25e-3, 7.40e-3),
        (1.25e-3, 1.95e-3, 2.75e-3, 3.85e-3),
    ),
    frets=20,
    action_nut_m=0.4e-3,
    action_12th_m=2.5e-3,
    fret_height_m=1.2e-3,
    fretboard_stiffness=1.0e10,
    finger=FingerSpec(mass_kg=0.008, press_force_n=6.0),
    pickup_position=0.9,
    body="none",
)

PRESETS: dict[str, Preset] = {p.name: p for p in (STEEL_ACOUSTIC, NYLON_CLASSICAL, ELECTRIC, BASS)}
DEFAULT_PRESET = STEEL_ACOUSTIC.name


def get_preset(name: str) -> Preset:
    try:
        return PRESETS[name]
    except KeyError:
        raise KeyError(f"unknown preset {name!r}; choose one of {sorted(PRESETS)}") from None


def tension_n(spec: StringSpec, length_m: float) -> float:
    """A string's tension at its pitch, stiff-string estimate: 4 L^2 rho A f0^2 - pi^2 E I / L^2
    (``engine.fd.string.tune`` solves the scheme's own relation; it differs by the grid's error)."""
    return spec.pitch_tension_n(length_m) - spec.stiffness_tension_n(length_m)


def added_string(preset: Preset, note: str) -> StringSpec:
    """A string below the preset's lowest (string n), built as a maker extends a set: the same
    construction as string n (its effective density, so the same wrap-to-core make-up, and its
    core-to-gauge ratio, so the same effective Young's modulus; its decay times, saddle
    setback and nut compensation), at the mean tension of the preset's two lowest strings (within
    their range), with the radius that gives that tension at ``note``: rho A = T / (2 L f0)^2,
    solved together with the small stiffness term.  ``tests/engine/test_tracks.py`` prints the
    results: the electric's B1 at 0.063" (7-string sets sell .059-.064), the steel acoustic's B1
    at 0.074", the bass's B0 at 0.141" (5-string sets: .125-.135; our bass's E1 is heavy, .105, too)."""
    low = preset.strings[-1]
    pair = preset.strings[-2:]
    n = preset.n_strings
    target = sum(tension_n(s, preset.string_length_m(n - len(pair) + 1 + j))
                 for j, s in enumerate(pair)) / len(pair)
    spec = replace(low, note=note)
    length = preset.speaking_length_m(low)
    f0 = note_frequency(note)
    radius = low.radius_m
    for _ in range(50):  # fixed point: rho pi r^2 (2 L f0)^2 = T + pi^2 E pi r^4 / 4 / L^2
        stiff = math.pi**2 * low.youngs_modulus_pa * math.pi * radius**4 / 4.0 / length**2
        new = math.sqrt((target + stiff) / (low.density_kg_m3 * math.pi * (2 * length * f0) ** 2))
        if abs(new - radius) < 1e-15:
            break
        radius = new
    return replace(spec, radius_m=new)


def fit_strings(preset: Preset, notes: list[str]) -> tuple[StringSpec, ...]:
    """The preset's strings for a tuning of ``len(notes)`` notes (string 1 first).  As many notes
    as strings: each string retuned.  More: strings added below the lowest, one by one, each built
    from the two strings above it (``added_string``).  Fewer: the run of consecutive preset
    strings whose open pitches are nearest the notes (least sum of squared semitone differences;
    the highest run on a tie), retuned, so a four-note bass tuning on a six-string guitar keeps
    the four lowest strings rather than thin trebles tuned down two octaves."""
    k, n = len(notes), preset.n_strings
    if k > n:
        extended = preset
        for note in notes[n:]:
            extended = replace(extended, strings=extended.strings + (added_string(extended, note),))
        strings = extended.strings
    elif k < n:
        def cost(start: int) -> float:
            return sum((12 * math.log2(note_frequency(m) / s.frequency_hz)) ** 2
                       for m, s in zip(notes, preset.strings[start:start + k], strict=True))
        start = min(range(n - k + 1), key=lambda j: (cost(j), j))
        strings = preset.strings[start:start + k]
    else:
        strings = preset.strings
    return tuple(replace(s, note=m) for s, m in zip(strings, notes, strict=True))


def apply_overrides(preset: Preset, guitar) -> Preset:
    """The preset refined by a scene's ``guitar`` overrides (tuning, strings, frets, action)."""
    strings = list(preset.strings)
    if guitar.tuning is not None:
        strings = list(fit_strings(preset, list(guitar.tuning)))
    for o in guitar.strings:
        changes = {
            k: v for k, v in o.model_dump(exclude={"string"}).items() if v is not None
        }
        strings[o.string - 1] = replace(strings[o.string - 1], **changes)
    geometry = {
        k: getattr(guitar, k)
        for k in ("frets", "action_nut_m", "action_12th_m")
        if getattr(guitar, k) is not None
    }
    return replace(preset, strings=tuple(strings), **geometry)
