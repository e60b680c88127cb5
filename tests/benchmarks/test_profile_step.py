"""benchmarks/profile_step.py: samples are counted by the compiled function whose code holds them."""

from benchmarks.profile_step import _by_function


def test_each_sample_goes_to_the_function_whose_code_holds_it():
    # (address in the child, offset in the object, size, function)
    spans = [(0x1000, 0, 0x100, "_held_run"), (0x2000, 0x100, 0x10, "_pass_kc")]
    ips = ["1000", "10ff", "2000", "200f", "2010", "fff", "1100"]
    assert _by_function(ips, spans) == {"_held_run": 2, "_pass_kc": 2, "outside": 3}
