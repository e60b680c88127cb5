"""One router per resource: pages (the demo), health (and limits), presets, render, score
(Guitar Pro and MIDI in, labels out)."""
