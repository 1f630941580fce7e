// The status page: polls /api/snapshot (the server samples the store every few seconds and
// answers every poll from its latest sample) and redraws its parts; figures are fetched again
// only when the done count moved (the server redraws them at a bounded rate). No library, no
// build step: everything the page needs is this file, page.css and index.html.
"use strict";

const $ = (id) => document.getElementById(id);
let figuresDoneAt = null;
let figureList = "";

function el(tag, attrs, ...children) {
  const node = document.createElement(tag);
  for (const [key, value] of Object.entries(attrs || {})) {
    if (key === "class") node.className = value;
    else if (key.startsWith("data-")) node.setAttribute(key, value);
    else node[key] = value;
  }
  for (const child of children) {
    if (child === null || child === undefined) continue;
    node.append(child instanceof Node ? child : String(child));
  }
  return node;
}

function duration(seconds) {
  if (seconds === null || seconds === undefined) return "unknown";
  seconds = Math.max(0, Math.round(seconds));
  const h = Math.floor(seconds / 3600), m = Math.floor((seconds % 3600) / 60), s = seconds % 60;
  if (h > 0) return `${h} h ${String(m).padStart(2, "0")} min`;
  if (m > 0) return `${m} min ${String(s).padStart(2, "0")} s`;
  return `${s} s`;
}

function when(unixSeconds) {
  return new Date(unixSeconds * 1000).toLocaleTimeString();
}

function shortId(id) {
  return id.length > 14 ? id.slice(0, 12) + "…" : id;
}

async function cancel(campaign, button) {
  if (!confirm(`Cancel the queued jobs of ${campaign.name} (${shortId(campaign.campaign)})? Running jobs finish.`)) return;
  button.disabled = true;
  const response = await fetch(`/api/campaigns/${encodeURIComponent(campaign.campaign)}/cancel`, {
    method: "POST", credentials: "same-origin",
  });
  const body = await response.json().catch(() => ({}));
  if (response.ok) alert(`cancelled ${body.cancelled} queued jobs`);
  else alert(`refused: ${body.error || response.status}`);
  button.disabled = false;
  refresh();
}

function campaignCard(c, snapshot) {
  const s = c.status;
  const pct = (100 * c.progress).toFixed(1);
  const part = (n, cls) => {
    const d = el("div", { class: cls });
    d.style.width = `${s.total ? (100 * n) / s.total : 0}%`;
    return d;
  };
  const bar = el("div", { class: "progress", title: `${pct} % finished` },
    part(s.done, "done"), part(s.failed, "failed"), part(s.cancelled, "cancelled"));
  const open = s.queued + s.running > 0;
  let action = null;
  if (open && c.cancelled_at === null) {
    if (snapshot.authenticated) {
      const button = el("button", { class: "danger", type: "button" }, "cancel");
      button.addEventListener("click", () => cancel(c, button));
      action = button;
    } else {
      action = el("a", { href: "/login", class: "small" }, snapshot.token_configured ? "log in to cancel" : "cancel needs --token-file");
    }
  }
  const rate = c.jobs_per_s === null ? "–" : c.jobs_per_s.toFixed(c.jobs_per_s < 10 ? 2 : 0);
  return el("div", { class: "card", "data-campaign": c.campaign },
    el("h3", {}, el("span", {}, c.name, " ", el("span", { class: "muted mono small", title: c.campaign }, shortId(c.campaign))), action),
    bar,
    el("div", { class: "counts" },
      el("span", {}, el("b", { class: "pct", "data-progress": pct }, `${pct} %`)),
      el("span", {}, el("b", { class: "ok" }, s.done), " done"),
      el("span", {}, el("b", { class: s.failed ? "bad" : "" }, s.failed), " failed"),
      el("span", {}, el("b", {}, s.running), " running"),
      el("span", {}, el("b", {}, s.queued), " queued"),
      s.cancelled ? el("span", {}, el("b", {}, s.cancelled), " cancelled") : null,
      el("span", {}, el("b", {}, s.total), " in all"),
      el("span", {}, el("b", {}, rate), " jobs/s"),
      el("span", {}, "remaining ", el("b", { class: "remaining" }, open ? duration(c.remaining_s) : "none"))),
    el("div", { class: "how" }, open ? `estimate: ${c.remaining_how}` : (c.cancelled_at ? "cancelled" : "finished")),
    c.timing.checked > 0
      ? el("div", { class: "how" }, `timing: ${c.timing.checked} points checked for noise, ${c.timing.rerun} re-run, ${c.timing.disturbed} flagged`)
      : null);
}

function renderCampaigns(snapshot) {
  const box = $("campaigns");
  if (snapshot.campaigns.length === 0) return;
  box.replaceChildren(...snapshot.campaigns.slice().reverse().map((c) => campaignCard(c, snapshot)));
}

function renderWorkers(snapshot) {
  const body = $("workers").tBodies[0];
  if (snapshot.workers.length === 0) return;
  body.replaceChildren(...snapshot.workers.map((w) => {
    const age = w.heartbeat_age_s;
    const heartbeat = el("span", { class: w.stale ? "bad" : "ok" }, w.stale ? `stale: ${duration(age)} ago` : `${age.toFixed(1)} s ago`);
    const hand = w.in_hand.length === 0 ? el("span", { class: "muted" }, "idle")
      : el("span", { class: "mono", title: w.in_hand.map((j) => j.job_id).join("\n") },
          w.in_hand.slice(0, 3).map((j) => `${j.kind} ${shortId(j.job_id)}`).join(", ") + (w.in_hand.length > 3 ? ` +${w.in_hand.length - 3}` : ""));
    return el("tr", { class: w.stale ? "stale" : "", "data-worker": w.id },
      el("td", { class: "mono" }, w.id),
      el("td", { class: "num" }, w.cores.length, el("span", { class: "muted small" }, ` (${w.cores.join(",")})`)),
      el("td", {}, w.cpu_model),
      el("td", { class: "mono", title: `${w.rustc}, ${w.profile}` }, w.git_commit.slice(0, 12)),
      el("td", {}, heartbeat),
      el("td", { class: "num" }, w.jobs_done),
      el("td", {}, hand),
      el("td", { class: "mono" }, w.allocation || el("span", { class: "muted" }, "–")));
  }));
}

const ALLOCATION_CLASS = { pending: "warn", running: "ok", ended: "muted", failed: "bad", cancelled: "muted" };

// The allocations of --slurm-alloc: the allocator's last decision (and its back-off), then one
// row per allocation, newest first; a failed one says why in red.
function renderAllocations(snapshot) {
  const a = snapshot.allocations;
  const section = $("allocations-section");
  if (!a || (!a.configured && a.allocations.length === 0)) {
    section.hidden = true;
    return;
  }
  section.hidden = false;
  const now = snapshot.taken_at;
  const backoff = a.retry_at !== null && a.retry_at > now
    ? el("span", { class: "bad" }, ` Backing off after ${a.failures} failures in a row: next submission in ${duration(a.retry_at - now)}.`)
    : null;
  $("allocator").replaceChildren(a.note ? `Allocator: ${a.note}` : "The allocator has not decided anything yet.", backoff || "");
  if (a.allocations.length === 0) return;
  const ago = (t) => (t === null ? "–" : `${duration(now - t)} ago`);
  $("allocations").tBodies[0].replaceChildren(...a.allocations.map((x) => el("tr", { "data-allocation": x.id },
    el("td", { class: "num" }, x.id),
    el("td", { class: "mono" }, x.external_id || "–"),
    el("td", { class: ALLOCATION_CLASS[x.state] || "" }, x.state),
    el("td", { class: "num" }, x.cores, el("span", { class: "muted small" }, x.nodes > 1 ? ` on ${x.nodes} nodes` : "")),
    el("td", {}, ago(x.submitted_at)),
    el("td", {}, ago(x.started_at)),
    el("td", {}, x.started_at === null ? "–" : duration((x.ended_at === null ? now : x.ended_at) - x.started_at)),
    el("td", { class: "num" }, x.workers),
    el("td", { class: "num" }, x.jobs_done === null ? "–" : x.jobs_done),
    el("td", { class: x.state === "failed" ? "bad" : "muted" }, x.reason))));
}

// The [[tune]] searches: a running one shows how many of its runs are done, a concluded one the
// value it found and why it stopped.
function renderSearches(snapshot) {
  const searches = snapshot.searches || [];
  $("searches-section").hidden = searches.length === 0;
  if (searches.length === 0) return;
  const num = (x) => (x === null || x === undefined ? "–" : Number(x).toPrecision(4));
  $("searches").tBodies[0].replaceChildren(...searches.map((s) => {
    const c = s.conclusion;
    const goal = s.goal.kind === "min" ? `min ${s.goal.field}` : "loosest safe";
    const o = c && c.objective;
    return el("tr", {},
      el("td", {}, s.campaign),
      el("td", {}, `${s.shape} N = ${s.n}, φ = ${s.phi}, X0 = ${s.x0}`),
      el("td", { class: "mono" }, s.knob),
      el("td", {}, goal),
      el("td", { class: "num" }, `${s.evaluations} / ${s.max_evaluations}`),
      el("td", { class: c ? "ok" : "warn" }, c ? c.stopped : "running"),
      el("td", { class: "num" }, c ? num(c.best) : "–"),
      el("td", { class: "num" }, c && c.interval ? `[${num(c.interval[0])}, ${num(c.interval[1])}]` : "–"),
      el("td", { class: "num" }, o ? `${num(o.mean)} ± ${num(o.half_width)} at ${num(o.x)} (${o.runs} runs)` : "–"));
  }));
}

function renderFailures(snapshot) {
  const body = $("failures").tBodies[0];
  if (snapshot.failures.length === 0) return;
  body.replaceChildren(...snapshot.failures.map((f) => el("tr", {},
    el("td", {}, when(f.failed_at)),
    el("td", { class: "mono", title: f.job_id }, `${f.kind} ${shortId(f.job_id)}`),
    el("td", { class: "num" }, f.attempt),
    el("td", { class: "mono" }, f.worker || "?"),
    el("td", { class: "bad" }, f.reason))));
}

// An SVG from our own server, inserted as a DOM node (not as HTML text), without any script.
function svgNode(text) {
  const doc = new DOMParser().parseFromString(text, "image/svg+xml");
  const root = doc.documentElement;
  if (root.nodeName !== "svg") throw new Error("not an SVG document");
  root.querySelectorAll("script, foreignObject").forEach((n) => n.remove());
  return document.importNode(root, true);
}

function tableNode(rows) {
  // Table 1's shape: one row per algorithm, one column per R*, the mean run time in each cell.
  const radii = [...new Set(rows.map((r) => r.r_star))].sort((a, b) => a - b);
  const algorithms = [...new Set(rows.map((r) => r.algorithm))];
  const cell = (a, r) => rows.find((x) => x.algorithm === a && x.r_star === r);
  return el("table", { class: "table1" },
    el("thead", {}, el("tr", {}, el("th", {}, "algorithm"), ...radii.map((r) => el("th", { class: "num" }, `R* = ${r} (ms)`)))),
    el("tbody", {}, ...algorithms.map((a) => el("tr", {}, el("td", {}, a), ...radii.map((r) => {
      const x = cell(a, r);
      const text = x ? `${x.mean_ms.toFixed(3)}${x.ci95_ms !== null ? ` ± ${x.ci95_ms.toFixed(3)}` : ""}` : "–";
      return el("td", { class: "num", title: x ? `${x.points} points, ${x.ns_per_check.toFixed(2)} ns/check` : "" }, text);
    })))));
}

async function refreshFigure(figure, slot) {
  const response = await fetch(figure.url, { credentials: "same-origin" });
  const status = slot.querySelector(".status");
  if (!response.ok) {
    const body = await response.json().catch(() => ({}));
    status.textContent = body.error || `HTTP ${response.status}`;
    return;
  }
  const drawn = response.headers.get("x-sweep-done");
  const content = slot.querySelector(".content");
  if (figure.format === "svg") content.replaceChildren(svgNode(await response.text()));
  else content.replaceChildren(tableNode(await response.json()));
  status.textContent = `as of ${drawn} jobs done`;
  slot.setAttribute("data-drawn-at", drawn);
}

async function renderFigures(snapshot) {
  const box = $("figures");
  const list = JSON.stringify([snapshot.figures, snapshot.figures_absent]);
  if (list !== figureList) {
    figureList = list;
    figuresDoneAt = null;
    box.replaceChildren(...snapshot.figures.map((f) => el("div", { class: "figure", "data-figure": f.name },
      el("h3", {}, f.title, " ", el("span", { class: "status muted small" }, "drawing…")),
      el("div", { class: "content" }))),
      ...snapshot.figures_absent.map((why) => el("p", { class: "muted" }, why)));
  }
  if (figuresDoneAt === snapshot.done_total || snapshot.figures.length === 0) return;
  figuresDoneAt = snapshot.done_total;
  await Promise.all(snapshot.figures.map((f) =>
    refreshFigure(f, box.querySelector(`[data-figure="${f.name}"]`)).catch((e) => {
      box.querySelector(`[data-figure="${f.name}"] .status`).textContent = String(e);
    })));
}

let timer = null;
async function refresh() {
  clearTimeout(timer);
  let next = 1000;
  try {
    const response = await fetch("/api/snapshot", { credentials: "same-origin" });
    if (response.status === 401) {
      location.href = "/login";
      return;
    }
    const snapshot = await response.json();
    $("session").replaceChildren(snapshot.authenticated
      ? el("span", {}, "logged in ", el("button", { type: "button", onclick: logout }, "log out"))
      : el("a", { href: "/login" }, snapshot.token_configured ? "log in" : "read-only"));
    renderCampaigns(snapshot);
    renderWorkers(snapshot);
    renderAllocations(snapshot);
    renderSearches(snapshot);
    renderFailures(snapshot);
    await renderFigures(snapshot);
    $("updated").textContent = `sampled at ${when(snapshot.taken_at)}`;
    $("cost").textContent = `The server samples the store every ${snapshot.next_sample_in_s.toFixed(1)} s (last sample ${(1000 * snapshot.sample_s).toFixed(0)} ms); this page asks every second.`;
    document.body.setAttribute("data-done-total", snapshot.done_total);
  } catch (e) {
    $("updated").textContent = `cannot reach the coordinator (${e.message}); retrying`;
    next = 3000;
  }
  timer = setTimeout(refresh, next);
}

async function logout() {
  await fetch("/logout", { method: "POST", credentials: "same-origin" });
  location.href = "/login";
}

refresh();
