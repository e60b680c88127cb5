// The demo page: build a scene, POST /render, play it, draw waveform and spectrogram.
"use strict";

const $ = (sel) => document.querySelector(sel);
const FIELDS = {  // which event fields each type takes (the rest are disabled in its row)
  pluck: ["time", "string", "force", "position"],
  fret: ["time", "string", "fret", "force", "release"],
  tap: ["time", "string", "fret", "force", "release"],
};
const DEFAULTS = {
  pluck: { string: 1, force: 2, position: 0.8 },
  fret: { string: 1, fret: 3, force: 2 },
  tap: { string: 3, fret: 7, force: 0.9 },
};
const COLUMNS = ["time", "string", "fret", "force", "position", "release"];

let presets = [];
let events = [];
let objectUrl = null;

// ---- examples ----------------------------------------------------------------------------
function strum(t0, strings, gap, force, position) {
  return strings.map((s, i) => ({ type: "pluck", time: +(t0 + i * gap).toFixed(3), string: s, force, position }));
}

const EXAMPLES = {
  strum: {
    preset: "steel-acoustic", duration: 2.5,
    events: strum(0.0, [6, 5, 4, 3, 2, 1], 0.02, 1.5, 0.85),
  },
  melody: {
    preset: "steel-acoustic", duration: 3.0,
    events: [[0, 0.0], [3, 0.4], [5, 0.8], [7, 1.2], [5, 1.6], [3, 2.0]].flatMap(([fret, t]) => [
      { type: "fret", time: t, string: 2, fret, force: 2 },
      { type: "pluck", time: +(t + 0.02).toFixed(3), string: 2, force: 2, position: 0.8 },
    ]),
  },
  tap: {
    preset: "steel-acoustic", duration: 2.5,
    events: [
      { type: "tap", time: 0.0, string: 3, fret: 7, force: 0.9, release: 0.55 },
      { type: "tap", time: 0.6, string: 3, fret: 9, force: 0.9, release: 1.15 },
      { type: "tap", time: 1.2, string: 2, fret: 8, force: 0.9 },
    ],
  },
  chord: {
    preset: "steel-acoustic", duration: 2.5,
    events: [
      { type: "fret", time: 0, string: 5, fret: 3, force: 2 },
      { type: "fret", time: 0, string: 4, fret: 2, force: 2 },
      { type: "fret", time: 0, string: 2, fret: 1, force: 2 },
      ...strum(0.02, [5, 4, 3, 2, 1], 0.025, 1.8, 0.82),
    ],
  },
};

function loadExample(name) {
  const ex = EXAMPLES[name];
  $("#preset").value = ex.preset;
  $("#duration").value = ex.duration;
  events = ex.events.map((e) => ({ ...e }));
  showPresetInfo();
  renderTable();
  clearErrors();
}

// ---- presets -------------------------------------------------------------------------------
async function loadPresets() {
  const r = await fetch("/presets");
  const body = await r.json();
  presets = body.presets;
  const sel = $("#preset");
  sel.innerHTML = "";
  for (const p of presets) {
    const o = document.createElement("option");
    o.value = p.name;
    o.textContent = p.name;
    sel.appendChild(o);
  }
  sel.value = body.default;
  showPresetInfo();
}

function showPresetInfo() {
  const p = presets.find((x) => x.name === $("#preset").value);
  if (!p) return;
  const tuning = p.strings.map((s) => `${s.string}:${s.note}`).join(" ");
  $("#preset-info").textContent =
    `${p.description}. ${p.frets} frets, tuning ${tuning}, tensions ` +
    `${Math.round(Math.min(...p.strings.map((s) => s.tension_n)))}–` +
    `${Math.round(Math.max(...p.strings.map((s) => s.tension_n)))} N.`;
}

// ---- event table ---------------------------------------------------------------------------
function renderTable() {
  const body = $("#events tbody");
  body.innerHTML = "";
  events.forEach((ev, i) => {
    const tr = document.createElement("tr");
    tr.dataset.index = i;
    const typeTd = document.createElement("td");
    const sel = document.createElement("select");
    for (const t of Object.keys(FIELDS)) {
      const o = document.createElement("option");
      o.value = o.textContent = t;
      sel.appendChild(o);
    }
    sel.value = ev.type;
    sel.dataset.field = `events[${i}].type`;
    sel.addEventListener("change", () => {
      events[i] = { type: sel.value, time: ev.time, ...DEFAULTS[sel.value], string: ev.string };
      renderTable();
    });
    typeTd.appendChild(sel);
    typeTd.appendChild(errorSpan(`events[${i}]`));
    tr.appendChild(typeTd);
    for (const col of COLUMNS) {
      const td = document.createElement("td");
      const input = document.createElement("input");
      input.type = "number";
      input.step = col === "string" || col === "fret" ? "1" : "any";
      input.dataset.field = `events[${i}].${col}`;
      if (FIELDS[ev.type].includes(col)) {
        input.value = ev[col] ?? "";
        input.placeholder = col === "release" ? "none" : "";
        input.addEventListener("input", () => {
          if (input.value === "") delete events[i][col];
          else events[i][col] = Number(input.value);
        });
      } else {
        input.disabled = true;
        input.placeholder = "—";
      }
      td.appendChild(input);
      td.appendChild(errorSpan(`events[${i}].${col}`));
      tr.appendChild(td);
    }
    const rm = document.createElement("td");
    const btn = document.createElement("button");
    btn.type = "button";
    btn.className = "remove";
    btn.title = "remove";
    btn.textContent = "×";
    btn.addEventListener("click", () => { events.splice(i, 1); renderTable(); });
    rm.appendChild(btn);
    tr.appendChild(rm);
    body.appendChild(tr);
  });
}

function errorSpan(field) {
  const s = document.createElement("span");
  s.className = "err";
  s.dataset.for = field;
  return s;
}

function addEvent(type) {
  const last = events.length ? events[events.length - 1].time : 0;
  events.push({ type, time: +(last + (events.length ? 0.25 : 0)).toFixed(3), ...DEFAULTS[type] });
  renderTable();
}

// ---- scene and errors ----------------------------------------------------------------------
function buildScene() {
  return {
    duration: Number($("#duration").value),
    sample_rate: Number($("#sample_rate").value),
    quality: $("#quality").value,
    guitar: { preset: $("#preset").value },
    events: events.map((ev) => {
      const out = { type: ev.type };
      for (const f of FIELDS[ev.type]) if (ev[f] !== undefined && ev[f] !== "") out[f] = ev[f];
      return out;
    }),
    output: {
      format: $("#format").value,
      normalize: $("#normalize").checked,
      ...($("#stereo").checked ? { channels: 2 } : {}),
    },
  };
}

function clearErrors() {
  document.querySelectorAll(".err").forEach((e) => { e.textContent = ""; });
  document.querySelectorAll(".invalid").forEach((e) => e.classList.remove("invalid"));
  document.querySelectorAll(".row-error").forEach((e) => e.classList.remove("row-error"));
}

// Put each error next to its field; what has no place on the page goes to the general box.
function showErrors(detail) {
  const general = [];
  for (const d of detail) {
    const field = d.field || "";
    const span = field && document.querySelector(`.err[data-for="${CSS.escape(field)}"]`);
    const text = d.msg ? d.msg.replace(/^Value error, /, "").replace(`${field}: `, "") : d.message;
    if (span) {
      span.textContent = span.textContent ? `${span.textContent}; ${text}` : text;
      const input = document.querySelector(`[data-field="${CSS.escape(field)}"]`);
      if (input) input.classList.add("invalid");
      const row = span.closest("tr");
      if (row) row.classList.add("row-error");
    } else {
      general.push(d.message || d.msg);
    }
  }
  $("#general-error").textContent = general.join("\n");
}

// ---- render --------------------------------------------------------------------------------
async function render() {
  clearErrors();
  const scene = buildScene();
  const button = $("#render");
  button.disabled = true;
  $("#status").textContent = "Rendering…";
  $("#spectrogram").dataset.drawn = "0";
  try {
    const r = await fetch("/render", {
      method: "POST", headers: { "content-type": "application/json" }, body: JSON.stringify(scene),
    });
    if (!r.ok) {
      const body = await r.json().catch(() => ({ detail: r.statusText }));
      if (Array.isArray(body.detail)) showErrors(body.detail);
      else $("#general-error").textContent = `${r.status}: ${body.detail}`;
      $("#status").textContent = `Not rendered (${r.status}).`;
      return;
    }
    const seconds = Number(r.headers.get("x-render-seconds"));
    const rtf = Number(r.headers.get("x-realtime-factor"));
    const blob = await r.blob();
    await showResult(blob, scene, seconds, rtf);
    $("#status").textContent = `Rendered ${scene.duration} s in ${seconds.toFixed(2)} s.`;
  } catch (err) {
    $("#general-error").textContent = String(err);
    $("#status").textContent = "Failed.";
  } finally {
    button.disabled = false;
  }
}

async function showResult(blob, scene, seconds, rtf) {
  if (objectUrl) URL.revokeObjectURL(objectUrl);
  objectUrl = URL.createObjectURL(blob);
  const audio = $("#audio");
  audio.src = objectUrl;
  const dl = $("#download");
  dl.href = objectUrl;
  dl.download = `guitar.${scene.output.format}`;
  dl.hidden = false;
  $("#stat-time").textContent = `${seconds.toFixed(3)} s`;
  $("#stat-rtf").textContent = `${rtf.toFixed(1)}× real time`;
  const chans = scene.output.channels === 2 ? "stereo" : "mono";
  $("#stat-audio").textContent = `${scene.duration} s ${chans} · ${(blob.size / 1024).toFixed(0)} KiB`;

  // Decode at the file's own rate, so the spectrogram's frequency axis is exact.
  const ctx = new OfflineAudioContext(2, 1, scene.sample_rate);
  const buffer = await ctx.decodeAudioData(await blob.arrayBuffer());
  let peak = 0;
  for (let c = 0; c < buffer.numberOfChannels; c++) {
    const ch = buffer.getChannelData(c);
    for (let i = 0; i < ch.length; i++) peak = Math.max(peak, Math.abs(ch[i]));
  }
  const samples = mixdown(buffer);
  $("#stat-peak").textContent = peak > 0 ? `${(20 * Math.log10(peak)).toFixed(1)} dBFS` : "silent";
  drawWaveform($("#waveform"), samples);
  drawSpectrogram($("#spectrogram"), samples, buffer.sampleRate);
}

// ---- drawing -------------------------------------------------------------------------------
// The drawings show the mono sum of a stereo file.
function mixdown(buffer) {
  if (buffer.numberOfChannels === 1) return buffer.getChannelData(0);
  const out = new Float32Array(buffer.length);
  for (let c = 0; c < buffer.numberOfChannels; c++) {
    const ch = buffer.getChannelData(c);
    for (let i = 0; i < out.length; i++) out[i] += ch[i] / buffer.numberOfChannels;
  }
  return out;
}

function fitCanvas(canvas) {
  const dpr = window.devicePixelRatio || 1;
  const w = Math.round(canvas.clientWidth * dpr) || canvas.width;
  const h = Math.round(canvas.clientHeight * dpr) || canvas.height;
  canvas.width = w;
  canvas.height = h;
  return [canvas.getContext("2d"), w, h];
}

function drawWaveform(canvas, samples) {
  const [g, w, h] = fitCanvas(canvas);
  g.fillStyle = "#14120f";
  g.fillRect(0, 0, w, h);
  g.strokeStyle = "#3a352e";
  g.beginPath(); g.moveTo(0, h / 2); g.lineTo(w, h / 2); g.stroke();
  g.fillStyle = "#e0a15e";
  const per = samples.length / w;
  for (let x = 0; x < w; x++) {
    let lo = 1, hi = -1;
    const a = Math.floor(x * per), b = Math.min(samples.length, Math.floor((x + 1) * per) + 1);
    for (let i = a; i < b; i++) { const v = samples[i]; if (v < lo) lo = v; if (v > hi) hi = v; }
    if (hi < lo) continue;
    const y0 = (1 - hi) * h / 2, y1 = (1 - lo) * h / 2;
    g.fillRect(x, y0, 1, Math.max(1, y1 - y0));
  }
}

// A perceptual dark-to-bright ramp (black, purple, orange, pale yellow).
function colour(t) {
  const stops = [[0, 0, 4], [40, 11, 84], [120, 28, 109], [187, 55, 84], [237, 105, 37], [251, 180, 26], [252, 255, 164]];
  const x = Math.min(0.9999, Math.max(0, t)) * (stops.length - 1);
  const i = Math.floor(x), f = x - i;
  return stops[i].map((c, k) => Math.round(c + f * (stops[i + 1][k] - c)));
}

// Log-frequency axis: a guitar's partials are evenly spaced in pitch, not in hertz.
function drawSpectrogram(canvas, samples, rate) {
  const [g, w, h] = fitCanvas(canvas);
  const n = 4096;
  const padded = samples.length >= n ? samples : Float32Array.from({ length: n }, (_, i) => samples[i] || 0);
  const { frames } = spectrogram(padded, n, w);
  const fmin = 40, fmax = Math.min(rate / 2, 10000);
  $("#frange").textContent = `${fmin} Hz – ${(fmax / 1000).toFixed(0)} kHz, log`;
  const binOf = (f) => Math.min(n / 2 - 1, Math.round((f * n) / rate));
  const rowBin = new Int32Array(h);
  for (let y = 0; y < h; y++) rowBin[y] = binOf(fmin * Math.pow(fmax / fmin, (h - 1 - y) / (h - 1)));
  let top = -Infinity;
  for (const f of frames) for (let k = binOf(fmin); k <= binOf(fmax); k++) top = Math.max(top, f[k]);
  const range = 90;  // dB shown below the loudest bin
  const img = g.createImageData(w, h);
  for (let x = 0; x < w; x++) {
    const f = frames[Math.min(frames.length - 1, Math.floor((x / w) * frames.length))];
    for (let y = 0; y < h; y++) {
      const [r, gg, b] = colour((f[rowBin[y]] - (top - range)) / range);
      const o = 4 * (y * w + x);
      img.data[o] = r; img.data[o + 1] = gg; img.data[o + 2] = b; img.data[o + 3] = 255;
    }
  }
  g.putImageData(img, 0, 0);
  // Frequency ticks.
  const dpr = window.devicePixelRatio || 1;
  g.font = `${11 * dpr}px system-ui, sans-serif`;
  g.fillStyle = "rgba(255,255,255,0.75)";
  for (const f of [100, 200, 500, 1000, 2000, 5000, 10000]) {
    if (f < fmin || f > fmax) continue;
    const y = (h - 1) * (1 - Math.log(f / fmin) / Math.log(fmax / fmin));
    g.fillRect(0, y, 6 * dpr, 1);
    g.fillText(f >= 1000 ? `${f / 1000}k` : `${f}`, 9 * dpr, y + 4 * dpr);
  }
  canvas.dataset.drawn = "1";
}

// ---- wiring --------------------------------------------------------------------------------
function wire() {
  document.querySelectorAll("[data-example]").forEach((b) =>
    b.addEventListener("click", () => loadExample(b.dataset.example)));
  document.querySelectorAll("[data-add]").forEach((b) =>
    b.addEventListener("click", () => addEvent(b.dataset.add)));
  $("#clear").addEventListener("click", () => { events = []; renderTable(); });
  $("#preset").addEventListener("change", showPresetInfo);
  $("#render").addEventListener("click", render);
}

async function main() {
  wire();
  try {
    await loadPresets();
    const limits = await (await fetch("/limits")).json();
    $("#duration").max = limits.max_duration_s;
  } catch (err) {
    $("#general-error").textContent = `Could not reach the service: ${err}`;
  }
  loadExample("strum");
  document.body.dataset.ready = "1";
}

main();
