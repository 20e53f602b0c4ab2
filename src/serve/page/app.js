"use strict";
// minos serve: the page. Talks to the server over one WebSocket per session; nothing is
// loaded from anywhere else. State for tests and benchmarks is kept in window.minos.
(() => {
  const $ = (id) => document.getElementById(id);
  const params = new URLSearchParams(location.search);
  const access = params.get("access");
  // A campaign participant's link: the campaign chooses the episodes.
  const participant = params.get("participant");
  const headers = access ? { "x-minos-access": access } : {};
  const KEYS = {
    ArrowUp: "forward", w: "forward", ArrowDown: "backward", s: "backward",
    ArrowLeft: "turn_left", a: "turn_left", ArrowRight: "turn_right", d: "turn_right",
    q: "strafe_left", e: "strafe_right", r: "look_up", PageUp: "look_up",
    f: "look_down", PageDown: "look_down", " ": "stop", Enter: "stop",
  };
  const state = window.minos = {
    info: null, session: null, episode: null, step: null, done: false, busy: false,
    queued: null, sentAt: 0, latencies: [], frames: 0, results: [], ended: false, error: null,
  };
  let ws = null, mapImage = null, episodeStart = 0, cameras = [], offered = new Set();

  async function init() {
    const r = await fetch("/api/info", { headers });
    if (!r.ok) { $("instruction").textContent = "The server refused: " + (await r.text()); return; }
    const info = state.info = await r.json();
    cameras = info.sensors;
    // Exactly the agent's actions: the others' buttons go, their keys do nothing.
    offered = new Set(info.actions);
    for (const b of document.querySelectorAll("button[data-action]")) b.hidden = !offered.has(b.dataset.action);
    const names = { forward: "W/↑ forward", backward: "S/↓ back", turn_left: "A/← turn left",
      turn_right: "D/→ turn right", strafe_left: "Q strafe left", strafe_right: "E strafe right",
      look_up: "R look up", look_down: "F look down", stop: "Space stop (say you are at the goal)" };
    $("keys").textContent = "Keys: " + info.actions.map((a) => names[a] || a).join(" · ") + " · N next episode";
    $("preset").textContent = "agent preset: " + info.preset;
    for (const e of info.episodes) $("episode").add(new Option(`${e.id} — ${e.instruction}`, e.id));
    if (!info.episodes.length) $("episode").add(new Option("(no episode file)", ""));
    for (const s of info.scenes) $("scene").add(new Option(s, s));
    if (params.get("episode")) $("episode").value = params.get("episode");
    if (params.get("scene")) $("scene").value = params.get("scene");
    if (params.get("path") === "1") $("show-path").checked = true;
    if (participant) {
      $("chooser").style.display = "none";
      state.campaign = true;
      start();
    } else if (params.has("autostart")) start();
  }

  async function start(ev) {
    if (ev) ev.preventDefault();
    if (ws) { ws.send(JSON.stringify({ end: true })); ws.close(); ws = null; }
    const scene = $("scene").value, episode = $("episode").value;
    const body = participant ? { participant } : scene ? { scene } : episode ? { episode } : {};
    const r = await fetch(participant ? "/api/campaign/join" : "/api/sessions", {
      method: "POST", headers: { ...headers, "content-type": "application/json" }, body: JSON.stringify(body),
    });
    const reply = await r.json();
    if (!r.ok) { showError(reply.error); return; }
    state.session = reply.name; state.ended = false;
    if (participant && reply.instructions) $("preset").textContent = reply.instructions;
    if (participant && reply.tutorial) $("result").textContent = "First a short tutorial episode.";
    $("session").textContent = "session " + reply.name;
    const proto = location.protocol === "https:" ? "wss" : "ws";
    const q = access ? "?access=" + encodeURIComponent(access) : "";
    ws = new WebSocket(`${proto}://${location.host}/api/sessions/${reply.token}/ws${q}`);
    ws.binaryType = "arraybuffer";
    ws.onopen = sendViews;
    ws.onmessage = (m) => (typeof m.data === "string" ? onText(JSON.parse(m.data)) : onBinary(m.data));
    ws.onclose = () => { state.ended = true; $("session").textContent += " (ended)"; };
  }

  function sendViews() {
    if (!ws || ws.readyState !== 1) return;
    const views = [];
    for (const c of cameras) if ($("show-" + c.name) && $("show-" + c.name).checked) views.push(c.name);
    ws.send(JSON.stringify({ views }));
    for (const name of ["depth", "semantic"]) $("fig-" + name).classList.toggle("off", !$("show-" + name).checked);
    $("fig-map").classList.toggle("off", !$("show-map").checked);
  }

  function showError(message) { state.error = message; $("result").className = "failure"; $("result").textContent = message; }

  function onText(m) {
    if (m.type === "episode") {
      state.episode = m; state.done = false; state.step = null; state.busy = false; state.queued = null;
      episodeStart = performance.now();
      $("instruction").textContent = m.instruction[0].toUpperCase() + m.instruction.slice(1);
      $("result").textContent = `episode ${m.episode_id} · shortest path ${m.geodesic_distance.toFixed(1)} m`;
      $("result").className = "";
    } else if (m.type === "step") {
      state.step = m;
      $("step").textContent = `${m.step} / ${state.episode.max_steps}`;
      const wall = (performance.now() - episodeStart) / 1000;
      $("time").textContent = `${m.time.toFixed(1)} s simulated · ${wall.toFixed(0)} s`;
      const d = m.geodesic ?? m.euclidean;
      $("dist").textContent = d == null ? "–" : `${d.toFixed(2)} m` + (m.collision ? " · bump!" : "");
      $("atgoal").textContent = m.at_goal ? "yes — press Space" : "no";
      drawMap();
    } else if (m.type === "done") {
      state.done = true; state.busy = false; state.results.push(m);
      const ok = m.metrics.success;
      $("result").className = ok ? "success" : "failure";
      $("result").textContent = (ok ? "Success! " : "Not reached. ") +
        `${m.metrics.steps} steps, ${m.metrics.path_length.toFixed(1)} m, SPL ${m.metrics.spl.toFixed(2)} · ` +
        `${m.played} episode(s) recorded` + (m.more ? " · N for the next" : "");
    } else if (m.type === "error") {
      state.busy = false; showError(m.message);
    } else if (m.type === "campaign_done") {
      state.campaignDone = true;
      $("instruction").textContent = "Thank you! There is nothing left for you to play.";
      $("feedback").hidden = false;
    } else if (m.type === "end") {
      $("result").textContent += ` · session over: ${m.episodes} episode(s) recorded in ${m.session}`;
    }
  }

  // The last stage of a participant's visit: how hard it was, and anything else to say.
  async function sendFeedback(ev) {
    ev.preventDefault();
    const picked = document.querySelector("input[name=rating]:checked");
    const body = { participant, comment: $("comment").value };
    if (picked) body.rating = Number(picked.value);
    const r = await fetch("/api/campaign/feedback", {
      method: "POST", headers: { ...headers, "content-type": "application/json" }, body: JSON.stringify(body),
    });
    const reply = await r.json();
    state.feedback = r.ok ? "sent" : reply.error;
    $("feedback-result").textContent = r.ok ? "Thank you — you may close this page." : reply.error;
    if (r.ok) $("send-feedback").disabled = true;
  }

  function onBinary(buf) {
    const head = new DataView(buf, 0, 8);
    const kind = head.getUint8(0), index = head.getUint8(1);
    const w = head.getUint16(2, true), h = head.getUint16(4, true);
    if (kind === 2) {
      const url = URL.createObjectURL(new Blob([new Uint8Array(buf, 8)], { type: "image/png" }));
      const img = new Image();
      img.onload = () => { mapImage = img; drawMap(); };
      img.src = url;
      return;
    }
    const cam = cameras[index];
    const canvas = $("cam-" + (cam ? cam.name : "color")) || $("cam-color");
    if (canvas.width !== w || canvas.height !== h) { canvas.width = w; canvas.height = h; }
    const ctx = canvas.getContext("2d"), format = head.getUint8(6);
    const shown = () => { if (cam && cam.modality === "color") frameShown(); };
    if (format === 0) {
      // Raw RGB pixels.
      const rgb = new Uint8Array(buf, 8), img = ctx.createImageData(w, h), px = img.data;
      for (let i = 0, j = 0; i < rgb.length; i += 3, j += 4) {
        px[j] = rgb[i]; px[j + 1] = rgb[i + 1]; px[j + 2] = rgb[i + 2]; px[j + 3] = 255;
      }
      ctx.putImageData(img, 0, 0);
      shown();
      return;
    }
    const type = format === 1 ? "image/jpeg" : format === 3 ? "image/webp" : "image/png";
    createImageBitmap(new Blob([new Uint8Array(buf, 8)], { type }))
      .then((bitmap) => { ctx.drawImage(bitmap, 0, 0); bitmap.close(); shown(); })
      .catch((e) => showError("a frame could not be decoded: " + e));
  }

  // The colour frame of the last action is on screen: its latency, and the queued action.
  function frameShown() {
    state.frames++;
    if (state.busy) {
      const ms = performance.now() - state.sentAt;
      state.latencies.push(ms);
      $("latency").textContent = `${ms.toFixed(0)} ms`;
      state.busy = false;
      if (state.queued) { const a = state.queued; state.queued = null; act(a); }
    }
  }

  function drawMap() {
    const canvas = $("map"), ep = state.episode;
    if (!mapImage || !ep) return;
    if (canvas.width !== mapImage.width) { canvas.width = mapImage.width; canvas.height = mapImage.height; }
    const ctx = canvas.getContext("2d"), map = ep.map;
    const px = (p) => [(p[0] - map.origin[0]) * map.pixels_per_metre, (p[2] - map.origin[1]) * map.pixels_per_metre];
    ctx.drawImage(mapImage, 0, 0);
    const r = Math.max(3, ep.radius * map.pixels_per_metre);
    if ($("show-path").checked && ep.path.length > 1) {
      ctx.strokeStyle = "#f5a623"; ctx.lineWidth = Math.max(2, r / 2); ctx.beginPath();
      ep.path.forEach((p, i) => { const [x, y] = px(p); i ? ctx.lineTo(x, y) : ctx.moveTo(x, y); });
      ctx.stroke();
    }
    ctx.fillStyle = "#e0245e";
    for (const g of ep.goals) { const [x, y] = px(g); ctx.beginPath(); ctx.arc(x, y, r * 1.2, 0, 7); ctx.fill(); }
    const s = state.step;
    const pos = s ? s.position : ep.start, yaw = s ? s.yaw : ep.start_yaw;
    const [x, y] = px(pos);
    ctx.fillStyle = "#2f6fde"; ctx.beginPath(); ctx.arc(x, y, r, 0, 7); ctx.fill();
    // Forward is (−sin yaw, −cos yaw) in (x, z).
    ctx.strokeStyle = "#2f6fde"; ctx.lineWidth = Math.max(2, r / 2); ctx.beginPath(); ctx.moveTo(x, y);
    ctx.lineTo(x - Math.sin(yaw) * r * 3, y - Math.cos(yaw) * r * 3); ctx.stroke();
  }

  function act(name) {
    if (!offered.has(name)) return;
    if (!ws || ws.readyState !== 1 || !state.episode || state.done || state.step == null) return;
    if (state.busy) { state.queued = name; return; }
    state.busy = true; state.sentAt = performance.now();
    ws.send(JSON.stringify({ action: name }));
  }

  function next() {
    if (ws && ws.readyState === 1 && state.done) { state.done = false; ws.send(JSON.stringify({ next: null })); }
  }

  document.addEventListener("keydown", (ev) => {
    if (ev.target instanceof HTMLSelectElement || ev.target instanceof HTMLTextAreaElement ||
      ev.ctrlKey || ev.metaKey || ev.altKey) return;
    const key = ev.key.length === 1 ? ev.key.toLowerCase() : ev.key;
    const toggles = { "1": "show-depth", "2": "show-semantic", m: "show-map", p: "show-path" };
    if (KEYS[key]) { ev.preventDefault(); act(KEYS[key]); }
    else if (key === "n") next();
    else if (toggles[key]) { const t = $(toggles[key]); t.checked = !t.checked; sendViews(); drawMap(); }
  });
  for (const b of document.querySelectorAll("button[data-action]")) b.addEventListener("click", () => act(b.dataset.action));
  $("next").addEventListener("click", next);
  for (const id of ["show-depth", "show-semantic", "show-map", "show-path"]) $(id).addEventListener("change", () => { sendViews(); drawMap(); });
  $("chooser").addEventListener("submit", start);
  $("feedback").addEventListener("submit", sendFeedback);
  init().catch((e) => showError(String(e)));
})();
