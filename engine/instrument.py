"""What both physical models share.

``DECAY_CHECK_FRAMES``: where both models test a string for decay.
"""

from __future__ import annotations

# The decay skip tests a string every this many output frames (on the global step grid, whatever
# the block size): the samples a render gives do not depend on its blocks.
DECAY_CHECK_FRAMES = 1024
