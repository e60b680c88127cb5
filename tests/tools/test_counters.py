"""tools/counters.py: the hardware counters the speed tables print next to the time."""

import pytest

from tools.counters import Counters, available

pytestmark = pytest.mark.skipif(not available(), reason="this machine gives no hardware counters")


def _count(n: int) -> Counters:
    with Counters() as c:
        total = 0
        for i in range(n):
            total += i
    return c


def test_instructions_grow_with_the_work_counted():
    # a Python loop retires tens of instructions per iteration: 400 000 more iterations are
    # millions more instructions, far beyond what the counters' own start and stop cost
    small = _count(100_000)
    large = _count(500_000)
    assert small.instructions > 0 and small.cycles > 0
    assert 3.0 < large.instructions / small.instructions < 7.0


def test_only_the_work_inside_the_block_is_counted():
    idle = _count(0)
    busy = _count(200_000)
    assert idle.instructions < busy.instructions / 100
