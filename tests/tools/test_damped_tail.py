"""tools/damped_tail.py --nodes: the lingering partial's amplitude along the waveguide string, read
at each fingertip of a damp."""

import re

from tools.damped_tail import nodes


def test_the_nodes_table_places_every_fingertip_of_the_damp(capsys):
    nodes(6, 0.3, 2.0)
    out = capsys.readouterr().out
    head = re.search(r"strongest partial .*: (\d+) Hz, partial (\d+) \((\d+) Hz\)", out)
    assert head, out
    f, k, fk = (int(g) for g in head.groups())
    assert abs(f - fk) < 30 and k >= 2  # a partial of the string, not the creep
    spacing = float(re.search(r"physical string's partial \d+: ([\d.]+) mm apart", out).group(1))
    rows = [r for r in out.splitlines() if re.match(r"\| \d", r)]
    assert len(rows) == 4  # DAMP_FINGERS fingertips
    for r in rows:
        x, amp, physical, ours = (float(c) for c in r.strip("| ").split(" | "))
        assert 0.0 <= amp <= 1.0
        # no point is farther than half the node spacing from a node of the partial
        assert 0.0 <= physical <= 0.5 * spacing + 0.1
        assert 0.0 <= ours
