// The page: one WebSocket to the ui box (services/ui/server.py). JSON texts come down (hello, view,
// reply, error, pong) and binary camera frames (tick int64, stamp float64, then the JPEG); requests go
// up as JSON ({op: ...}, checked by services/ui/protocol.py). No build step: this file is served as is.
"use strict";

const $ = (id) => document.getElementById(id);
const EARS = {
  teacher: "Teacher drives: the student learns",
  student: "The student drives",
  unsure: "The robot is unsure: teach it!",
};
const PLOT_SECONDS = 60;
const stats = { frames: [], keys: [], clicks: [] };  // for tests and the benchmark: when frames were shown, keys went down, buttons were clicked
window.doggedStats = stats;

let ws = null, hello = null, shownMode = null, series = [], frameTimes = [];
let framesCame = 0, frameDrawn = 0;  // frames in order of arrival; the newest drawn (decoding may finish out of order)
const held = new Set();  // arrow keys and buttons held now
let padAxes = null;      // the gamepad's say: [forward, turn] fractions or nulls
let refresh = null;

const esc = (s) => String(s).replace(/[&<>"']/g, (c) => `&#${c.charCodeAt(0)};`);  // bus names are checked; still

function now() { return performance.timeOrigin + performance.now(); }

function say(text, kind = "info") {
  const el = document.createElement("div");
  el.className = `msg ${kind}`;
  el.textContent = text;
  $("messages").appendChild(el);
  setTimeout(() => el.remove(), kind === "error" ? 8000 : 4000);
}

function send(obj) {
  if (ws && ws.readyState === WebSocket.OPEN) ws.send(JSON.stringify(obj));
}
window.doggedSendRaw = (text) => ws && ws.send(text);  // tests send malformed messages this way

function connect() {
  const token = new URLSearchParams(location.search).get("token");
  const url = `${location.protocol === "https:" ? "wss" : "ws"}://${location.host}/ws${token ? `?token=${encodeURIComponent(token)}` : ""}`;
  ws = new WebSocket(url);
  ws.binaryType = "arraybuffer";
  ws.onopen = () => { $("link").textContent = "online"; $("link").className = "link up"; };
  ws.onclose = () => {
    $("link").textContent = "offline"; $("link").className = "link down";
    setTimeout(connect, 1000);
  };
  ws.onmessage = (ev) => (typeof ev.data === "string" ? onText(JSON.parse(ev.data)) : onFrame(ev.data));
}

function onText(msg) {
  if (msg.type === "hello") {
    hello = msg;
    $("where").textContent = `instance ${msg.instance} · robot ${msg.robot} · you teach as ${msg.person}`;
  } else if (msg.type === "view") {
    onView(msg);
  } else if (msg.type === "error") {
    say(`refused: ${msg.text}`, "error");
  } else if (msg.type === "reply") {
    say(msg.text, msg.ok ? "info" : "error");
  }
}

function onFrame(buffer) {
  const view = new DataView(buffer);
  const tick = Number(view.getBigInt64(0, true)), stamp = view.getFloat64(8, true);
  const blob = new Blob([buffer.slice(hello ? hello.frame_header_bytes : 16)], { type: "image/jpeg" });
  const seq = ++framesCame;
  // drawn on a canvas, not shown as an <img> of a blob URL: headless chromium kept the images of those URLs,
  // revoked or not (1,254 -> 1,501 MB in an hour of ball seeking, benchmarks/soak.py; 15 frames a second on a
  // bare page: 1,062 -> 1,352 MB in 5 minutes as <img>, 906 -> 908 MB on a canvas)
  createImageBitmap(blob).then((bitmap) => {
    if (seq > frameDrawn) {  // an older frame decoded late is not drawn over a newer one
      frameDrawn = seq;
      const canvas = $("camera");
      if (canvas.width !== bitmap.width || canvas.height !== bitmap.height) {
        canvas.width = bitmap.width;
        canvas.height = bitmap.height;
      }
      canvas.getContext("2d").drawImage(bitmap, 0, 0);
      stats.frames.push([stamp * 1000, now(), tick]);
      if (stats.frames.length > 2000) stats.frames.splice(0, 1000);
    }
    bitmap.close();
  }, () => {});  // a frame that does not decode is skipped
  const t = now();
  frameTimes.push(t);
  while (frameTimes.length && frameTimes[0] < t - 2000) frameTimes.shift();
  $("fps").textContent = (frameTimes.length / 2).toFixed(1);
}

function onView(v) {
  const c = v.command || {};
  if (c.mode) {
    const ears = $("ears");
    ears.className = `ears ${c.mode}`;
    ears.dataset.mode = c.mode;
    $("ears-text").textContent = EARS[c.mode] || c.mode;
    $("confidence-text").textContent = `confidence ${(100 * c.confidence).toFixed(0)} %`;
    $("confidence").textContent = c.confidence.toFixed(2);
    $("confidence-bar").style.width = `${Math.round(100 * c.confidence)}%`;
    $("tick").textContent = c.tick;
    if (c.mode === "unsure" && shownMode !== "unsure") askAloud();
    shownMode = c.mode;
  }
  for (const p of v.series) series.push(p);
  const cut = (series.length ? series[series.length - 1][0] : 0) - PLOT_SECONDS;
  while (series.length && series[0][0] < cut) series.shift();
  drawPlot();
  drawTeachers(v.teachers, v.teaching);
  drawServices(v.services);
  drawTask(v.task || {});
  const p = v.person;
  $("person").textContent = p.active ? `you drive: ${describe(p.y, p.mask)}` : "you are not driving";
}

// a task's reward (a Gymnasium environment): the episode under way, and who drove the last ones
function drawTask(task) {
  if (task.episode === undefined) return;
  $("task").hidden = false;
  $("task-episode").textContent = task.episode;
  $("task-step").textContent = task.step;
  $("task-return").textContent = task.episode_return.toFixed(1);
  const rows = (task.ended || []).slice().reverse().map((e) => {
    const total = Object.values(e.modes).reduce((a, b) => a + b, 0) || 1;
    const who = Object.entries(e.modes).map(([m, n]) => `${m} ${Math.round(100 * n / total)} %`).join(", ");
    return `<tr><td>${e.episode}</td><td>${e.steps}</td><td>${e.episode_return.toFixed(1)}</td><td>${esc(who)}</td></tr>`;
  });
  $("episodes").querySelector("tbody").innerHTML = rows.join("");
}

function describe(y, mask) {
  if (!hello || !y) return "";
  return hello.outputs.names.map((n, i) => (mask && !mask[i] ? null : `${n} ${y[i].toFixed(2)}`))
    .filter(Boolean).join(", ");
}

function askAloud() {
  if (!$("sound").checked) return;
  try {  // a short two-tone chime: the ears turning green, heard
    const ctx = askAloud.ctx || (askAloud.ctx = new AudioContext());
    [660, 880].forEach((f, i) => {
      const o = ctx.createOscillator(), g = ctx.createGain();
      o.frequency.value = f; g.gain.value = 0.15;
      o.connect(g); g.connect(ctx.destination);
      o.start(ctx.currentTime + i * 0.18); o.stop(ctx.currentTime + i * 0.18 + 0.15);
    });
  } catch (e) { /* no audio until the person has touched the page */ }
  if ("speechSynthesis" in window) speechSynthesis.speak(new SpeechSynthesisUtterance("I am unsure. Teach me."));
}

// --- teaching switches -----------------------------------------------------------------------
let teacherNames = "";
function drawTeachers(teachers, teaching) {
  const box = $("teachers");
  const names = teachers.join(",");
  if (names !== teacherNames) {
    teacherNames = names;
    box.innerHTML = teachers.length ? "" : '<p class="small">no teacher runs in this instance</p>';
    for (const name of teachers) {
      const row = document.createElement("div");
      row.className = "teacher-row";
      row.innerHTML = `<b>${esc(name)}</b><button class="toggle" data-teacher="${esc(name)}">Teach</button>` +
        `<button class="hold" data-teacher="${esc(name)}">Hold to teach</button>`;
      box.appendChild(row);
    }
    box.querySelectorAll("button.toggle").forEach((b) => b.addEventListener("click", () => {
      stats.clicks.push([b.dataset.teacher, now()]);
      send({ op: "teach", teacher: b.dataset.teacher, on: !b.classList.contains("on") });
    }));
    box.querySelectorAll("button.hold").forEach((b) => {
      const t = b.dataset.teacher;
      // the pointer is captured while pressed: the button's row may reflow under it (the toggle's label
      // changes), and only letting go, not a layout moving, ends the lesson
      b.addEventListener("pointerdown", (ev) => {
        b.setPointerCapture(ev.pointerId);
        b.classList.add("on");
        send({ op: "teach", teacher: t, on: true, hold: true });
      });
      for (const ev of ["pointerup", "pointercancel"])
        b.addEventListener(ev, () => { b.classList.remove("on"); send({ op: "teach", teacher: t, on: false, hold: true }); });
    });
  }
  box.querySelectorAll("button.toggle").forEach((b) => {
    const on = teaching.includes(b.dataset.teacher);
    b.classList.toggle("on", on);
    b.textContent = on ? "Teaching: stop" : "Teach";
  });
}

// --- teleoperation: keys, buttons, gamepad ------------------------------------------------------
const KEYS = { ArrowUp: "up", ArrowDown: "down", ArrowLeft: "left", ArrowRight: "right" };

function axes() {
  // output 0 (forward): up +1, down -1; output 1 (turn, left positive): left +1, right -1; others unsaid.
  // Outputs that are a choice (one per action, the largest taken: a Gymnasium Discrete): left the first
  // action, right the last, up or down the middle one; the chosen at its high end, the rest at their low.
  const n = hello ? hello.outputs.names.length : 2;
  if (hello && hello.outputs.choice) return chosen(n);
  const y = new Array(n).fill(null);
  const pick = (plus, minus) => (held.has(plus) && !held.has(minus) ? 1 : held.has(minus) && !held.has(plus) ? -1 : null);
  y[0] = pick("up", "down");
  if (n > 1) y[1] = pick("left", "right");
  if (padAxes) padAxes.forEach((v, i) => { if (i < n && y[i] === null && v !== null) y[i] = v; });
  return y;
}

function chosen(n) {
  const action = held.has("left") ? 0 : held.has("right") ? n - 1 : held.has("up") || held.has("down") ? (n - 1) >> 1 : null;
  return action === null ? new Array(n).fill(null) : Array.from({ length: n }, (_, i) => (i === action ? 1 : -1));
}

let lastSaid = "";
function teleop(force = false) {
  const y = axes();
  const said = JSON.stringify(y);
  const speaking = y.some((v) => v !== null);
  if (said !== lastSaid || (force && speaking)) send({ op: "teleop", y, sent: now() });
  lastSaid = said;
  clearInterval(refresh);
  refresh = speaking ? setInterval(() => teleop(true), hello ? hello.teleop_refresh_ms : 100) : null;
  for (const k of ["up", "down", "left", "right"]) $(`key-${k}`).classList.toggle("held", held.has(k));
}

document.addEventListener("keydown", (ev) => {
  const k = KEYS[ev.key];
  if (!k || ev.target.tagName === "INPUT") return;
  ev.preventDefault();
  if (ev.repeat || held.has(k)) return;
  stats.keys.push([k, now()]);
  held.add(k);
  teleop();
});
document.addEventListener("keyup", (ev) => {
  const k = KEYS[ev.key];
  if (!k) return;
  held.delete(k);
  teleop();
});
window.addEventListener("blur", () => { held.clear(); teleop(); });  // a key released elsewhere is released
document.querySelectorAll(".pad .arrow").forEach((b) => {
  b.addEventListener("pointerdown", (ev) => {
    ev.preventDefault();
    b.setPointerCapture(ev.pointerId);  // a thumb sliding off the arrow does not let go: lifting it does
    stats.keys.push([b.dataset.key, now()]);
    held.add(b.dataset.key);
    teleop();
  });
  for (const ev of ["pointerup", "pointercancel"])
    b.addEventListener(ev, () => { if (held.delete(b.dataset.key)) teleop(); });
});

const PAD_DEAD_ZONE = 0.15;  // of a stick's throw, each axis
function pollGamepad() {
  const pads = navigator.getGamepads ? Array.from(navigator.getGamepads()).filter(Boolean) : [];
  const pad = pads[0];
  let next = null;
  if (pad) {
    const stick = [-pad.axes[1] || 0, -pad.axes[0] || 0];  // stick up: forward; stick left: turn left
    // one control over both axes: off centre it says both, an axis inside the dead zone as 0 (straight up is
    // forward and no turn, taught); inside the dead zone on both it says nothing and lets go. Said as unsaid,
    // the student's own turn was learned as the person's with every stick pushed straight (issue 31's soak)
    // past the dead zone an axis says its throw from the zone's edge, scaled to the whole range: a stick just off
    // centre says a gentle turn. Said as the stick's own value, nothing under 0.15 of an output's range could be
    // said: a person centring the ball (the program's turn under 0.15 while it is within 0.15 of the middle)
    // taught no turn at all
    const off = (v) => Math.abs(v) > PAD_DEAD_ZONE;
    const past = (v) => Math.sign(v) * Math.min(1, (Math.abs(v) - PAD_DEAD_ZONE) / (1 - PAD_DEAD_ZONE));
    next = stick.some(off) ? stick.map((v) => (off(v) ? past(v) : 0)) : null;
    $("gamepad").textContent = `gamepad: ${pad.id.slice(0, 40)}`;
  }
  if (JSON.stringify(next) !== JSON.stringify(padAxes)) { padAxes = next; teleop(); }
}
setInterval(pollGamepad, 50);

// --- arena and learner --------------------------------------------------------------------------
$("arena").addEventListener("submit", (ev) => {
  ev.preventDefault();
  send({ op: "arena", seed: Number($("arena-seed").value), balls: { pink: [Number($("pink-x").value), Number($("pink-y").value)] } });
});
$("record").addEventListener("click", () => send({ op: "record", on: !$("record").classList.contains("on") }));
$("swap").addEventListener("submit", (ev) => {
  ev.preventDefault();
  const service = $("swap-service").value;
  if (!service) { say("no learner service to swap", "error"); return; }
  send({ op: "swap", service, spec: $("swap-spec").value });
  say(`swapping ${service} to ${$("swap-spec").value}…`);
});

// --- drawing ------------------------------------------------------------------------------------
let servicesShown = "";
function drawServices(services) {
  // redrawn only when something changed (their rates do once a second): rebuilt with every view, ten a second,
  // the table took 6 % of a core of headless chromium
  const said = JSON.stringify(services);
  if (said === servicesShown) return;
  servicesShown = said;
  const rows = services.map((s) => {
    const rates = Object.entries(s.rates || {}).filter(([, v]) => v).slice(0, 4).map(([k, v]) => `${esc(k)} ${esc(v)}`).join(", ");
    const [i, r, n] = [esc(s.instance), esc(s.role), esc(s.name)];
    return `<tr data-service="${i}/${r}/${n}"><td>${i}</td><td>${r}</td><td>${n}</td>` +
      `<td class="${s.alive ? "alive" : "gone"}">${s.alive ? "alive" : "gone"}</td><td>${rates}</td></tr>`;
  });
  $("services").tBodies[0].innerHTML = rows.join("");
  const recorders = services.filter((s) => s.role === "recorder" && s.alive);
  $("recording").hidden = !recorders.length;
  if (recorders.length) {
    const on = recorders.every((s) => s.recording !== false);
    const button = $("record");
    button.classList.toggle("on", on);
    button.textContent = on ? "Recording: pause" : "Paused: record";
    $("record-state").textContent = on ? "every message goes into the run's files" : "not recording";
  }
  const select = $("swap-service"), learners = services.filter((s) => s.role === "learner").map((s) => s.name);
  if (select.options.length !== learners.length || learners.some((n, i) => select.options[i].value !== n))
    select.innerHTML = learners.map((n) => `<option value="${esc(n)}">${esc(n)}</option>`).join("");
}

function drawPlot() {
  const canvas = $("plot"), ctx = canvas.getContext("2d");
  const w = (canvas.width = canvas.clientWidth || 720), h = canvas.height;
  ctx.clearRect(0, 0, w, h);
  if (!series.length) return;
  const t1 = series[series.length - 1][0], t0 = t1 - PLOT_SECONDS;
  const x = (t) => ((t - t0) / PLOT_SECONDS) * w, y = (v) => h - 4 - Math.min(1, Math.max(0, v)) * (h - 8);
  ctx.fillStyle = "#c6282840";  // bands where a teacher spoke
  for (let i = 0; i < series.length; i++)
    if (series[i][3] === "teacher") {
      const next = i + 1 < series.length ? series[i + 1][0] : t1;
      ctx.fillRect(x(series[i][0]), 0, Math.max(1, x(next) - x(series[i][0])), h);
    }
  ctx.strokeStyle = "#bbb"; ctx.beginPath(); ctx.moveTo(0, y(0.25)); ctx.lineTo(w, y(0.25)); ctx.stroke();
  line(ctx, series.map((p) => [x(p[0]), y(p[1])]), "#1565c0");
  ctx.fillStyle = "#e65100";
  for (const p of series) if (p[2] !== null) ctx.fillRect(x(p[0]) - 1.5, y(p[2]) - 1.5, 3, 3);
}

function line(ctx, points, colour) {
  ctx.strokeStyle = colour; ctx.lineWidth = 2; ctx.beginPath();
  points.forEach(([px, py], i) => (i ? ctx.lineTo(px, py) : ctx.moveTo(px, py)));
  ctx.stroke();
}

connect();
