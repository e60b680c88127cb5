// The audio side of live play: an AudioWorklet that plays the blocks WS /live sends, through a
// small jitter buffer. Blocks arrive as Float32Arrays (port messages); playback starts once
// `target` frames are buffered, and starts again the same way after an underrun (the buffer ran
// dry: the quantum is filled with silence and counted). Every 100 ms it reports what is buffered.
"use strict";

class LivePlayer extends AudioWorkletProcessor {
  constructor(options) {
    super();
    this.size = 1 << 17; // ring buffer, frames (about 3 s)
    this.ring = new Float32Array(this.size);
    this.read = 0;
    this.write = 0;
    this.target = (options.processorOptions && options.processorOptions.target) || 1024;
    this.playing = false;
    this.underruns = 0;
    this.played = 0;
    this.dropped = 0;
    this.lastReport = 0;
    this.port.onmessage = (e) => {
      const d = e.data;
      if (d.type === "block") this.push(d.samples);
      else if (d.type === "target") this.target = d.frames;
      else if (d.type === "reset") { this.read = this.write = 0; this.playing = false; }
    };
  }

  buffered() { return this.write - this.read; }

  push(x) {
    if (this.buffered() + x.length > this.size) { this.dropped += x.length; return; }
    for (let i = 0; i < x.length; i++) this.ring[(this.write + i) % this.size] = x[i];
    this.write += x.length;
  }

  process(inputs, outputs) {
    const out = outputs[0];
    const n = out[0].length;
    if (!this.playing && this.buffered() >= this.target) this.playing = true;
    if (this.playing) {
      if (this.buffered() < n) {
        this.underruns += 1;
        this.playing = false;
        for (const ch of out) ch.fill(0);
      } else {
        for (let i = 0; i < n; i++) {
          const v = this.ring[(this.read + i) % this.size];
          for (const ch of out) ch[i] = v;
        }
        this.read += n;
        this.played += n;
      }
    } else {
      for (const ch of out) ch.fill(0);
    }
    if (currentTime - this.lastReport > 0.1) {
      this.lastReport = currentTime;
      this.port.postMessage({ type: "stats", buffered: this.buffered(), underruns: this.underruns,
        played: this.played, playing: this.playing, dropped: this.dropped });
    }
    return true;
  }
}

registerProcessor("live-player", LivePlayer);
