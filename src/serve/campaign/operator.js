"use strict";
// minos campaign: the operator page. Polls the campaign's status, replays demonstrations
// (the simulator plays the recorded actions again; frames arrive over a WebSocket) and
// sends the operator's verdicts. State for tests is kept in window.operator.
(() => {
  const token = new URLSearchParams(location.search).get("operator") || "";
  const $ = (id) => document.getElementById(id);
  const state = window.operator = { status: null, error: null, replay: null, reviewed: null };
  const auth = { "x-minos-operator": token };
  function cell(tr, content) {
    const td = document.createElement("td");
    if (content instanceof Node) td.append(content); else td.textContent = content;
    tr.append(td);
  }
  function rows(id, items, cells, cls) {
    const body = $(id).querySelector("tbody");
    body.replaceChildren(...items.map((it) => {
      const tr = document.createElement("tr");
      if (cls) tr.className = cls(it);
      for (const c of cells(it)) cell(tr, c);
      return tr;
    }));
  }
  function button(label, title, onclick) {
    const b = document.createElement("button");
    b.type = "button"; b.textContent = label; b.title = title;
    b.addEventListener("click", onclick);
    return b;
  }
  const num = (v, d) => (v == null ? "–" : Number(v).toFixed(d));
  const said = (v) => (v.accepted ? "accepted" : "flagged: " + v.reasons.join("; "));
  function verdictText(d) {
    if (d.tutorial) return "tutorial";
    if (!d.review) return said(d.verdict);
    return (d.verdict.accepted ? "accepted" : "flagged") + " by the operator" +
      (d.review.note ? ": " + d.review.note : "") + ` (thresholds: ${said(d.review.automatic)})`;
  }
  function actions(d) {
    const span = document.createElement("span");
    span.append(button("replay", "play the recorded actions again", () => openReplay(d.session, d.episode_id)));
    if (!d.tutorial) {
      span.append(button("accept", "accept this demonstration", () => review(d, true)));
      span.append(button("flag", "flag this demonstration", () => review(d, false)));
    }
    return span;
  }
  async function refresh() {
    try {
      const r = await fetch("/api/operator/status", { headers: auth });
      if (!r.ok) throw new Error((await r.json()).error);
      const s = state.status = await r.json();
      $("name").textContent = s.campaign || "";
      $("summary").textContent = `${s.episodes_covered} of ${s.episodes_total} episodes have ` +
        `${s.demos_per_episode} accepted demonstrations · ${s.demos_accepted} accepted, ` +
        `${s.demos_flagged} flagged · ${s.live.length} live session(s)`;
      rows("episodes", s.episodes, (e) => [e.episode_id, e.accepted, e.flagged, e.in_flight],
        (e) => (e.accepted >= s.demos_per_episode ? "covered" : ""));
      rows("live", s.live, (l) => [l.participant, l.session]);
      rows("demos", s.demos, (d) => [d.session, d.episode_id + (d.tutorial ? " (tutorial)" : ""),
        verdictText(d),
        d.qc ? (d.qc.success ? "yes" : "no") : "–", d.qc ? num(d.qc.path_ratio, 2) : "–",
        d.qc ? num(d.qc.idle_seconds, 1) : "–", d.qc ? d.qc.collisions : "–",
        d.qc ? num(d.qc.actions_per_second, 2) : "–", d.qc ? num(d.qc.time_to_first_move, 1) : "–",
        actions(d)],
        (d) => (d.verdict.accepted || d.tutorial ? "" : "flagged"));
      rows("feedback", s.feedback || [], (f) => [f.participant, f.rating ?? "–", f.comment]);
      state.error = null;
    } catch (e) { state.error = String(e); $("summary").textContent = "error: " + e; }
  }

  async function review(d, accepted) {
    const body = { session: d.session, episode_id: d.episode_id, accepted, note: $("note").value };
    const r = await fetch("/api/operator/review", {
      method: "POST", headers: { ...auth, "content-type": "application/json" }, body: JSON.stringify(body),
    });
    const reply = await r.json();
    if (!r.ok) { state.error = reply.error; $("summary").textContent = "error: " + reply.error; return; }
    state.reviewed = reply;
    $("note").value = "";
    refresh();
  }

  // The replay: every frame is kept (a colour image and the pose), so the slider can go back.
  let socket = null, timer = null, mapImage = null;
  function openReplay(session, episode) {
    closeReplay();
    const rp = state.replay = { session, episode, info: null, frames: [], images: [], ended: false,
      end: null, error: null, at: 0 };
    $("replay").hidden = false;
    $("replay-title").textContent = `${episode} · ${session}`;
    $("replay-status").textContent = "replaying…"; $("replay-status").className = "muted";
    const proto = location.protocol === "https:" ? "wss" : "ws";
    const q = new URLSearchParams({ session, episode, operator: token });
    socket = new WebSocket(`${proto}://${location.host}/api/operator/replay?${q}`);
    socket.binaryType = "arraybuffer";
    socket.onmessage = (m) => {
      if (typeof m.data !== "string") return onBinary(rp, m.data);
      const v = JSON.parse(m.data);
      if (v.type === "replay") rp.info = v;
      else if (v.type === "frame") rp.frames.push(v);
      else if (v.type === "replay_end") {
        rp.ended = true; rp.end = v;
        const s = $("replay-status");
        s.className = v.agrees ? "agrees" : "differs";
        s.textContent = `${v.frames} frames · ${v.metrics.success ? "success" : "not reached"} · ` +
          `${v.metrics.path_length.toFixed(2)} m · ` +
          (v.agrees ? "the replay agrees with the quality record" : "the replay DIFFERS from the quality record");
      } else if (v.type === "error") { rp.error = v.message; $("replay-status").textContent = "error: " + v.message; }
    };
    socket.onclose = () => { if (!rp.ended && !rp.error) $("replay-status").textContent = "the replay stopped"; };
  }
  function onBinary(rp, buf) {
    const head = new DataView(buf, 0, 8);
    const kind = head.getUint8(0), format = head.getUint8(6);
    const w = head.getUint16(2, true), h = head.getUint16(4, true);
    const bytes = new Uint8Array(buf, 8);
    if (kind === 2) {
      const img = new Image();
      img.onload = () => { mapImage = img; show(rp.at); };
      img.src = URL.createObjectURL(new Blob([bytes], { type: "image/png" }));
      return;
    }
    let src;
    if (format === 0) {
      // Raw RGB: drawn through a canvas of its own.
      const c = document.createElement("canvas"); c.width = w; c.height = h;
      const data = new ImageData(w, h);
      for (let i = 0, j = 0; i < w * h; i++, j += 3) {
        data.data[4 * i] = bytes[j]; data.data[4 * i + 1] = bytes[j + 1]; data.data[4 * i + 2] = bytes[j + 2]; data.data[4 * i + 3] = 255;
      }
      c.getContext("2d").putImageData(data, 0, 0);
      src = c.toDataURL();
    } else {
      const type = format === 1 ? "image/jpeg" : format === 3 ? "image/webp" : "image/png";
      src = URL.createObjectURL(new Blob([bytes], { type }));
    }
    const img = new Image();
    img.src = src;
    rp.images.push(img);
    $("replay-slider").max = String(rp.images.length - 1);
    if (rp.images.length === 1) { img.onload = () => show(0); }
  }
  function show(i) {
    const rp = state.replay;
    if (!rp || !rp.images.length) return;
    i = Math.max(0, Math.min(i, rp.images.length - 1));
    rp.at = i;
    $("replay-slider").value = String(i);
    const img = rp.images[i], cam = $("replay-cam"), ctx = cam.getContext("2d");
    const draw = () => ctx.drawImage(img, 0, 0, cam.width, cam.height);
    if (img.complete) draw(); else img.onload = draw;
    const f = rp.frames[i];
    $("replay-at").textContent = f ? `frame ${i} · step ${f.step} · ${f.action || "start"}` +
      (f.collision ? " · bump" : "") + (f.done ? (f.success ? " · success" : " · ended") : "") : "";
    drawMap(rp, i);
  }
  function drawMap(rp, upto) {
    const c = $("replay-map"), ctx = c.getContext("2d");
    ctx.clearRect(0, 0, c.width, c.height);
    if (!mapImage || !rp.info) return;
    const m = rp.info.map, s = Math.min(c.width / m.size[0], c.height / m.size[1]);
    ctx.drawImage(mapImage, 0, 0, m.size[0] * s, m.size[1] * s);
    const px = (p) => [(p[0] - m.origin[0]) * m.pixels_per_metre * s, (p[2] - m.origin[1]) * m.pixels_per_metre * s];
    ctx.fillStyle = "#d92d20";
    for (const g of rp.info.goals || []) { const [x, y] = px(g); ctx.fillRect(x - 3, y - 3, 6, 6); }
    ctx.strokeStyle = "#1570ef"; ctx.lineWidth = 2; ctx.beginPath();
    rp.frames.slice(0, upto + 1).forEach((f, k) => { const [x, y] = px(f.position); if (k) ctx.lineTo(x, y); else ctx.moveTo(x, y); });
    ctx.stroke();
  }
  function play() {
    const rp = state.replay;
    if (!rp) return;
    if (timer) { clearInterval(timer); timer = null; $("replay-play").textContent = "▶ play"; return; }
    if (rp.at >= rp.images.length - 1) rp.at = 0;
    const dt = (rp.info && rp.info.dt ? rp.info.dt : 0.1) * 1000;
    $("replay-play").textContent = "❚❚ pause";
    timer = setInterval(() => {
      if (rp.at >= rp.images.length - 1 && rp.ended) { play(); return; }
      show(rp.at + 1);
    }, dt);
  }
  function closeReplay() {
    if (timer) { clearInterval(timer); timer = null; $("replay-play").textContent = "▶ play"; }
    if (socket) { socket.close(); socket = null; }
    mapImage = null;
    $("replay").hidden = true;
  }
  $("replay-play").addEventListener("click", play);
  $("replay-close").addEventListener("click", closeReplay);
  $("replay-slider").addEventListener("input", (e) => show(Number(e.target.value)));
  state.openReplay = openReplay;
  refresh();
  setInterval(refresh, 2000);
})();
