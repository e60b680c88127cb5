// A tablature view of the labels (POST /scene/labels): one line per string (string 1, the highest,
// on top), each note's fret number where it starts, its technique marks (h, p, /, b, ~, PM, x,
// harmonics as <12>), a cursor at the playing time with the notes under it highlighted, click to
// seek, zoom and a native horizontal scrollbar. Only the visible window is drawn, so a long song
// with many notes stays responsive: the notes are sorted by time and each redraw looks up the first
// visible one by bisection.
//
//   const tab = new TabView(scrollBox, canvas, {onSeek: (t) => ...});
//   tab.setNotes(notes, duration, strings, timing);  tab.setTime(t, follow);  tab.zoom(2);
//
// `timing`: the scene's `score` field (bar and beat start times, bar numbers), when the scene came
// from a score: bar lines, numbered, and beat ticks; without it, a line every few seconds.
"use strict";

class TabView {
  constructor(box, canvas, { onSeek } = {}) {
    this.box = box;            // overflow-x: auto; its spacer child gives the scroll width
    this.canvas = canvas;      // position: sticky; left: 0 inside the box
    this.spacer = box.querySelector(".tab-spacer");
    this.onSeek = onSeek || (() => {});
    this.notes = [];
    this.bars = [];            // bar starts (s), their numbers, beats (s): the score's timing
    this.barNumbers = [];
    this.beats = [];
    this.duration = 0;
    this.strings = 6;
    this.pxPerSecond = 120;    // CSS pixels
    this.time = 0;
    this.frame = 0;
    box.addEventListener("scroll", () => this.draw());
    canvas.addEventListener("click", (e) => {
      const r = canvas.getBoundingClientRect();
      this.onSeek(Math.max(0, Math.min(this.duration, this.timeAt(e.clientX - r.left))));
    });
    window.addEventListener("resize", () => this.draw());
  }

  setNotes(notes, duration, strings, timing) {
    this.notes = notes.slice().sort((a, b) => a.time - b.time);
    this.bars = (timing && timing.bars) || [];
    this.barNumbers = (timing && timing.bar_numbers) || this.bars.map((_, i) => i + 1);
    this.beats = (timing && timing.beats) || [];
    this.duration = duration;
    this.strings = Math.max(strings || 0, ...this.notes.map((n) => n.string || 0), 1);
    // the longest note bounds how far back a note sounding at the left edge can start
    this.longest = this.notes.reduce((m, n) => Math.max(m, n.duration), 0);
    this.layout();
  }

  layout() {
    this.spacer.style.width = `${Math.ceil(this.duration * this.pxPerSecond) + 40}px`;
    this.canvas.style.height = `${34 + 18 * this.strings}px`;
    this.draw();
  }

  // zoom by `factor`, keeping the cursor where it is on screen
  zoom(factor) {
    const x = this.time * this.pxPerSecond - this.box.scrollLeft;
    this.pxPerSecond = Math.max(10, Math.min(2000, this.pxPerSecond * factor));
    this.layout();
    this.box.scrollLeft = this.time * this.pxPerSecond - x;
    this.draw();
  }

  timeAt(x) { return (this.box.scrollLeft + x - 20) / this.pxPerSecond; }

  // the playing time; with `follow`, scroll so that the cursor stays in view
  setTime(t, follow) {
    this.time = t;
    const x = 20 + t * this.pxPerSecond, w = this.box.clientWidth;
    if (follow && (x < this.box.scrollLeft + 20 || x > this.box.scrollLeft + w * 0.8)) {
      // at the song's end the box may already be scrolled as far as it goes: no "scroll" event
      this.box.scrollLeft = Math.max(0, x - w * 0.25);
    }
    this.draw();  // one paint a frame however often it is asked
  }

  // index of the first note starting at or after t
  first(t) { return TabView.bisect(this.notes, t, (n) => n.time); }

  // index of the first item of a sorted list whose key is at or after t
  static bisect(list, t, key = (x) => x) {
    let lo = 0, hi = list.length;
    while (lo < hi) {
      const mid = (lo + hi) >> 1;
      if (key(list[mid]) < t) lo = mid + 1; else hi = mid;
    }
    return lo;
  }

  // one paint per frame, of the latest state (a pending paint is never cancelled: the playback
  // loop asks for one every frame, and cancelling would starve it)
  draw() {
    if (this.frame) return;
    this.frame = requestAnimationFrame(() => { this.frame = 0; this.paint(); });
  }

  paint() {
    const c = this.canvas, dpr = window.devicePixelRatio || 1;
    const cssW = this.box.clientWidth, cssH = c.clientHeight;
    c.style.width = `${cssW}px`;
    c.width = Math.round(cssW * dpr);
    c.height = Math.round(cssH * dpr);
    const g = c.getContext("2d");
    g.setTransform(dpr, 0, 0, dpr, 0, 0);
    g.fillStyle = "#14120f";
    g.fillRect(0, 0, cssW, cssH);
    const left = this.box.scrollLeft, pps = this.pxPerSecond;
    const t0 = (left - 20) / pps, t1 = (left + cssW) / pps;
    const x = (t) => 20 + t * pps - left;
    const top = 24, gap = 18, y = (s) => top + (s - 1) * gap;

    g.font = "10px system-ui, sans-serif";
    g.textBaseline = "alphabetic";
    const staff = (this.strings - 1) * gap;
    if (this.bars.length) {
      // beat ticks under the staff where they are at least 5 px apart, then the bar lines,
      // numbered (every n-th bar when they are close)
      const bStart = TabView.bisect(this.beats, t0), bEnd = TabView.bisect(this.beats, t1);
      if ((bEnd - bStart) * 5 < cssW) {
        g.fillStyle = "#4a443b";
        for (let i = bStart; i < bEnd; i++) g.fillRect(Math.round(x(this.beats[i])), top + staff + 4, 1, 5);
      }
      const i0 = Math.max(0, TabView.bisect(this.bars, t0) - 1), i1 = TabView.bisect(this.bars, t1);
      const mean = this.duration / this.bars.length * pps;  // px per bar, on average
      const every = mean >= 28 ? 1 : Math.ceil(28 / mean / 4) * 4;
      for (let i = i0; i < i1; i++) {
        const bx = Math.round(x(this.bars[i]));
        g.fillStyle = "#6d655a";
        g.fillRect(bx, top, 1, staff);
        if (i % every === 0) {
          g.fillStyle = "rgba(255,255,255,0.5)";
          g.fillText(String(this.barNumbers[i]), bx + 3, 11);
        }
      }
    } else {
      // time grid: a line every second (every 5 or 10 when zoomed out), labelled
      const step = pps >= 60 ? 1 : pps >= 15 ? 5 : 10;
      for (let s = Math.max(0, Math.ceil(t0 / step) * step); s <= Math.min(t1, this.duration); s += step) {
        g.fillStyle = "#2c2822";
        g.fillRect(Math.round(x(s)), top - 6, 1, staff + 12);
        g.fillStyle = "rgba(255,255,255,0.45)";
        g.fillText(`${Math.floor(s / 60)}:${String(s % 60).padStart(2, "0")}`, x(s) + 3, 11);
      }
    }
    // strings
    g.fillStyle = "#5a5247";
    for (let s = 1; s <= this.strings; s++) g.fillRect(0, y(s), cssW, 1);

    // notes in the window (and the ones that started before it and still sound)
    const now = [];
    g.font = "bold 12px system-ui, sans-serif";
    g.textAlign = "center";
    g.textBaseline = "middle";
    const end = this.first(t1);
    const right = {}; // per string: where the last fret number drawn ends (px)
    for (let i = this.first(t0 - this.longest); i < end; i++) {
      const n = this.notes[i];
      if (n.time + n.duration < t0 || n.string === undefined) continue;
      const sounding = this.time >= n.time && this.time < n.time + n.duration;
      if (sounding) now.push(n);
      const nx = x(n.time), ny = y(n.string);
      // how long it rings: a thin bar along the string
      g.fillStyle = sounding ? "rgba(224,161,94,0.55)" : "rgba(224,161,94,0.18)";
      g.fillRect(nx, ny - 1, Math.max(1, n.duration * pps), 3);
      const label = TabView.label(n);
      const w = g.measureText(label).width + 4;
      if (!sounding && nx - w / 2 < (right[n.string] ?? -Infinity)) {
        // too close to the previous number to read at this zoom: a tick marks the attack
        g.fillStyle = "#f1e7da";
        g.fillRect(nx, ny - 4, 1, 8);
        continue;
      }
      right[n.string] = nx + w / 2;
      g.fillStyle = sounding ? "#e0a15e" : "#14120f";
      g.fillRect(nx - w / 2, ny - 7, w, 14);
      g.fillStyle = sounding ? "#14120f" : "#f1e7da";
      g.fillText(label, nx, ny + 0.5);
      const mark = TabView.mark(n);
      if (mark) {
        g.font = "10px system-ui, sans-serif";
        g.fillStyle = "#8fc0d6";
        g.fillText(mark, nx, ny - 11 < 4 ? ny + 12 : ny - 11);
        g.font = "bold 12px system-ui, sans-serif";
      }
    }
    g.textAlign = "left";
    // the cursor
    const cx = x(this.time);
    if (cx >= 0 && cx <= cssW) {
      g.fillStyle = "#f5f0e8";
      g.fillRect(Math.round(cx), 14, 2, (this.strings - 1) * gap + 20);
    }
    c.dataset.drawn = "1";
    c.dataset.bars = String(this.bars.length);
    c.dataset.sounding = String(now.length);
    c.dataset.time = this.time.toFixed(3);
    this.sounding = now;
  }

  // the fret as tab writes it: x for a dead note, <12> for a harmonic
  static label(n) {
    const a = n.articulations || [];
    if (a.includes("dead")) return "x";
    if (a.some((s) => s.startsWith("harmonic"))) return `<${n.fret}>`;
    return String(n.fret);
  }

  // technique marks above the note
  static mark(n) {
    const a = n.articulations || [];
    const m = [];
    if (a.includes("hammer_on")) m.push("h");
    if (a.includes("pull_off")) m.push("p");
    if (a.includes("slide")) m.push(n.slideFrom !== undefined && n.slideFrom > n.fret ? "\\" : "/");
    if (a.includes("bend") || a.includes("prebend")) m.push("b");
    if (a.includes("vibrato")) m.push("~");
    if (a.includes("palm_mute")) m.push("PM");
    if (a.includes("tap")) m.push("t");
    return m.join(" ");
  }
}

window.TabView = TabView;
