// The demo page's score player: open a Guitar Pro or MIDI file, choose tracks, render, play, and
// see which notes sound where (a piano roll of the labels, each note marked with its string and
// fret, under the waveform, with a playhead that follows the audio).
//
//   POST /score/scene   the file -> the scene (track list, warnings in X-Score-Warnings)
//   POST /scene/labels  the scene -> its notes as JAMS (one note_midi annotation per string)
//   POST /render/score  the file -> audio
//
// Self-contained: it uses nothing of app.js.
"use strict";

(() => {
  const q = (sel) => document.querySelector(sel);
  const COLOURS = ["#e0a15e", "#6fb7d6", "#b58bd8", "#8fcf7a", "#e57373", "#e6d36a", "#5fc4b0",
                   "#d98bb3"];
  const NAMES = ["C", "C♯", "D", "D♯", "E", "F", "F♯", "G", "G♯", "A", "A♯", "B"];
  const state = { file: null, tracks: [], notes: [], duration: 0, samples: null, url: null,
                  limits: null, raf: 0 };

  const noteName = (m) => `${NAMES[((Math.round(m) % 12) + 12) % 12]}${Math.floor(Math.round(m) / 12) - 1}`;

  function setStatus(text) { q("#score-status").textContent = text; }
  function setError(text) { q("#score-error").textContent = text || ""; }

  // A 422's detail is a list of {field, message}; anything else a string.
  async function failure(r) {
    const body = await r.json().catch(() => ({ detail: r.statusText }));
    const d = body.detail;
    const text = Array.isArray(d) ? d.map((e) => e.message || `${e.field}: ${e.msg}`).join("\n") : d;
    return `${r.status}: ${text}`;
  }

  function showWarnings(header) {
    const list = q("#score-warnings");
    list.replaceChildren();
    let warnings = [];
    try { warnings = header ? JSON.parse(header) : []; } catch { warnings = [header]; }
    for (const w of warnings) {
      const li = document.createElement("li");
      li.textContent = w;
      list.append(li);
    }
    list.hidden = warnings.length === 0;
  }

  function form(extra) {
    const f = new FormData();
    f.append("file", state.file, state.file.name);
    for (const [k, v] of Object.entries(extra)) f.append(k, typeof v === "string" ? v : JSON.stringify(v));
    return f;
  }

  function options(withTracks) {
    const o = { quality: q("#score-quality").value, model: q("#score-model").value };
    const secs = Number(q("#score-seconds").value);
    if (secs > 0) o.max_seconds = secs;
    if (withTracks) {
      const chosen = [...document.querySelectorAll("#score-tracks input:checked")].map((c) => c.value);
      o.tracks = chosen;
    }
    return o;
  }

  // ---- tracks --------------------------------------------------------------------------------
  // Tracks are chosen by name (the API takes numbers or names); tracks that share a name are one
  // choice.
  function listTracks(scene) {
    const box = q("#score-tracks");
    box.replaceChildren();
    const groups = new Map();
    scene.tracks.forEach((t, i) => {
      const name = t.name || `Track ${i + 1}`;
      if (!groups.has(name)) groups.set(name, []);
      groups.get(name).push({ index: i, track: t });
    });
    for (const [name, members] of groups) {
      const label = document.createElement("label");
      label.className = "check";
      const box1 = document.createElement("input");
      box1.type = "checkbox";
      box1.checked = true;
      box1.value = name;
      box1.dataset.tracks = members.map((m) => m.index).join(" ");
      const swatch = document.createElement("span");
      swatch.className = "swatch";
      swatch.style.background = COLOURS[members[0].index % COLOURS.length];
      const presets = [...new Set(members.map((m) => m.track.guitar.preset || "steel-acoustic"))];
      const strings = members[0].track.guitar.tuning ? `${members[0].track.guitar.tuning.length} strings` : "";
      label.append(box1, swatch, `${name}${members.length > 1 ? ` (${members.length} tracks)` : ""}`);
      const info = document.createElement("span");
      info.className = "hint";
      info.textContent = ` ${presets.join(", ")}${strings ? ", " + strings : ""}`;
      label.append(info);
      box.append(label);
    }
    q("#score-render").disabled = groups.size === 0;
  }

  // ---- labels (JAMS) -> notes -----------------------------------------------------------------
  function notesOf(jam) {
    const notes = [];
    for (const ann of jam.annotations) {
      if (ann.namespace !== "note_midi") continue;
      const extra = (ann.sandbox && ann.sandbox.notes) || [];
      ann.data.forEach((obs, i) => {
        const n = extra[i] || {};
        notes.push({ time: obs.time, duration: obs.duration, pitch: obs.value,
                     track: n.track ?? ann.sandbox.track ?? 0, trackName: n.track_name ?? ann.sandbox.track_name ?? "",
                     string: n.string ?? ann.sandbox.string, fret: n.fret,
                     articulations: n.articulations || [] });
      });
    }
    return notes.sort((a, b) => a.time - b.time || a.pitch - b.pitch);
  }

  async function labels(scene) {
    const r = await fetch("/scene/labels", { method: "POST", headers: { "content-type": "application/json" },
                                             body: JSON.stringify(scene) });
    if (!r.ok) throw new Error(await failure(r));
    return notesOf(await r.json());
  }

  // ---- drawing --------------------------------------------------------------------------------
  function fit(canvas) {
    const dpr = window.devicePixelRatio || 1;
    canvas.width = Math.round(canvas.clientWidth * dpr) || canvas.width;
    canvas.height = Math.round(canvas.clientHeight * dpr) || canvas.height;
    return [canvas.getContext("2d"), canvas.width, canvas.height, dpr];
  }

  function drawWave() {
    const canvas = q("#score-waveform");
    const [g, w, h] = fit(canvas);
    g.fillStyle = "#14120f";
    g.fillRect(0, 0, w, h);
    const s = state.samples;
    if (!s) return;
    g.fillStyle = "#e0a15e";
    // the waveform spans the scene's duration, as the roll does
    const per = (state.duration * state.rate) / w;
    for (let x = 0; x < w; x++) {
      let lo = 1, hi = -1;
      const a = Math.floor(x * per), b = Math.min(s.length, Math.floor((x + 1) * per) + 1);
      for (let i = a; i < b; i++) { const v = s[i]; if (v < lo) lo = v; if (v > hi) hi = v; }
      if (hi < lo) continue;
      g.fillRect(x, (1 - hi) * h / 2, 1, Math.max(1, (hi - lo) * h / 2));
    }
    canvas.dataset.drawn = "1";
  }

  function rollGeometry(w, h) {
    const pitches = state.notes.map((n) => n.pitch);
    const lo = Math.floor(Math.min(...pitches)) - 1, hi = Math.ceil(Math.max(...pitches)) + 2;
    const row = h / (hi - lo);
    return { lo, hi, row, x: (t) => (t / state.duration) * w, y: (p) => h - (p - lo + 1) * row };
  }

  function drawRoll() {
    const canvas = q("#score-roll");
    const [g, w, h, dpr] = fit(canvas);
    g.fillStyle = "#14120f";
    g.fillRect(0, 0, w, h);
    if (!state.notes.length) return;
    const geo = rollGeometry(w, h);
    // octave lines, labelled with their C
    g.font = `${10 * dpr}px system-ui, sans-serif`;
    for (let p = Math.ceil(geo.lo / 12) * 12; p < geo.hi; p += 12) {
      g.fillStyle = "#2c2822";
      g.fillRect(0, geo.y(p) + geo.row, w, 1);
      g.fillStyle = "rgba(255,255,255,0.45)";
      g.fillText(noteName(p), 3 * dpr, geo.y(p) + geo.row - 2 * dpr);
    }
    g.textBaseline = "middle";
    for (const n of state.notes) {
      const x0 = geo.x(n.time), x1 = Math.max(x0 + 2, geo.x(n.time + n.duration));
      const y = geo.y(n.pitch);
      g.fillStyle = COLOURS[n.track % COLOURS.length];
      g.globalAlpha = 0.85;
      g.fillRect(x0, y, x1 - x0, Math.max(2, geo.row - 1));
      g.globalAlpha = 1;
      // tab: string and fret on the note when there is room, else the fret alone
      const long = `s${n.string} f${n.fret}`;
      const label = x1 - x0 > g.measureText(long).width + 4 * dpr ? long : `${n.fret}`;
      if (n.fret !== undefined && geo.row >= 9 * dpr && x1 - x0 > g.measureText(label).width + 4 * dpr) {
        g.fillStyle = "#14120f";
        g.fillText(label, x0 + 2 * dpr, y + geo.row / 2);
      }
    }
    canvas.dataset.drawn = "1";
    canvas.dataset.notes = String(state.notes.length);
  }

  function noteAt(event) {
    const canvas = q("#score-roll");
    const r = canvas.getBoundingClientRect();
    const geo = rollGeometry(r.width, r.height);
    const t = ((event.clientX - r.left) / r.width) * state.duration;
    const p = geo.lo - 0.5 + (r.height - (event.clientY - r.top)) / geo.row;
    return state.notes.find((n) => t >= n.time && t <= n.time + n.duration && Math.abs(n.pitch - p) <= 0.5);
  }

  function describe(n) {
    const where = n.string !== undefined ? `string ${n.string}, fret ${n.fret}` : "";
    const arts = n.articulations.filter((a) => a !== "pluck").join(", ");
    return `${n.time.toFixed(2)} s: ${noteName(n.pitch)} (MIDI ${n.pitch.toFixed(2)}) on ` +
           `${n.trackName ? `'${n.trackName}', ` : ""}${where}, ${n.duration.toFixed(2)} s` +
           `${arts ? ` · ${arts}` : ""}`;
  }

  // The notes sounding now, and the playhead over both drawings.
  function follow() {
    const audio = q("#score-audio");
    const t = audio.currentTime;
    const head = q("#score-playhead");
    head.style.left = `${Math.min(100, (t / (state.duration || 1)) * 100)}%`;
    head.hidden = !state.duration;
    const now = state.notes.filter((n) => t >= n.time && t < n.time + n.duration);
    q("#score-now").textContent = now.length
      ? `Sounding: ${now.map((n) => `${noteName(n.pitch)} (s${n.string} f${n.fret})`).join(" · ")}`
      : "";
    if (!audio.paused) state.raf = requestAnimationFrame(follow);
  }

  // ---- actions --------------------------------------------------------------------------------
  async function openFile() {
    const file = q("#score-file").files[0];
    setError("");
    showWarnings(null);
    q("#score-tracks").replaceChildren();
    q("#score-render").disabled = true;
    if (!file) return;
    state.file = file;
    setStatus(`Reading ${file.name}…`);
    try {
      const r = await fetch("/score/scene", { method: "POST", body: form({ options: options(false) }) });
      if (!r.ok) { setError(await failure(r)); setStatus("Not a score this service can read."); return; }
      showWarnings(r.headers.get("x-score-warnings"));
      const scene = await r.json();
      listTracks(scene);
      state.duration = scene.duration;
      state.samples = null;
      state.notes = await labels(scene);
      drawWave();
      drawRoll();
      setStatus(`${file.name}: ${scene.tracks.length} tracks, ${state.notes.length} notes, ` +
                `${scene.duration.toFixed(1)} s. Choose tracks and render.`);
    } catch (err) {
      setError(String(err));
      setStatus("Failed.");
    }
  }

  async function render() {
    setError("");
    const button = q("#score-render");
    button.disabled = true;
    q("#score-roll").dataset.drawn = "0";
    q("#score-waveform").dataset.drawn = "0";
    setStatus("Rendering…");
    try {
      const opts = options(true);
      if (!opts.tracks.length) { setError("Choose at least one track."); setStatus(""); return; }
      const [sceneR, audioR] = await Promise.all([
        fetch("/score/scene", { method: "POST", body: form({ options: opts }) }),
        fetch("/render/score", { method: "POST", body: form({ options: opts, output: "wav" }) }),
      ]);
      if (!sceneR.ok) { setError(await failure(sceneR)); setStatus("Not rendered."); return; }
      if (!audioR.ok) { setError(await failure(audioR)); setStatus(`Not rendered (${audioR.status}).`); return; }
      showWarnings(audioR.headers.get("x-score-warnings"));
      const scene = await sceneR.json();
      state.duration = scene.duration;
      state.notes = await labels(scene);
      const blob = await audioR.blob();
      if (state.url) URL.revokeObjectURL(state.url);
      state.url = URL.createObjectURL(blob);
      const audio = q("#score-audio");
      audio.src = state.url;
      const ctx = new OfflineAudioContext(1, 1, scene.sample_rate);
      const buffer = await ctx.decodeAudioData(await blob.arrayBuffer());
      state.rate = buffer.sampleRate;
      state.samples = buffer.getChannelData(0);
      drawWave();
      drawRoll();
      follow();
      const secs = Number(audioR.headers.get("x-render-seconds"));
      setStatus(`Rendered ${scene.duration.toFixed(1)} s of ${state.file.name} in ${secs.toFixed(1)} s ` +
                `(${state.notes.length} notes).`);
    } catch (err) {
      setError(String(err));
      setStatus("Failed.");
    } finally {
      button.disabled = false;
    }
  }

  function seek(event) {
    const audio = q("#score-audio");
    if (!state.duration || !audio.src) return;
    const r = event.currentTarget.getBoundingClientRect();
    audio.currentTime = ((event.clientX - r.left) / r.width) * state.duration;
    follow();
  }

  function wire() {
    q("#score-file").addEventListener("change", openFile);
    q("#score-render").addEventListener("click", render);
    q("#score-model").addEventListener("change", () => {  // no quality levels on the waveguide
      const waveguide = q("#score-model").value === "waveguide";
      q("#score-quality").disabled = waveguide;
      q("#score-quality").title = waveguide ? "the waveguide model has no quality levels" : "";
    });
    const audio = q("#score-audio");
    audio.addEventListener("play", () => { cancelAnimationFrame(state.raf); follow(); });
    audio.addEventListener("seeked", follow);
    audio.addEventListener("pause", follow);
    for (const c of ["#score-roll", "#score-waveform"]) q(c).addEventListener("click", seek);
    q("#score-roll").addEventListener("mousemove", (e) => {
      const n = state.notes.length ? noteAt(e) : null;
      q("#score-note").textContent = n ? describe(n) : "";
    });
    fetch("/limits").then((r) => r.json()).then((l) => {
      state.limits = l;
      const s = q("#score-seconds");
      s.max = l.max_duration_s;
      if (Number(s.value) > l.max_duration_s) s.value = l.max_duration_s;
      q("#score-file").accept = (l.score_formats || ["gp3", "gp4", "gp5", "mid", "midi"]).map((x) => `.${x}`).join(",");
    }).catch(() => {});
    window.addEventListener("resize", () => { drawWave(); drawRoll(); });
  }

  wire();
  window.scorePlayer = { state, describe };  // for the browser test and the console
})();
