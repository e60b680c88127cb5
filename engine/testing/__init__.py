"""What the tests and the benchmarks share, so that both judge the engine with the same ruler (as
``numpy.testing`` does for numpy).  The engine itself never imports it.

- ``scenes``: the one set of scene builders (``scene``, ``pluck``, ``fret``, ``tap``) with the
  defaults the physics checks use; a script that wants other values passes them.
- ``stability``: a render's physics checks: finite output, energy balance, stored energy bounded
  by the work done, non-negative dissipation, the contact potentials' auxiliary variables
  (``check``, ``violations``, ``LIMITS``).
- ``waveguide_stability``: the waveguide model's check of a render: finite output, the rails'
  windowed energy after each string's last event not growing (``check``, ``GROWTH``).
- ``random_scenes``: the one generator of random valid scenes, drawn from hypothesis in the tests
  (so failures shrink) and from a seeded numpy generator in the soak (so cases replay).
- ``measure``: measurements that need the engine's state, not just its audio: how deep a string
  sinks into the fretboard, whether a fretted string rests on its fret, the share of steps each
  skip takes, the pitch the Kirchhoff-Carrier skip moves.
- ``articulations``: the playable guitar's targets (bend, vibrato, slide, hammer-on, pull-off,
  harmonics, palm mute, dead note) measured on rendered audio.

Plain signal analysis (pitch, partials, levels, decay rates) is in ``engine.analysis``.
"""
