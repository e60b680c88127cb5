// The score player's reader, in a worker of its own (score.js starts it): a whole song's scene and
// labels are megabytes of JSON, and parsing them on the page's main thread held it for over 100 ms
// while the audio of the last render played. Here they are fetched and parsed off that thread;
// the page gets back only what it shows (the tracks, the length, the bars, the notes) and both
// files as Blobs for its download links.
//
//   in:  { id, file, options }   the score file and the options of POST /score/scene
//   out: { id, scene, notes, sceneBlob, jamBlob, warnings }   read
//        { id, refused: { status, statusText, body }, warnings? }   the service said no
//        { id, error }   anything else (the network, a body that is not JSON)
"use strict";

self.onmessage = async ({ data: { id, file, options } }) => {
  try {
    self.postMessage({ id, ...(await read(file, options)) });
  } catch (err) {
    self.postMessage({ id, error: String((err && err.message) || err) });
  }
};

function form(file, options) {
  const f = new FormData();
  f.append("file", file, file.name);
  f.append("options", JSON.stringify(options));
  return f;
}

async function refusal(r) {
  return { status: r.status, statusText: r.statusText, body: await r.json().catch(() => null) };
}

async function read(file, options) {
  const r = await fetch("/score/scene", { method: "POST", body: form(file, options) });
  if (!r.ok) return { refused: await refusal(r) };
  const warnings = r.headers.get("x-score-warnings-summary") || r.headers.get("x-score-warnings");
  const scene = await r.json();
  // from the score itself: a whole song's scene may be larger than a request body may be
  const jamR = await fetch("/score/labels", { method: "POST", body: form(file, options) });
  if (!jamR.ok) return { refused: await refusal(jamR), warnings };
  const jamText = await jamR.text();
  return {
    // what the page uses of the scene: no events (a whole song has tens of thousands)
    scene: { duration: scene.duration, sample_rate: scene.sample_rate, score: scene.score,
             tracks: scene.tracks.map((t) => ({ name: t.name, guitar: t.guitar })) },
    notes: notesOf(JSON.parse(jamText)),
    sceneBlob: new Blob([JSON.stringify(scene, null, 1)], { type: "application/json" }),
    jamBlob: new Blob([jamText], { type: "application/json" }),
    warnings,
  };
}

// The labels (JAMS: one note_midi annotation per string of each track) as notes in time order.
function notesOf(jam) {
  const notes = [];
  for (const ann of jam.annotations) {
    if (ann.namespace !== "note_midi") continue;
    const extra = (ann.sandbox && ann.sandbox.notes) || [];
    ann.data.forEach((obs, i) => {
      const n = extra[i] || {};
      notes.push({ time: obs.time, duration: obs.duration, pitch: obs.value,
                   track: n.track ?? ann.sandbox.track ?? 0,
                   trackName: n.track_name ?? ann.sandbox.track_name ?? "",
                   string: n.string ?? ann.sandbox.string, fret: n.fret,
                   articulations: n.articulations || [] });
    });
  }
  return notes.sort((a, b) => a.time - b.time || a.pitch - b.pitch);
}
