"""engine.fd.kernels.data: the kept entry point is the one numba would pick, for the types it tells
apart."""

import numpy as np

from engine.fd import kernels
from engine.fd.instrument import prepare
from engine.options import RenderOptions
from engine.scene import Scene
from engine.testing.scenes import fret, pluck, scene


def _voice_args(v, nsteps=400):
    out = np.zeros((len(v.pickup_gains), nsteps))
    e = np.empty(0)
    return (v.coefs, v.geom, v.ctl.arrays, v.state, v.policy, v.step, nsteps, out, False, e, e, e)


def test_type_key_tells_apart_what_typeof_tells_apart():
    a = np.zeros(12)
    ro = np.zeros(12)
    ro.flags.writeable = False
    cases = [a, a[::2], ro, np.zeros(12, np.float32), np.zeros(12, np.int64),
             np.zeros((3, 4)), np.zeros((3, 4), order="F"), np.zeros((4, 6))[:, :3],
             1, 1.0, True, (a, 1), (a, a[::2])]
    for x in cases:
        for y in cases:
            same_type = kernels.step_block.typeof_pyval(x) == kernels.step_block.typeof_pyval(y)
            assert (kernels._type_key(x) == kernels._type_key(y)) == same_type, (x, y)


def test_strings_share_one_entry_point_and_it_renders_as_the_dispatcher(monkeypatch):
    sc = Scene.model_validate(scene([fret(2, 5), pluck(2, force=8.0), pluck(5)], duration=0.01))
    eng = prepare(sc, RenderOptions(skip_decayed=False))
    a, b = eng.voices
    args_a, args_b = _voice_args(a), _voice_args(b)
    fn = kernels.entry_point(kernels.step_block, args_a)
    assert kernels.step_block.compile(
        tuple(kernels.step_block.typeof_pyval(x) for x in args_b)) is fn

    def no_typeof(_value):
        raise AssertionError("the second string resolved its argument types again")

    monkeypatch.setattr(kernels.step_block, "typeof_pyval", no_typeof)
    assert kernels.entry_point(kernels.step_block, args_b) is fn
    monkeypatch.undo()

    twin = prepare(sc, RenderOptions(skip_decayed=False)).voices[0]
    args_t = _voice_args(twin)
    assert fn(*args_a) == kernels.step_block(*args_t) == kernels.OK
    assert np.array_equal(args_a[6], args_t[6])
    assert np.any(args_a[6] != 0.0)
