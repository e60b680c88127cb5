"""One router per resource: pages (the demo), health (and limits), presets, render."""
