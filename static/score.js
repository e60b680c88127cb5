// The demo page's score player: open a Guitar Pro or MIDI file, choose tracks, render, play, and
// see which notes sound where (a piano roll of the labels, each note marked with its string and
// fret, under the waveform, with a playhead that follows the audio).
//
//   POST /score/scene   the file -> the scene (track list, warnings in X-Score-Warnings)
//   POST /score/labels  the file -> its notes as JAMS (one note_midi annotation per string)
//   POST /jobs          the file -> audio, for a song longer than one request may render,
//   GET /jobs/{id}/stream   played as it renders (a WAV whose bytes come as they are written)
//   POST /render/score  the file -> audio
//
// The scene and the labels are fetched and parsed in a worker (score-reader.js): a whole song's
// are megabytes of JSON. Self-contained otherwise: it uses nothing of app.js.
"use strict";

(() => {
  const q = (sel) => document.querySelector(sel);
  const COLOURS = ["#e0a15e", "#6fb7d6", "#b58bd8", "#8fcf7a", "#e57373", "#e6d36a", "#5fc4b0",
                   "#d98bb3"];
  const NAMES = ["C", "C♯", "D", "D♯", "E", "F", "F♯", "G", "G♯", "A", "A♯", "B"];
  const state = { file: null, scene: null, tracks: [], notes: [], duration: 0, samples: null,
                  urls: {}, limits: null, raf: 0, busy: false, tab: null, sceneKey: null, job: null };

  const noteName = (m) => `${NAMES[((Math.round(m) % 12) + 12) % 12]}${Math.floor(Math.round(m) / 12) - 1}`;

  function setStatus(text) { q("#score-status").textContent = text; }
  function setError(text) { q("#score-error").textContent = text || ""; }

  // The page's own names of the fields the API names.
  const FIELDS = { "options.max_seconds": "First seconds", duration: "Song length",
                   "options.all_instruments": "Other instruments", "options.tempo_scale": "Tempo",
                   "options.tracks": "Tracks", "options.quality": "Quality", "options.model": "Model",
                   file: "Score file" };

  // A refusal in the page's words: a 422's detail is a list of {field, msg, message}, each said
  // as "<the page's field name>: <what is wrong>"; anything else is a plain sentence.
  async function failure(r) {
    return refusalText({ status: r.status, statusText: r.statusText,
                         body: await r.json().catch(() => null) });
  }

  function refusalText({ status, statusText, body }) {
    const d = body ? body.detail : statusText;
    if (!Array.isArray(d)) {
      if (status === 429 || status === 503) return "The service is busy: try again in a moment.";
      return String(d || `The service answered ${status}.`);
    }
    return d.map((e) => {
      const field = e.field || "";
      const name = FIELDS[field] || (field.startsWith("file") ? "Score file" : field);
      const msg = String(e.msg || e.message || "").replace(/^Value error, /, "").replace(`${field}: `, "");
      return name ? `${name}: ${msg}` : msg;
    }).join("\n");
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
    const tempo = Number(q("#score-tempo").value);
    if (tempo > 0 && tempo !== 1) o.tempo_scale = tempo;
    if (q("#score-all").checked) o.all_instruments = true;
    if (withTracks) {
      const boxes = [...document.querySelectorAll("#score-tracks input[type=checkbox]")];
      const chosen = boxes.filter((c) => c.checked).map((c) => c.value);
      if (chosen.length < boxes.length) o.tracks = chosen;  // all of them: the score's default
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
      box1.addEventListener("change", tracksChanged);
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
      const solo = document.createElement("button");
      solo.type = "button";
      solo.className = "quiet solo";
      solo.textContent = "solo";
      solo.title = "play this track alone (click again: all tracks)";
      solo.addEventListener("click", (e) => { e.preventDefault(); soloTrack(name); });
      label.append(solo);
      box.append(label);
    }
    q("#score-render").disabled = groups.size === 0;
  }

  // Solo: only this track checked; soloing it again brings every track back.
  function soloTrack(name) {
    const boxes = [...document.querySelectorAll("#score-tracks input[type=checkbox]")];
    const alone = boxes.every((b) => b.checked === (b.value === name));
    for (const b of boxes) b.checked = alone || b.value === name;
    tracksChanged();
  }

  const noTrackChosen = () => !document.querySelector("#score-tracks input:checked");

  // Muting or soloing changes the mix: the audio is one render, so it is rendered again.
  function tracksChanged() {
    const none = noTrackChosen();
    q("#score-render").disabled = none || state.busy;
    if (none) setStatus("Choose at least one track.");
    else if (q("#score-audio").src) setStatus("Tracks changed: press Play to hear the new mix.");
  }

  // ---- reading a score: the scene and its labels, parsed in score-reader.js -------------------
  let reader = null;
  let reads = 0;
  function readScore(opts) {
    reader = reader || new Worker("/static/score-reader.js");
    const id = ++reads;
    return new Promise((resolve, reject) => {
      const done = (event) => {
        if (event.type === "message" && event.data.id !== id) return;  // an older read's answer
        reader.removeEventListener("message", done);
        reader.removeEventListener("error", done);
        if (event.type === "error") reject(new Error(event.message || "the score reader failed"));
        else resolve(event.data);
      };
      reader.addEventListener("message", done);
      reader.addEventListener("error", done);
      reader.postMessage({ id, file: state.file, options: opts });
    });
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

  // Lets the browser run what waits (input, painting, the audio element) before going on.
  const nextTask = () => new Promise((resolve) => setTimeout(resolve, 0));

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
      // tab: string and fret on the note when there is room, else the fret alone; a note no
      // wider than a label's padding and one digit of the 10 px font (over 5 px) has no room and
      // is not measured, which keeps a whole song's roll fast
      if (n.fret === undefined || geo.row < 9 * dpr || x1 - x0 <= 9 * dpr) continue;
      const long = `s${n.string} f${n.fret}`;
      const label = x1 - x0 > g.measureText(long).width + 4 * dpr ? long : `${n.fret}`;
      if (x1 - x0 > g.measureText(label).width + 4 * dpr) {
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

  // The notes sounding now, and the playhead over the tab and both drawings.
  function follow() {
    const audio = q("#score-audio");
    const t = audio.currentTime;
    const head = q("#score-playhead");
    head.style.left = `${Math.min(100, (t / (state.duration || 1)) * 100)}%`;
    head.hidden = !state.duration;
    if (state.tab) state.tab.setTime(t, true);  // playing or seeking: the cursor stays in view
    const now = state.notes.filter((n) => t >= n.time && t < n.time + n.duration);
    q("#score-now").textContent = now.length
      ? `Sounding: ${now.map((n) => `${noteName(n.pitch)} (s${n.string} f${n.fret})`).join(" · ")}`
      : "";
    if (!audio.paused) state.raf = requestAnimationFrame(follow);
  }

  // ---- the tablature ----------------------------------------------------------------------------
  function tabTracks(scene) {
    const sel = q("#tab-track");
    const keep = sel.value;
    sel.replaceChildren();
    const present = new Set(state.notes.map((n) => n.track));
    scene.tracks.forEach((t, i) => {
      if (!present.has(i)) return;
      const o = document.createElement("option");
      o.value = String(i);
      o.textContent = t.name || `Track ${i + 1}`;
      sel.append(o);
    });
    if ([...sel.options].some((o) => o.value === keep)) sel.value = keep;
    showTab();
  }

  function showTab() {
    const i = Number(q("#tab-track").value);
    const track = state.scene && state.scene.tracks[i];
    const notes = state.notes.filter((n) => n.track === i);
    const strings = track && track.guitar.tuning ? track.guitar.tuning.length : 0;
    state.tab.setNotes(notes, state.duration, strings, state.scene && state.scene.score);
  }

  function download(id, href, name) {
    const a = q(id);
    a.href = href;
    a.download = name;
    a.hidden = false;
  }

  function blobUrl(key, blob) {
    if (state.urls[key]) URL.revokeObjectURL(state.urls[key]);
    state.urls[key] = URL.createObjectURL(blob);
    return state.urls[key];
  }

  // The scene and its labels for the current choices: what the tab and the roll show.
  async function loadScene(withTracks) {
    const opts = options(withTracks);
    const key = JSON.stringify(opts);
    if (key === state.sceneKey && state.scene) return state.scene;  // already read for these choices
    const got = await readScore(opts);
    if (got.warnings !== undefined) showWarnings(got.warnings);
    if (got.refused) throw new PageError(refusalText(got.refused));
    if (got.error) throw new Error(got.error);
    state.scene = got.scene;
    state.duration = got.scene.duration;
    state.notes = got.notes;
    state.sceneKey = key;
    const stem = state.file.name.replace(/\.[^.]+$/, "");
    download("#score-dl-labels", blobUrl("labels", got.jamBlob), `${stem}.jams`);
    download("#score-dl-scene", blobUrl("scene", got.sceneBlob), `${stem}.json`);
    return state.scene;
  }

  class PageError extends Error {}

  // ---- actions --------------------------------------------------------------------------------
  async function openFile() {
    const file = q("#score-file").files[0];
    setError("");
    showWarnings(null);
    q("#score-tracks").replaceChildren();
    q("#score-render").disabled = true;
    if (!file) return;
    state.file = file;
    state.sceneKey = null;
    setStatus(`Reading ${file.name}…`);
    try {
      const scene = await loadScene(false);
      listTracks(scene);
      state.samples = null;
      tabTracks(scene);
      drawWave();
      drawRoll();
      describeScene("Choose tracks and render.");
    } catch (err) {
      setError(err instanceof PageError ? err.message : `Could not read the score: ${err.message || err}`);
      setStatus(err instanceof PageError ? "Not a score this page can play." : "Failed.");
    }
  }

  function describeScene(then) {
    const m = Math.floor(state.duration / 60), sec = (state.duration % 60).toFixed(1).padStart(4, "0");
    setStatus(`${state.file.name}: ${state.scene.tracks.length} tracks, ${state.notes.length} notes, ` +
              `${m}:${sec} (${state.duration.toFixed(1)} s). ${then}`);
  }

  // "First seconds" or the tempo changed: the scene is another length, re-read it.
  async function choicesChanged() {
    if (!state.file || state.busy) return;
    try {
      await loadScene(true);
      tabTracks(state.scene);
      drawWave();
      drawRoll();
      describeScene("Render to hear it.");
    } catch (err) {
      setError(err instanceof PageError ? err.message : String(err));
    }
  }

  // The audio: one request up to the service's limit for a render; beyond it a job, played
  // while it renders (GET /jobs/{id}/stream: a WAV whose bytes arrive as they are computed, so
  // playback starts within seconds and a seek ahead of the render waits for it).
  async function renderShort(opts) {
    const r = await fetch("/render/score", { method: "POST", body: form({ options: opts, output: "wav" }) });
    if (!r.ok) throw new PageError(await failure(r));
    return { blob: await r.blob(), seconds: Number(r.headers.get("x-render-seconds")) };
  }

  async function renderStreamed(opts) {
    const audio = q("#score-audio");
    const r = await fetch("/jobs", { method: "POST",
      body: form({ options: opts, output: { format: "wav", normalize: false } }) });
    if (!r.ok) throw new PageError(await failure(r));
    let job = await r.json();
    const before = state.job;
    state.job = job.id;
    if (before) fetch(`/jobs/${before}`, { method: "DELETE" }).catch(() => {});  // its audio is not wanted
    audio.src = `/jobs/${job.id}/stream`;
    audio.play().catch(() => {});  // starts as soon as the first blocks are in
    // playing: another Play (other tracks, tempo...) may start a new render, this one withdrawn
    state.busy = false;
    q("#score-render").disabled = noTrackChosen();
    const bar = q("#score-progress");
    bar.value = 0;
    bar.hidden = false;
    try {
      while (job.status === "queued" || job.status === "running") {
        const playing = !audio.paused && audio.readyState >= 3;
        setStatus(job.status === "queued" ? "Waiting for a free renderer…"
          : `${playing ? "Playing" : "Starting"} while the rest renders: ${Math.round(100 * job.progress)} % rendered`);
        await new Promise((resolve) => setTimeout(resolve, 500));
        if (state.job !== job.id) return null;  // a newer render took over
        const poll = await fetch(`/jobs/${job.id}`);
        if (!poll.ok) throw new PageError(await failure(poll));
        job = await poll.json();
        bar.value = job.progress;
      }
    } finally {
      bar.hidden = true;
    }
    if (job.status !== "done") {
      throw new PageError(job.status === "cancelled" ? "The render was cancelled."
        : `The render failed: ${job.error || "no reason given"}.`);
    }
    return { url: job.audio_url, seconds: job.render_seconds };
  }

  // Render and play: a click on Play.
  async function render() {
    setError("");
    const button = q("#score-render");
    button.disabled = true;
    state.busy = true;
    q("#score-roll").dataset.drawn = "0";
    q("#score-waveform").dataset.drawn = "0";
    setStatus("Preparing…");
    const stem = state.file.name.replace(/\.[^.]+$/, "");
    try {
      const opts = options(true);
      if (opts.tracks && !opts.tracks.length) { setError("Choose at least one track."); setStatus(""); return; }
      const scene = await loadScene(true);
      // each drawing of a whole song in a task of its own: one long task would hold the page
      await nextTask();
      tabTracks(scene);
      await nextTask();
      drawRoll();
      await state.limitsReady;
      const limit = state.limits ? state.limits.max_duration_s : Infinity;
      const audio = q("#score-audio");
      audio.pause();  // the last render's audio stops when Play asks for a new one
      q("#score-dl-audio").hidden = true;
      state.samples = null;
      drawWave();
      if (scene.duration > limit) {
        const done = await renderStreamed(opts);
        if (!done) return;
        download("#score-dl-audio", done.url, `${stem}.wav`);
        setStatus(`Rendered ${scene.duration.toFixed(1)} s of ${state.file.name} in ` +
                  `${done.seconds.toFixed(1)} s (${state.notes.length} notes).`);
        return;
      }
      state.job = null;
      const { blob, seconds } = await renderShort(opts);
      const url = blobUrl("audio", blob);
      audio.src = url;
      download("#score-dl-audio", url, `${stem}.wav`);
      audio.play().catch(() => {});
      const ctx = new OfflineAudioContext(1, 1, scene.sample_rate);
      const buffer = await ctx.decodeAudioData(await blob.arrayBuffer());
      state.rate = buffer.sampleRate;
      state.samples = buffer.getChannelData(0);
      drawWave();
      drawRoll();
      follow();
      setStatus(`Rendered ${scene.duration.toFixed(1)} s of ${state.file.name} in ${seconds.toFixed(1)} s ` +
                `(${state.notes.length} notes).`);
    } catch (err) {
      setError(err instanceof PageError ? err.message : `Something went wrong: ${err.message || err}`);
      setStatus("Not rendered.");
    } finally {
      state.busy = false;
      button.disabled = noTrackChosen();
    }
  }

  function seekTo(t) {
    const audio = q("#score-audio");
    if (!state.duration || !audio.src) return;
    audio.currentTime = t;
    follow();
  }

  function seek(event) {
    const r = event.currentTarget.getBoundingClientRect();
    seekTo(((event.clientX - r.left) / r.width) * state.duration);
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
    state.tab = new TabView(q("#tab-box"), q("#tab"), { onSeek: seekTo });
    q("#tab-track").addEventListener("change", showTab);
    q("#tab-zoom-in").addEventListener("click", () => state.tab.zoom(1.5));
    q("#tab-zoom-out").addEventListener("click", () => state.tab.zoom(1 / 1.5));
    q("#score-seconds").addEventListener("change", choicesChanged);
    q("#score-all").addEventListener("change", openFile);  // other tracks: another track list
    q("#score-tempo").addEventListener("change", choicesChanged);
    state.limitsReady = fetch("/limits").then((r) => r.json()).then((l) => {
      state.limits = l;
      q("#score-file").accept = (l.score_formats || ["gp3", "gp4", "gp5", "mid", "midi"]).map((x) => `.${x}`).join(",");
    }).catch(() => {});
    window.addEventListener("resize", () => { drawWave(); drawRoll(); });
  }

  wire();
  window.scorePlayer = { state, describe, seekTo };  // for the browser test and the console
})();
