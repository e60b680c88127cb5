"""One router per resource: pages (the demo), health (and limits), presets, render, score
(Guitar Pro, MusicXML and MIDI in, labels out)."""
