"""tools/instructions.py: callgrind counts the stretches between the child's markers."""

import os
import shutil
import sys

import pytest

from tools.instructions import callgrind_marked

# a child that does nothing, then a loop, then the same loop twice over, between its markers
CHILD = """
import os
def work(n):
    t = 0
    for i in range(n):
        t += i
    return t
work(1000)  # the interpreter's warm-up, before the first marker
os.getppid()
os.getppid()
work(200_000)
os.getppid()
work(400_000)
os.getppid()
"""


@pytest.mark.skipif(shutil.which("valgrind") is None, reason="valgrind is not installed")
def test_each_count_is_the_stretch_after_its_marker():
    idle, once, twice = callgrind_marked([sys.executable, "-c", CHILD], dict(os.environ), 3)
    assert idle < once / 100  # nothing between the first two markers
    assert 1.6 < twice / once < 2.4  # the loop's work, and only it


@pytest.mark.skipif(shutil.which("valgrind") is None, reason="valgrind is not installed")
def test_the_child_runs_in_the_tree_it_counts(tmp_path):
    """A ``python -c`` child imports from its working directory first: counting another tree's
    engine from this one counted this tree's engine (and compiled it under valgrind)."""
    (tmp_path / "which_tree.py").write_text("HERE = True\n")
    child = "import os, which_tree\nos.getppid()\nos.getppid()\n"
    assert len(callgrind_marked([sys.executable, "-c", child], dict(os.environ), 1,
                                cwd=tmp_path)) == 1
    with pytest.raises(SystemExit, match="ModuleNotFoundError"):
        callgrind_marked([sys.executable, "-c", child], dict(os.environ), 1)
