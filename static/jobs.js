// Long renders as jobs (POST /jobs): the page polls GET /jobs/{id} and shows its progress, then
// fetches GET /jobs/{id}/audio. app.js calls renderJob for scenes longer than /render's limit.

const JOB_POLL_MS = 500;

// -> {ok: true, blob, seconds, warnings} | {ok: false, response} (POST refused: app.js shows
// the 4xx like /render's) | {ok: false, error} (the job failed or was cancelled)
async function renderJob(scene, onStatus) {
  const r = await fetch("/jobs", {
    method: "POST", headers: { "content-type": "application/json" }, body: JSON.stringify(scene),
  });
  if (!r.ok) return { ok: false, response: r };
  let job = await r.json();
  const bar = document.getElementById("job-progress");
  bar.value = 0;
  bar.hidden = false;
  try {
    while (job.status === "queued" || job.status === "running") {
      onStatus(job.status === "queued" ? "Queued as a job…"
        : `Rendering as a job… ${Math.round(100 * job.progress)} %`);
      await new Promise((resolve) => setTimeout(resolve, JOB_POLL_MS));
      const poll = await fetch(`/jobs/${job.id}`);
      if (!poll.ok) return { ok: false, error: `job ${job.id}: ${poll.status}` };
      job = await poll.json();
      bar.value = job.progress;
    }
  } finally {
    bar.hidden = true;
  }
  if (job.status !== "done") {
    return { ok: false, error: `The job ${job.status}${job.error ? `: ${job.error}` : "."}` };
  }
  const audio = await fetch(job.audio_url);
  return { ok: true, blob: await audio.blob(), seconds: job.render_seconds, warnings: job.warnings };
}
