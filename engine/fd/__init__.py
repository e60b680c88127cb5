"""The finite-difference guitar: the DAFx24 model (Bilbao, Russo, Webb & Ducceschi 2024), a string
with fretboard, frets, fingers and tension modulation on a grid, stepped by numba kernels.

Modules, each knowing only those before it (and the engine's shared layers below the models):

* ``kernels/``     the numba time-step loop of one string (one module per part of the step)
* ``grid``         the stability bound and smallest grid (plain arithmetic: the cost estimate reads it)
* ``string``       one string's grid, coefficients, tuning and geometry
* ``controls``     events -> one string's control arrays
* ``intonation``   fret calibration and seating forces (small static solves)
* ``statics``      the pressed string's statics the waveguide is handed (``engine.statics``)
* ``voice``        one string of a scene: state across blocks, energy bookkeeping, the skips
* ``playability``  warnings: fingers too light to seat their string, lost pull-offs
* ``instrument``   the voices of one guitar, block by block (``engine.instrument``'s face)

Nothing is imported here, so that ``engine.fd.grid`` loads no numerics.
"""
