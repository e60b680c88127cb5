// Live play (static/live.html): a fretboard, the computer keyboard and Web MIDI send events to
// WS /live; the blocks it streams back play through an AudioWorklet (static/live-worklet.js).
"use strict";

const L = (sel) => document.querySelector(sel);
const KEYS = "asdfgh"; // strings 6..1
const HEADER_BYTES = 8; // each binary block: uint64 LE frame index, then float32 LE samples

const live = {
  ws: null, ctx: null, node: null, presets: [],
  rate: 44100, block: 256, strings: 6, tuning: [], frets: 20,
  fret: 0, // the fret the keyboard plays
  held: {}, // string -> fret the finger holds (0: open)
  sounding: {}, // string -> MIDI note it plays
  muted: {}, // string -> true while a damping mute lies on it
  bent: null, // string bent now
  lastString: 1,
  nextId: 1, sent: new Map(), acked: new Map(), latencies: [],
  blocks: 0, buffered: 0, underruns: 0,
  midiNotes: 0, sustain: false, pendingOff: new Set(),
};

// ---- presets and notes ---------------------------------------------------------------------
function midiOf(name) {
  const m = /^([A-Ga-g])([#b]?)(-?\d+)$/.exec(name);
  if (!m) return null;
  const base = { c: 0, d: 2, e: 4, f: 5, g: 7, a: 9, b: 11 }[m[1].toLowerCase()];
  return 12 * (Number(m[3]) + 1) + base + (m[2] === "#" ? 1 : m[2] === "b" ? -1 : 0);
}

async function loadPresets() {
  const body = await (await fetch("/presets")).json();
  live.presets = body.presets;
  const sel = L("#live-preset");
  for (const p of body.presets) {
    const o = document.createElement("option");
    o.textContent = p.name;
    sel.appendChild(o);
  }
  sel.value = body.default;
  presetChanged();
}

function presetChanged() {
  const p = live.presets.find((x) => x.name === L("#live-preset").value);
  live.strings = p.tuning.length;
  live.tuning = p.tuning.map(midiOf);
  live.frets = p.frets;
  drawFretboard();
}

// ---- the fretboard -------------------------------------------------------------------------
function drawFretboard() {
  const fb = L("#fretboard");
  fb.innerHTML = "";
  fb.style.gridTemplateColumns = `3rem repeat(${live.frets + 1}, minmax(1.6rem, 1fr))`;
  const p = live.presets.find((x) => x.name === L("#live-preset").value);
  for (let s = 1; s <= live.strings; s++) {
    const name = document.createElement("span");
    name.className = "name";
    name.textContent = `${s} ${p.tuning[s - 1]}`;
    fb.appendChild(name);
    for (let f = 0; f <= live.frets; f++) {  // every fret the preset has
      const b = document.createElement("button");
      b.type = "button";
      b.className = "cell" + (f === 0 ? " open" : "");
      b.dataset.string = s;
      b.dataset.fret = f;
      b.textContent = f === 0 ? "open" : f;
      b.addEventListener("pointerdown", (e) => { e.preventDefault(); cellDown(s, f); });
      b.addEventListener("pointerup", () => cellUp(s));
      b.addEventListener("pointerleave", () => cellUp(s));
      fb.appendChild(b);
    }
  }
}

function showHeld() {
  for (const c of document.querySelectorAll("#fretboard .cell")) {
    const s = Number(c.dataset.string);
    c.classList.toggle("held", (live.held[s] || 0) === Number(c.dataset.fret) && live.held[s] > 0);
  }
}

function flash(s, f) {
  const c = document.querySelector(`#fretboard .cell[data-string='${s}'][data-fret='${f}']`);
  if (!c) return;
  c.classList.add("flash");
  setTimeout(() => c.classList.remove("flash"), 150);
}

const mode = () => document.querySelector("input[name='mode']:checked").value;

function cellDown(s, f) {
  const m = mode();
  if (m === "pluck") play(s, f, 2.0);
  else if (m === "hammer_on") hammer(s, f);
  else if (m === "slide") slide(s, f);
  else if (m === "bend") { play(s, f, 2.0); bend(s, 1.0); }
  else if (m === "mute") toggleMute(s);
}

function cellUp(s) {
  if (live.bent === s) unbend();
}

// ---- what the player does, as WS /live events -----------------------------------------------
function send(msg) {
  if (!live.ws || live.ws.readyState !== WebSocket.OPEN) return;
  const id = live.nextId++;
  live.sent.set(id, performance.now());
  live.ws.send(JSON.stringify({ ...msg, id }));
}

function unmute(s) {
  if (live.muted[s]) { send({ type: "release", string: s, what: "mute" }); live.muted[s] = false; }
}

function setFret(s, f) {
  if ((live.held[s] || 0) !== f) send({ type: "fret", string: s, fret: f });
  live.held[s] = f;
}

function play(s, f, force) {
  unmute(s);
  setFret(s, f);
  send({ type: "pluck", string: s, force: Math.min(Math.max(force, 0.05), 20) });
  live.lastString = s;
  flash(s, f);
  showHeld();
}

function hammer(s, f) {
  unmute(s);
  if (f === 0) return play(s, 0, 2.0);
  send({ type: "hammer_on", string: s, fret: f });
  live.held[s] = f;
  live.lastString = s;
  flash(s, f);
  showHeld();
}

function slide(s, f) {
  const from = live.held[s] || 0;
  if (from === 0 || f === 0 || from === f) return play(s, f, 2.0);
  send({ type: "slide", string: s, from_fret: from, to_fret: f, duration: 0.12 });
  live.held[s] = f;
  flash(s, f);
  showHeld();
}

function bend(s, semitones) {
  if (live.bent !== null) return;
  send({ type: "bend", string: s, semitones, duration: 0.08 });
  live.bent = s;
}

function unbend() {
  if (live.bent === null) return;
  send({ type: "release", string: live.bent, what: "bend" });
  live.bent = null;
}

function damp(s) {
  send({ type: "mute", string: s, amount: 1.0 });
  live.muted[s] = true;
}

function toggleMute(s) {
  if (live.muted[s]) unmute(s); else damp(s);
}

// ---- the computer keyboard -----------------------------------------------------------------
const FRET_KEYS = { "-": 10, "=": 11 };
let palm = false;

function keyDown(e) {
  if (e.target.closest && e.target.closest("select, input:not([type=radio])")) return;
  const k = e.key.toLowerCase();
  if (e.repeat) return;
  if (/^[0-9]$/.test(k) || k in FRET_KEYS) {
    live.fret = k in FRET_KEYS ? FRET_KEYS[k] : Number(k);
    L("#live-fret").textContent = live.fret;
  } else if (KEYS.includes(k)) {
    const s = live.strings - KEYS.indexOf(k);
    if (s < 1) return;
    if (e.shiftKey) hammer(s, live.fret); else play(s, live.fret, 2.0);
  } else if (k === "b") {
    bend(live.lastString, 2.0);
  } else if (k === "m" && !palm) {
    palm = true;
    send({ type: "mute", amount: 0.7 });
  } else if (k === " ") {
    for (let s = 1; s <= live.strings; s++) damp(s);
  } else return;
  e.preventDefault();
}

function keyUp(e) {
  const k = e.key.toLowerCase();
  if (k === "b") unbend();
  else if (k === "m" && palm) { palm = false; send({ type: "release", what: "mute" }); }
}

// ---- Web MIDI ------------------------------------------------------------------------------
// A note goes where a guitarist would put it: among the strings that can play it (fret 0..the
// preset's frets) and are not holding another note, the fret closest to where the hand is (the
// last fretted position), an open string counting as close to anywhere.
let hand = 3;

function place(note) {
  let best = null;
  for (let s = 1; s <= live.strings; s++) {
    const f = note - live.tuning[s - 1];
    if (f < 0 || f > live.frets) continue;
    const busy = live.sounding[s] !== undefined && live.sounding[s] !== note;
    const cost = (busy ? 100 : 0) + (f === 0 ? 1.5 : Math.abs(f - hand));
    if (!best || cost < best.cost) best = { s, f, cost };
  }
  return best;
}

function midiMessage(data) {
  const [status, a, b] = data;
  const kind = status & 0xf0;
  if (kind === 0x90 && b > 0) noteOn(a, b);
  else if (kind === 0x80 || (kind === 0x90 && b === 0)) noteOff(a);
  else if (kind === 0xe0) wheel(((b << 7) | a) / 8192 - 1);
  else if (kind === 0xb0 && a === 64) pedal(b >= 64);
}

function noteOn(note, velocity) {
  const p = place(note);
  if (!p) { log(`MIDI note ${note}: out of this guitar's range`); return; }
  for (const [s, n] of Object.entries(live.sounding)) if (n === note) delete live.sounding[s];
  live.sounding[p.s] = note;
  live.pendingOff.delete(p.s);
  if (p.f > 0) hand = p.f;
  // velocity 1..127 -> 0.2..4 N, roughly linear in loudness as the pluck's force is
  play(p.s, p.f, 0.2 + (3.8 * velocity) / 127);
  live.midiNotes += 1;
  L("#live-midi").textContent = `${live.midiNotes} notes`;
}

function noteOff(note) {
  for (const [key, n] of Object.entries(live.sounding)) {
    if (n !== note) continue;
    const s = Number(key);
    if (live.sustain) { live.pendingOff.add(s); continue; }
    delete live.sounding[s];
    if (live.bent === s) unbend();
    damp(s);
  }
}

function wheel(v) {
  // up only: a guitar bends up; the last string played, 0..2 semitones
  if (v > 0.05 && live.bent === null) bend(live.lastString, Math.max(0.1, 2 * v));
  else if (v <= 0.05 && live.bent !== null) unbend();
}

function pedal(down) {
  live.sustain = down;
  if (down) return;
  for (const s of live.pendingOff) {
    delete live.sounding[s];
    damp(s);
  }
  live.pendingOff.clear();
}

async function setupMidi() {
  if (!navigator.requestMIDIAccess) { L("#live-midi").textContent = "not available in this browser"; return; }
  L("#live-midi").textContent = "asking…";
  try {
    const access = await navigator.requestMIDIAccess();
    const attach = () => {
      const names = [];
      for (const input of access.inputs.values()) {
        input.onmidimessage = (e) => midiMessage(e.data);
        names.push(input.name);
      }
      L("#live-midi").textContent = names.length ? names.join(", ") : "no input";
    };
    access.onstatechange = attach;
    attach();
  } catch (err) {
    L("#live-midi").textContent = `not allowed (${err.message || err})`;
  }
}

// ---- connection and audio ------------------------------------------------------------------
function log(text) {
  const li = document.createElement("li");
  li.textContent = text;
  const ul = L("#live-log");
  ul.prepend(li);
  while (ul.children.length > 30) ul.lastChild.remove();
}

async function connect() {
  if (live.ws) { live.ws.close(1000); return; }
  L("#live-error").textContent = "";
  if (!live.ctx) {
    live.ctx = new AudioContext({ latencyHint: "interactive" });
    await live.ctx.audioWorklet.addModule("/static/live-worklet.js");
  }
  await live.ctx.resume();
  live.rate = live.ctx.sampleRate;
  live.block = Number(L("#live-block").value);
  // the jitter buffer: two blocks or 20 ms, whichever is more
  const target = Math.max(2 * live.block, Math.round(0.02 * live.rate));
  live.node = new AudioWorkletNode(live.ctx, "live-player", { outputChannelCount: [2],
    processorOptions: { target } });
  live.node.connect(live.ctx.destination);
  live.node.port.onmessage = (e) => {
    const d = e.data;
    live.buffered = d.buffered;
    live.underruns = d.underruns;
  };
  const url = `${location.protocol === "https:" ? "wss" : "ws"}://${location.host}/live`;
  const ws = new WebSocket(url);
  ws.binaryType = "arraybuffer";
  live.ws = ws;
  L("#live-status").textContent = "connecting…";
  L("#live-connect").textContent = "Disconnect";
  ws.onopen = () => ws.send(JSON.stringify({ type: "open", preset: L("#live-preset").value,
    sample_rate: live.rate, block_frames: live.block, quality: L("#live-quality").value,
    model: L("#live-model").value }));
  ws.onmessage = (e) => (typeof e.data === "string" ? text(JSON.parse(e.data)) : block(e.data));
  ws.onclose = (e) => {
    L("#live-status").textContent = `closed${e.reason ? `: ${e.reason}` : ""} (${e.code})`;
    if (e.code !== 1000 && e.code !== 1005) L("#live-error").textContent = e.reason || `closed (${e.code})`;
    L("#live-connect").textContent = "Connect";
    live.ws = null;
    if (live.node) { live.node.disconnect(); live.node = null; }
    live.held = {}; live.muted = {}; live.sounding = {}; live.bent = null;
    showHeld();
  };
}

function text(msg) {
  if (msg.type === "opened") {
    const model = msg.model === "waveguide" ? " (waveguide)" : "";
    L("#live-status").textContent = `playing ${msg.preset}${model} at ${msg.sample_rate} Hz, ` +
      `${msg.block_frames}-frame blocks (${(msg.block_seconds * 1000).toFixed(1)} ms)`;
    document.body.dataset.live = "1";
  } else if (msg.type === "ack") {
    live.acked.set(msg.frame, [...(live.acked.get(msg.frame) || []), msg.id]);
  } else if (msg.type === "error") {
    log(`refused: ${msg.field}: ${msg.message}`);
    live.sent.delete(msg.id);
  }
}

function block(buf) {
  const frame = Number(new DataView(buf).getBigUint64(0, true));
  const samples = new Float32Array(buf, HEADER_BYTES);
  const end = frame + samples.length;
  if (live.node) live.node.port.postMessage({ type: "block", samples }, [buf]);
  live.blocks += 1;
  const now = performance.now();
  for (const [f, ids] of live.acked) {
    if (f >= end) continue;
    for (const id of ids) {
      const t = live.sent.get(id);
      if (t !== undefined && f >= frame) live.latencies.push(now - t);
      live.sent.delete(id);
    }
    live.acked.delete(f);
  }
  if (live.latencies.length > 200) live.latencies.splice(0, live.latencies.length - 200);
}

function median(xs) {
  const s = [...xs].sort((a, b) => a - b);
  return s.length ? s[Math.floor(s.length / 2)] : NaN;
}

function showStats() {
  if (live.latencies.length) {
    L("#live-latency").textContent = `${median(live.latencies).toFixed(1)} ms median ` +
      `(${live.latencies.length} events)`;
    L("#live-latency").dataset.ms = median(live.latencies).toFixed(2);
  }
  const out = live.ctx ? (live.ctx.outputLatency || 0) + (live.ctx.baseLatency || 0) : 0;
  L("#live-buffer").textContent = `${((live.buffered / live.rate) * 1000).toFixed(0)} ms` +
    (out ? ` + ${(out * 1000).toFixed(0)} ms output` : "");
  L("#live-underruns").textContent = live.underruns;
  L("#live-blocks").textContent = live.blocks;
}

// The waveguide model has no grids to choose: the quality select does nothing there.
function modelChanged() {
  const waveguide = L("#live-model").value === "waveguide";
  L("#live-quality").disabled = waveguide;
  L("#live-quality").title = waveguide ? "the waveguide model has no quality levels" : "";
}

async function start() {
  await loadPresets();
  L("#live-preset").addEventListener("change", presetChanged);
  L("#live-model").addEventListener("change", modelChanged);
  modelChanged();
  L("#live-connect").addEventListener("click", () => connect().catch((err) => {
    L("#live-error").textContent = `could not start audio: ${err.message || err}`;
  }));
  window.addEventListener("keydown", keyDown);
  window.addEventListener("keyup", keyUp);
  setInterval(showStats, 250);
  // Web MIDI only when the user asks for it: the browser's permission prompt follows a click
  L("#live-midi-enable").addEventListener("click", setupMidi);
  document.body.dataset.ready = "1";
}

start();
