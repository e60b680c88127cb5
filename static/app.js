// The demo page: build a scene, POST /render, play it, draw waveform and spectrogram.
"use strict";

const $ = (sel) => document.querySelector(sel);

// ---- event types ---------------------------------------------------------------------------
// Each event type with exactly the fields the API takes (API.md; engine/scene.py), in the order
// the editor shows them, and the values a newly added event starts from. A field left empty is
// not sent, so the API's default applies; `empty` says what that default is where it is not a
// plain value.
const EVENTS = {
  pluck: {
    fields: ["time", "string", "style", "position", "force", "duration"],
    start: { string: 1, style: "finger", position: 0.8, force: 2 },
    empty: { duration: "style's" },
  },
  fret: {
    fields: ["time", "string", "fret", "force", "release"],
    start: { string: 1, fret: 3, force: 2 },
  },
  tap: {
    fields: ["time", "string", "fret", "force", "velocity", "release"],
    start: { string: 3, fret: 7, force: 0.9 },
  },
  hammer_on: {
    fields: ["time", "string", "fret", "force", "velocity", "release"],
    start: { string: 3, fret: 7 },
  },
  pull_off: {
    fields: ["time", "string", "fret", "force"],
    start: { string: 3, fret: 7, force: 1 },
  },
  slide: {
    fields: ["time", "string", "from_fret", "to_fret", "duration", "force", "release"],
    start: { string: 3, from_fret: 5, to_fret: 7, duration: 0.2 },
  },
  bend: {
    fields: ["time", "string", "semitones", "duration", "release"],
    start: { string: 2, semitones: 2, duration: 0.25 },
  },
  vibrato: {
    fields: ["time", "string", "depth_cents", "rate_hz", "duration"],
    start: { string: 1, depth_cents: 25, rate_hz: 5.5, duration: 1 },
  },
  harmonic: {
    fields: ["time", "string", "fret", "position", "release"],
    start: { string: 1, fret: 12 },
    empty: { fret: "or position", position: "or fret" },
  },
  mute: {
    fields: ["time", "string", "position", "amount", "release"],
    start: { position: 0.96, amount: 0.7 },
    empty: { string: "all" },
  },
  strum: {
    fields: ["time", "strings", "direction", "spread", "force", "position", "style"],
    start: { direction: "down", spread: 0.03, force: 2, position: 0.8, style: "finger" },
  },
  damp: {
    fields: ["time", "string"],
    start: { string: 1 },
    empty: { string: "all" },
  },
};

// How each parameter is edited: a number (`int`: whole) or one of `choices`; `empty` is the
// placeholder of an empty field ("" where the field is required).
const FIELD_INPUTS = {
  time: { label: "Time (s)", empty: "" },
  fret: { label: "Fret", int: true, empty: "" },
  from_fret: { label: "From fret", int: true, empty: "" },
  to_fret: { label: "To fret", int: true, empty: "" },
  force: { label: "Force (N)", empty: "preset's" },
  velocity: { label: "Velocity (m/s)" },
  position: { label: "Position (x/L)" },
  duration: { label: "Duration (s)" },
  release: { label: "Release (s)", empty: "none" },
  semitones: { label: "Semitones", empty: "" },
  depth_cents: { label: "Depth (cents)" },
  rate_hz: { label: "Rate (Hz)" },
  amount: { label: "Amount (0–1)" },
  spread: { label: "Spread (s)" },
  style: { label: "Style", choices: ["finger", "pick", "slap", "pop"] },
  direction: { label: "Direction", choices: ["down", "up"] },
};
const FIXED = ["time", "string", "strings"];  // the table's own columns; the rest are parameters
const MAX_PICKUPS = 4;

let presets = [];
let examples = [];
let events = [];
let pickups = [];  // [{position, gain}]; empty: the preset's single pickup
let objectUrl = null;

const currentPreset = () => presets.find((p) => p.name === $("#preset").value);

// ---- examples ------------------------------------------------------------------------------
// static/examples.json holds ready scenes; the tests render every one of them.
async function loadExamples() {
  const body = await (await fetch("/static/examples.json")).json();
  examples = body.examples;
  const box = $("#examples");
  for (const ex of examples) {
    const b = document.createElement("button");
    b.type = "button";
    b.dataset.example = ex.id;
    b.textContent = ex.label;
    b.title = ex.description;
    b.addEventListener("click", () => loadExample(ex.id));
    box.appendChild(b);
  }
  return body.default;
}

// Fill the form from an example's scene; buildScene() gives the same scene back.
function loadExample(id) {
  const ex = examples.find((e) => e.id === id);
  const scene = ex.scene;
  const output = scene.output || {};
  $("#preset").value = scene.guitar?.preset ?? presets.find((p) => p.default).name;
  $("#duration").value = scene.duration;
  $("#sample_rate").value = scene.sample_rate ?? 44100;
  $("#quality").value = scene.quality ?? "standard";
  $("#model").value = scene.model ?? "fdtd";
  modelChanged();
  $("#format").value = output.format || "wav";
  $("#body").value = output.body || "";
  $("#normalize").checked = output.normalize !== false;
  $("#stereo").checked = output.channels === 2;
  pickups = (output.pickups || []).map((p) => ({ ...p }));
  events = scene.events.map((e) => structuredClone(e));
  $("#example-info").textContent = ex.description;
  presetChanged();
  clearErrors();
}

// ---- presets -------------------------------------------------------------------------------
async function loadPresets() {
  const r = await fetch("/presets");
  const body = await r.json();
  presets = body.presets;
  const sel = $("#preset");
  sel.innerHTML = "";
  for (const p of presets) sel.appendChild(option(p.name, p.name));
  sel.value = body.default;
  presetChanged();
}

// The string selectors, fret limits and pickup hint follow the preset.
function presetChanged() {
  const p = currentPreset();
  if (!p) return;
  const tuning = p.strings.map((s) => `${s.string}:${s.note}`).join(" ");
  $("#preset-info").textContent =
    `${p.description}. ${p.strings.length} strings, ${p.frets} frets, tuning ${tuning}, tensions ` +
    `${Math.round(Math.min(...p.strings.map((s) => s.tension_n)))}–` +
    `${Math.round(Math.max(...p.strings.map((s) => s.tension_n)))} N.`;
  $("#pickup-default").textContent = `(none: the preset's, at x/L ${p.pickup_position})`;
  $("#body option[value='']").textContent = `preset's (${p.body})`;
  renderTable();
  renderPickups();
}

// ---- event table ---------------------------------------------------------------------------
function option(value, text) {
  const o = document.createElement("option");
  o.value = value;
  o.textContent = text;
  return o;
}

function errorSpan(...fields) {
  const s = document.createElement("span");
  s.className = "err";
  s.dataset.for = fields.join(" ");
  return s;
}

// A "×" button that removes a row.
function removeButton(title, onClick) {
  const rm = document.createElement("button");
  rm.type = "button";
  rm.className = "remove";
  rm.title = title;
  rm.textContent = "×";
  rm.addEventListener("click", onClick);
  return rm;
}

function cell(...children) {
  const td = document.createElement("td");
  td.append(...children);
  return td;
}

function renderTable() {
  const body = $("#events tbody");
  body.innerHTML = "";
  events.forEach((ev, i) => {
    const tr = document.createElement("tr");
    tr.dataset.index = i;
    tr.dataset.type = ev.type;
    const fields = EVENTS[ev.type].fields;
    const typeSel = document.createElement("select");
    for (const t of Object.keys(EVENTS)) typeSel.appendChild(option(t, t));
    typeSel.value = ev.type;
    typeSel.dataset.field = `events[${i}].type`;
    typeSel.addEventListener("change", () => changeType(i, typeSel.value));
    tr.appendChild(cell(typeSel, errorSpan(`events[${i}]`)));
    tr.appendChild(cell(numberInput(ev, i, "time"), errorSpan(`events[${i}].time`)));
    if (fields.includes("strings")) {
      tr.appendChild(cell(stringsInput(ev, i), errorSpan(`events[${i}].strings`)));
    } else {
      tr.appendChild(cell(stringSelect(ev, i), errorSpan(`events[${i}].string`)));
    }
    const params = document.createElement("div");
    params.className = "params";
    for (const name of fields.filter((f) => !FIXED.includes(f))) {
      const label = document.createElement("label");
      label.className = "param";
      const spec = FIELD_INPUTS[name];
      const input = spec.choices ? choiceSelect(ev, i, name, spec.choices) : numberInput(ev, i, name);
      label.append(spec.label, input, errorSpan(`events[${i}].${name}`));
      params.appendChild(label);
    }
    tr.appendChild(cell(params));
    tr.appendChild(cell(removeButton("remove", () => { events.splice(i, 1); renderTable(); })));
    body.appendChild(tr);
  });
}

// A new type keeps the event's time and string and starts its own fields from EVENTS[type].start.
function changeType(i, type) {
  const { time, string } = events[i];
  events[i] = { type, time, ...EVENTS[type].start };
  if (string !== undefined && EVENTS[type].fields.includes("string")) events[i].string = string;
  renderTable();
}

function numberInput(ev, i, name) {
  const spec = FIELD_INPUTS[name];
  const input = document.createElement("input");
  input.type = "number";
  input.step = spec.int ? "1" : "any";
  input.dataset.field = `events[${i}].${name}`;
  if (name.includes("fret")) {
    input.min = name === "fret" && ev.type === "fret" ? "0" : "1";
    input.max = currentPreset().frets;
  }
  input.value = ev[name] ?? "";
  input.placeholder = (EVENTS[ev.type].empty || {})[name] ?? spec.empty ?? "default";
  input.addEventListener("input", () => {
    if (input.value === "") delete events[i][name];
    else events[i][name] = Number(input.value);
  });
  return input;
}

function choiceSelect(ev, i, name, choices) {
  const sel = document.createElement("select");
  for (const c of choices) sel.appendChild(option(c, c));
  sel.value = ev[name] ?? choices[0];  // the first choice is the API's default
  sel.dataset.field = `events[${i}].${name}`;
  sel.addEventListener("change", () => { events[i][name] = sel.value; });
  return sel;
}

// Strings 1..n of the current preset, each with its open note; "all" where the type allows it.
// A string the preset lacks (after a preset change) stays listed, so the API can say so.
function stringSelect(ev, i) {
  const sel = document.createElement("select");
  const empty = (EVENTS[ev.type].empty || {}).string;
  if (empty) sel.appendChild(option("", empty));
  for (const s of currentPreset().strings) sel.appendChild(option(s.string, `${s.string} ${s.note}`));
  if (ev.string !== undefined && !sel.querySelector(`option[value="${ev.string}"]`)) {
    sel.appendChild(option(ev.string, `${ev.string} ?`));
  }
  sel.value = ev.string ?? "";
  sel.dataset.field = `events[${i}].string`;
  sel.addEventListener("change", () => {
    if (sel.value === "") delete events[i].string;
    else events[i].string = Number(sel.value);
  });
  return sel;
}

// A strum's strings as "4 3 2 1" (or with commas); empty: all of them.
function stringsInput(ev, i) {
  const input = document.createElement("input");
  input.type = "text";
  input.value = (ev.strings || []).join(" ");
  input.placeholder = "all";
  input.dataset.field = `events[${i}].strings`;
  input.addEventListener("input", () => {
    const list = input.value.split(/[\s,]+/).filter(Boolean).map(Number);
    if (list.length) events[i].strings = list;
    else delete events[i].strings;
  });
  return input;
}

function addEvent(type) {
  const last = events.length ? events[events.length - 1].time : 0;
  const time = +(last + (events.length ? 0.25 : 0)).toFixed(3);
  events.push({ type, time, ...EVENTS[type].start });
  renderTable();
}

// ---- pickups -------------------------------------------------------------------------------
function renderPickups() {
  const box = $("#pickups");
  box.innerHTML = "";
  pickups.forEach((pu, k) => {
    const row = document.createElement("div");
    row.className = "pickup";
    for (const [name, text, empty] of [["position", "x/L", ""], ["gain", "gain", "1"]]) {
      const label = document.createElement("label");
      label.className = "param";
      const input = document.createElement("input");
      input.type = "number";
      input.step = "any";
      input.value = pu[name] ?? "";
      input.placeholder = empty;
      input.dataset.field = `output.pickups[${k}].${name}`;
      input.addEventListener("input", () => {
        if (input.value === "") delete pickups[k][name];
        else pickups[k][name] = Number(input.value);
      });
      label.append(text, input, errorSpan(`output.pickups[${k}].${name}`));
      row.appendChild(label);
    }
    row.append(removeButton("remove pickup", () => { pickups.splice(k, 1); renderPickups(); }),
               errorSpan(`output.pickups[${k}]`));
    box.appendChild(row);
  });
  $("#pickup-default").hidden = pickups.length > 0;
  $("#add-pickup").disabled = pickups.length >= MAX_PICKUPS;
}

function addPickup() {
  const p = currentPreset();
  pickups.push({ position: pickups.length ? 0.75 : p.pickup_position, gain: 1 });
  renderPickups();
}

// ---- scene and errors ----------------------------------------------------------------------
function buildScene() {
  const output = { format: $("#format").value, normalize: $("#normalize").checked };
  if ($("#stereo").checked) output.channels = 2;
  if ($("#body").value) output.body = $("#body").value;
  if (pickups.length) output.pickups = pickups.map((p) => ({ ...p }));
  return {
    duration: Number($("#duration").value),
    sample_rate: Number($("#sample_rate").value),
    quality: $("#quality").value,
    model: $("#model").value,
    guitar: { preset: $("#preset").value },
    events: events.map((ev) => {
      const out = { type: ev.type };
      for (const f of EVENTS[ev.type].fields) if (ev[f] !== undefined && ev[f] !== "") out[f] = ev[f];
      return out;
    }),
    output,
  };
}

function clearErrors() {
  document.querySelectorAll(".err").forEach((e) => { e.textContent = ""; });
  document.querySelectorAll(".invalid").forEach((e) => e.classList.remove("invalid"));
  document.querySelectorAll(".row-error").forEach((e) => e.classList.remove("row-error"));
}

// The error box of a field, else of the nearest field that contains it:
// events[2].strings[0] -> events[2].strings -> events[2].
function errorPlace(field) {
  for (let f = field; f;) {
    const span = document.querySelector(`.err[data-for~="${CSS.escape(f)}"]`);
    if (span) return span;
    const parent = f.replace(/(\.\w+|\[\d+\])$/, "");
    if (parent === f) break;
    f = parent;
  }
  return null;
}

// Put each error next to its field; what has no place on the page goes to the general box.
function showErrors(detail) {
  const general = [];
  for (const d of detail) {
    const field = d.field || "";
    const span = field && errorPlace(field);
    if (!span) {
      general.push(d.message || d.msg);
      continue;
    }
    const own = span.dataset.for.split(" ").includes(field);
    const text = own && d.msg ? d.msg.replace(/^Value error, /, "").replace(`${field}: `, "") : d.message;
    span.textContent = span.textContent ? `${span.textContent}; ${text}` : text;
    const input = document.querySelector(`[data-field="${CSS.escape(span.dataset.for.split(" ")[0])}"]`);
    if (input) input.classList.add("invalid");
    const row = span.closest("tr");
    if (row) row.classList.add("row-error");
  }
  $("#general-error").textContent = general.join("\n");
}

// ---- render --------------------------------------------------------------------------------
// X-Render-Warnings: a JSON array of what the scene asks for that will not sound as meant (a
// finger pressing too lightly to seat its string).
function showWarnings(header) {
  const list = $("#warnings");
  list.replaceChildren();
  let warnings = [];
  try {
    warnings = header ? JSON.parse(header) : [];
  } catch {
    warnings = [header];  // not JSON: show it as it came
  }
  for (const w of warnings) {
    const item = document.createElement("li");
    item.textContent = w;
    list.append(item);
  }
  list.hidden = warnings.length === 0;
}

let renderLimit = Infinity;

async function render() {
  clearErrors();
  showWarnings(null);
  const scene = buildScene();
  const button = $("#render");
  button.disabled = true;
  $("#status").textContent = "Rendering…";
  $("#spectrogram").dataset.drawn = "0";
  try {
    let r;
    if (scene.duration > renderLimit) {  // too long for one request: a job (static/jobs.js)
      const job = await renderJob(scene, (text) => { $("#status").textContent = text; });
      if (job.ok) {
        showWarnings(job.warnings.length ? JSON.stringify(job.warnings) : null);
        await showResult(job.blob, scene, job.seconds, scene.duration / job.seconds);
        $("#status").textContent = `Rendered ${scene.duration} s as a job in ${job.seconds.toFixed(2)} s.`;
        return;
      }
      if (job.response === undefined) {
        $("#general-error").textContent = job.error;
        $("#status").textContent = "Not rendered.";
        return;
      }
      r = job.response;  // refused (4xx): shown below like /render's answer
    } else {
      r = await fetch("/render", {
        method: "POST", headers: { "content-type": "application/json" }, body: JSON.stringify(scene),
      });
    }
    if (!r.ok) {
      const body = await r.json().catch(() => ({ detail: r.statusText }));
      if (Array.isArray(body.detail)) showErrors(body.detail);
      else $("#general-error").textContent = `${r.status}: ${body.detail}`;
      $("#status").textContent = `Not rendered (${r.status}).`;
      return;
    }
    showWarnings(r.headers.get("x-render-warnings"));
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
  // A label only where it clears the one below it and the canvas's top edge (a short canvas or
  // a narrow range would otherwise print them over each other).
  let lastY = Infinity;
  for (const f of [50, 100, 200, 500, 1000, 2000, 5000, 10000]) {
    if (f < fmin || f > fmax) continue;
    const y = (h - 1) * (1 - Math.log(f / fmin) / Math.log(fmax / fmin));
    if (lastY - y < 16 * dpr || y < 10 * dpr) continue;
    g.fillRect(0, y, 6 * dpr, 1);
    g.fillText(f >= 1000 ? `${f / 1000}k` : `${f}`, 9 * dpr, y + 4 * dpr);
    lastY = y;
  }
  canvas.dataset.drawn = "1";
}

// The waveguide model has no grids to choose: the quality select does nothing there.
function modelChanged() {
  const waveguide = $("#model").value === "waveguide";
  $("#quality").disabled = waveguide;
  $("#quality").title = waveguide ? "the waveguide model has no quality levels" : "";
}

// ---- wiring --------------------------------------------------------------------------------
function wire() {
  for (const t of Object.keys(EVENTS)) $("#add-type").appendChild(option(t, t));
  $("#add").addEventListener("click", () => addEvent($("#add-type").value));
  $("#clear").addEventListener("click", () => { events = []; renderTable(); });
  $("#add-pickup").addEventListener("click", addPickup);
  $("#preset").addEventListener("change", presetChanged);
  $("#model").addEventListener("change", modelChanged);
  $("#render").addEventListener("click", render);
}

async function main() {
  wire();
  try {
    await loadPresets();
    loadExample(await loadExamples());
    const limits = await (await fetch("/limits")).json();
    renderLimit = limits.max_duration_s;  // longer scenes are rendered as jobs
    $("#duration").max = limits.job_max_duration_s ?? limits.max_duration_s;
    $("#render").disabled = false;  // only now can a render be built (it needs the presets)
  } catch (err) {
    $("#general-error").textContent = `Could not reach the service: ${err}`;
  }
  document.body.dataset.ready = "1";
}

main();
