// A small radix-2 FFT and a short-time spectrum for the demo page (no dependencies).
"use strict";

class FFT {
  constructor(n) {
    if (n & (n - 1)) throw new Error("FFT size must be a power of two");
    this.n = n;
    this.cos = new Float64Array(n / 2);
    this.sin = new Float64Array(n / 2);
    for (let i = 0; i < n / 2; i++) {
      this.cos[i] = Math.cos((2 * Math.PI * i) / n);
      this.sin[i] = -Math.sin((2 * Math.PI * i) / n);
    }
    this.rev = new Uint32Array(n);
    const bits = Math.log2(n);
    for (let i = 0; i < n; i++) {
      let r = 0;
      for (let b = 0; b < bits; b++) r |= ((i >> b) & 1) << (bits - 1 - b);
      this.rev[i] = r;
    }
  }

  // In place, iterative Cooley-Tukey on (re, im).
  transform(re, im) {
    const n = this.n;
    for (let i = 0; i < n; i++) {
      const j = this.rev[i];
      if (j > i) {
        let t = re[i]; re[i] = re[j]; re[j] = t;
        t = im[i]; im[i] = im[j]; im[j] = t;
      }
    }
    for (let size = 2; size <= n; size *= 2) {
      const half = size / 2, step = n / size;
      for (let start = 0; start < n; start += size) {
        for (let k = 0; k < half; k++) {
          const c = this.cos[k * step], s = this.sin[k * step];
          const a = start + k, b = a + half;
          const tr = re[b] * c - im[b] * s;
          const ti = re[b] * s + im[b] * c;
          re[b] = re[a] - tr; im[b] = im[a] - ti;
          re[a] += tr; im[a] += ti;
        }
      }
    }
  }
}

// Magnitudes in dB of Hann-windowed frames: returns {frames: [Float32Array(n/2)], hop, n}.
function spectrogram(samples, n = 1024, maxFrames = 900) {
  const fft = new FFT(n);
  const hop = Math.max(1, Math.floor((samples.length - n) / maxFrames) || 1);
  const win = new Float64Array(n);
  for (let i = 0; i < n; i++) win[i] = 0.5 - 0.5 * Math.cos((2 * Math.PI * i) / n);
  const re = new Float64Array(n), im = new Float64Array(n);
  const frames = [];
  for (let start = 0; start + n <= samples.length; start += hop) {
    for (let i = 0; i < n; i++) { re[i] = samples[start + i] * win[i]; im[i] = 0; }
    fft.transform(re, im);
    const mag = new Float32Array(n / 2);
    for (let k = 0; k < n / 2; k++) {
      mag[k] = 10 * Math.log10(re[k] * re[k] + im[k] * im[k] + 1e-20);
    }
    frames.push(mag);
  }
  return { frames, hop, n };
}

window.FFT = FFT;
window.spectrogram = spectrogram;
