"""tools/profile_step.py: samples are counted by the compiled function whose code holds them."""

from tools.profile_step import _by_function


def test_each_sample_goes_to_the_function_whose_code_holds_it():
    # (address in the child, offset in the object, size, function)
    spans = [(0x1000, 0, 0x100, "_held_run"), (0x2000, 0x100, 0x10, "_pass_kc")]
    ips = ["1000", "10ff", "2000", "200f", "2010", "fff", "1100"]
    assert _by_function(ips, spans) == {"_held_run": 2, "_pass_kc": 2, "outside": 3}


def test_the_line_table_build_has_every_kernel_in_one_module(tmp_path):
    """numba's line tables name the file of the function code was inlined into, so the profile
    compiles a copy of the engine whose kernels are one module; it must define what the package
    defines, and nothing must be left over from the package's own imports."""
    import json
    import os
    import subprocess
    import sys

    from tools.profile_step import ROOT, _helpers, _one_file_engine

    src = _one_file_engine(str(tmp_path))
    probe = ("import json, engine.fd.kernels as k; "
             "print(json.dumps([k.__file__, sorted(n for n in vars(k) if not n.startswith('__'))]))")
    names = {}
    for path in (f"{src}{os.pathsep}{ROOT}", str(ROOT)):
        out = subprocess.run([sys.executable, "-c", probe], env={**os.environ, "PYTHONPATH": path},
                             capture_output=True, text=True, check=True, cwd=tmp_path).stdout
        file, defined = json.loads(out)
        names[file.endswith("kernels.py")] = set(defined)
    one, package = names[True], names[False]
    submodules = {"data", "linear", "excitation", "collisions", "finger", "sav", "system",
                  "energy", "runs", "step"}
    assert package - submodules <= one
    helpers = [name for _, name in _helpers(src / "engine" / "fd" / "kernels.py")]
    assert {"_held_run", "_pass_kc", "_solve", "step_block"} <= set(helpers)
    assert len(helpers) == len(set(helpers))
    # what a render of the copy reads besides the kernels: the digests of the sources behind the
    # calibration store's keys and the kernels' stamps, which name the package's files
    digests = ("import engine.calibration_store as c, engine.precompile as p; "
               "print(len(c._version()), len(p.sources_digest()))")
    out = subprocess.run([sys.executable, "-c", digests], capture_output=True, text=True,
                         env={**os.environ, "PYTHONPATH": f"{src}{os.pathsep}{ROOT}"},
                         cwd=tmp_path)
    assert out.returncode == 0, out.stderr[-2000:]
    assert out.stdout.split() == ["64", "64"]
