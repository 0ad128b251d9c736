// navstack dashboard: vanilla JS, one canvas, one WebSocket; no build step.
// The server pushes {type: hello | state | layer | plan | trail | result | error}.
// Commands go over HTTP with "Authorization: Bearer <token>"; without a token the page
// is read-only.  World frame is "map" (x right, y up); the canvas flips y.
"use strict";

const COLORS = {
  background: "#20242b", robot: "rgb(0,160,255)", robotEdge: "#00121f",
  scan: "#ff1744", plan: "#00e676", localPlan: "#ffd600", trail: "#ff9800",
  goal: "#ff00ff", waypoint: "#b388ff", aruco: "#18ffff", package: "#ffab40",
  frontier: "#2979ff", blacklisted: "#ff1744", frontierGoal: "#00e676",
};

const S = {
  hello: null, state: null, layers: {}, plan: [], trail: [], trailStart: 0,
  token: null, authorized: false, mode: "goal", costmap: "global",
  show: { scan: true, plan: true, trail: true }, dirty: true, renders: 0,
  view: null, ws: null, connected: false,
};

const $ = (id) => document.getElementById(id);
const canvas = $("map");
const ctx = canvas.getContext("2d");

// --- token --------------------------------------------------------------------------------
function readToken() {
  const m = /(?:^|[#&])token=([^&]+)/.exec(location.hash);
  if (m) {
    sessionStorage.setItem("navstack-token", decodeURIComponent(m[1]));
    history.replaceState(null, "", location.pathname + location.search);
  }
  return sessionStorage.getItem("navstack-token");
}

async function checkToken(token) {
  if (!token) return false;
  try {
    const r = await fetch("/api/auth", { headers: { Authorization: "Bearer " + token } });
    return r.status === 200;
  } catch (e) {
    return false;
  }
}

function setAuthorized(ok) {
  S.authorized = ok;
  for (const el of document.querySelectorAll("[data-needs-token]")) {
    if (el.id !== "release") el.disabled = !ok;
  }
  $("access").textContent = ok ? "control" : "read-only";
  $("access").className = "badge " + (ok ? "good" : "warn");
  $("token-box").classList.toggle("hidden", ok);
  updateEstopUi();
}

async function initToken() {
  S.token = readToken();
  const ok = await checkToken(S.token);
  if (!ok && S.token) {
    sessionStorage.removeItem("navstack-token");
    S.token = null;
    message("the stored token was refused; the page is read-only");
  }
  setAuthorized(ok);
}

// --- commands -------------------------------------------------------------------------------
async function command(method, path, body) {
  if (!S.authorized) {
    message("read-only: enter the token to send commands");
    return null;
  }
  const opts = { method, headers: { Authorization: "Bearer " + S.token } };
  if (body !== undefined) {
    opts.headers["Content-Type"] = "application/json";
    opts.body = JSON.stringify(body);
  }
  try {
    const r = await fetch(path, opts);
    const data = await r.json().catch(() => ({}));
    if (r.status === 401) setAuthorized(false);
    if (!r.ok) message(data.error || ("HTTP " + r.status));
    else message("");
    return { status: r.status, data };
  } catch (e) {
    message("request failed: " + e);
    return null;
  }
}

function message(text) { $("msg").textContent = text; }

// --- WebSocket ----------------------------------------------------------------------------------
function connect() {
  const proto = location.protocol === "https:" ? "wss:" : "ws:";
  const ws = new WebSocket(proto + "//" + location.host + "/ws");
  S.ws = ws;
  ws.onopen = () => { S.connected = true; setConn("live", "good"); };
  ws.onclose = () => {
    S.connected = false;
    setConn("disconnected – retrying", "bad");
    setTimeout(connect, 1000);
  };
  ws.onmessage = (ev) => onMessage(JSON.parse(ev.data));
}

function setConn(text, cls) { $("conn").textContent = text; $("conn").className = "badge " + cls; }

function onMessage(msg) {
  switch (msg.type) {
    case "hello":
      S.hello = msg; S.layers = {}; S.trail = []; S.trailStart = 0; resize(); break;
    case "layer": {
      const img = new Image();
      img.onload = () => { S.layers[msg.name] = { img, meta: msg }; markDirty(); };
      img.src = "data:image/png;base64," + msg.png;
      break;
    }
    case "plan": S.plan = msg.points; break;
    case "trail":
      if (msg.start !== S.trailStart + S.trail.length / 2) { S.trail = []; S.trailStart = msg.start; }
      S.trail = S.trail.concat(msg.points);
      break;
    case "state": S.state = msg; updatePanels(msg); break;
    case "error": message(msg.error); break;
    default: break;
  }
  markDirty();
}

// --- view transform --------------------------------------------------------------------------------
function resize() {
  const r = canvas.getBoundingClientRect();
  const dpr = window.devicePixelRatio || 1;
  canvas.width = Math.max(1, Math.round(r.width * dpr));
  canvas.height = Math.max(1, Math.round(r.height * dpr));
  if (!S.hello) return;
  const [xmin, ymin, xmax, ymax] = S.hello.bounds;
  const pad = 8;
  const s = Math.min((r.width - 2 * pad) / (xmax - xmin), (r.height - 2 * pad) / (ymax - ymin));
  const ox = (r.width - s * (xmax - xmin)) / 2;
  const oy = (r.height - s * (ymax - ymin)) / 2;
  S.view = { s, ox, oy, xmin, ymax, dpr };
  markDirty();
}

function worldToCss(x, y) {
  const v = S.view;
  return [v.ox + v.s * (x - v.xmin), v.oy + v.s * (v.ymax - y)];
}

function cssToWorld(px, py) {
  const v = S.view;
  return [v.xmin + (px - v.ox) / v.s, v.ymax - (py - v.oy) / v.s];
}

function worldTransform() {
  const v = S.view;
  const k = v.dpr * v.s;
  ctx.setTransform(k, 0, 0, -k, v.dpr * (v.ox - v.s * v.xmin), v.dpr * (v.oy + v.s * v.ymax));
}

// --- drawing ----------------------------------------------------------------------------------------------
function markDirty() {
  if (S.dirty) return;
  S.dirty = true;
  requestAnimationFrame(render);
}

function drawLayer(name) {
  const layer = S.layers[name];
  if (!layer) return;
  const m = layer.meta;
  const w = m.width * m.resolution, h = m.height * m.resolution;
  ctx.save();
  ctx.translate(m.pose[0], m.pose[1]);
  ctx.rotate(m.pose[2]);
  ctx.scale(1, -1);
  ctx.drawImage(layer.img, 0, -h, w, h);
  ctx.restore();
}

function polyline(flat, color, widthPx) {
  if (!flat || flat.length < 4) return;
  ctx.beginPath();
  ctx.moveTo(flat[0], flat[1]);
  for (let i = 2; i < flat.length; i += 2) ctx.lineTo(flat[i], flat[i + 1]);
  ctx.strokeStyle = color;
  ctx.lineWidth = widthPx / S.view.s;
  ctx.stroke();
}

function arrow(x, y, th, color, len) {
  const px = 1 / S.view.s;
  ctx.beginPath();
  ctx.arc(x, y, 5 * px, 0, 2 * Math.PI);
  ctx.fillStyle = color;
  ctx.fill();
  ctx.beginPath();
  ctx.moveTo(x, y);
  ctx.lineTo(x + len * Math.cos(th), y + len * Math.sin(th));
  ctx.strokeStyle = color;
  ctx.lineWidth = 3 * px;
  ctx.stroke();
}

// an ArUco marker on the map (a bar along its surface, a tick where it faces, its id) or
// a package (the ring the costmap avoids)
function drawAruco([id, x, y, yaw, kind]) {
  const px = 1 / S.view.s;
  ctx.lineWidth = 3 * px;
  if (kind === "package") {
    ctx.beginPath();
    ctx.arc(x, y, 0.15, 0, 2 * Math.PI);
    ctx.strokeStyle = COLORS.package;
    ctx.stroke();
  } else {
    const c = Math.cos(yaw), s = Math.sin(yaw), h = 0.15;
    ctx.beginPath();
    ctx.moveTo(x + s * h, y - c * h);
    ctx.lineTo(x - s * h, y + c * h);
    ctx.moveTo(x, y);
    ctx.lineTo(x + c * 0.12, y + s * 0.12);
    ctx.strokeStyle = COLORS.aruco;
    ctx.stroke();
  }
  ctx.save();
  ctx.translate(x, y);
  ctx.scale(px, -px);
  ctx.fillStyle = kind === "package" ? COLORS.package : COLORS.aruco;
  ctx.font = "12px sans-serif";
  ctx.fillText(String(id), 6, -6);
  ctx.restore();
}

function drawRobot(pose) {
  const [x, y, th] = pose;
  const c = Math.cos(th), s = Math.sin(th);
  const fp = S.hello.footprint;
  ctx.beginPath();
  fp.forEach(([u, v], i) => {
    const wx = x + c * u - s * v, wy = y + s * u + c * v;
    if (i === 0) ctx.moveTo(wx, wy); else ctx.lineTo(wx, wy);
  });
  ctx.closePath();
  ctx.fillStyle = COLORS.robot;
  ctx.fill();
  ctx.lineWidth = 1.5 / S.view.s;
  ctx.strokeStyle = COLORS.robotEdge;
  ctx.stroke();
  const r = Math.max(...fp.map(([u, v]) => Math.hypot(u, v)));
  ctx.beginPath();
  ctx.moveTo(x, y);
  ctx.lineTo(x + r * c, y + r * s);
  ctx.strokeStyle = "#ffffff";
  ctx.lineWidth = 2 / S.view.s;
  ctx.stroke();
}

function render() {
  S.dirty = false;
  ctx.setTransform(1, 0, 0, 1, 0, 0);
  ctx.fillStyle = COLORS.background;
  ctx.fillRect(0, 0, canvas.width, canvas.height);
  if (!S.view) return;
  worldTransform();
  ctx.imageSmoothingEnabled = false;
  drawLayer("map");
  if (S.costmap === "global" || S.costmap === "both") drawLayer("global_costmap");
  if (S.costmap === "local" || S.costmap === "both") drawLayer("local_costmap");
  if (S.show.trail) polyline(S.trail, COLORS.trail, 2);
  if (S.show.plan) polyline(S.plan, COLORS.plan, 2.5);
  const st = S.state;
  if (st) {
    if (S.show.plan) polyline(st.local_plan, COLORS.localPlan, 3);
    if (S.show.scan && st.scan.length) {
      ctx.fillStyle = COLORS.scan;
      const d = 2.5 / S.view.s;
      for (let i = 0; i < st.scan.length; i += 2) ctx.fillRect(st.scan[i] - d / 2, st.scan[i + 1] - d / 2, d, d);
    }
    drawFrontiers(st.frontiers);
    st.waypoints.forEach(([x, y, th]) => arrow(x, y, th, COLORS.waypoint, 0.5));
    (st.aruco || []).forEach(drawAruco);
    const goals = st.nav.status === "EXECUTING" || st.nav.status === "ACCEPTED" ? st.nav.goals : [];
    goals.forEach(([x, y, th]) => arrow(x, y, th, COLORS.goal, 0.6));
    if (st.robot) drawRobot(st.robot);
  }
  S.renders += 1;
}

// exploration frontiers (explore/frontiers markers): cells as dots, goals as rings
function drawFrontiers(f) {
  if (!f) return;
  const d = 3 / S.view.s;
  [["points", COLORS.frontier], ["blacklisted", COLORS.blacklisted]].forEach(([key, color]) => {
    ctx.fillStyle = color;
    const pts = f[key];
    for (let i = 0; i + 1 < pts.length; i += 2) ctx.fillRect(pts[i] - d / 2, pts[i + 1] - d / 2, d, d);
  });
  ctx.strokeStyle = COLORS.frontierGoal;
  ctx.lineWidth = 2 / S.view.s;
  for (let i = 0; i + 1 < f.goals.length; i += 2) {
    ctx.beginPath();
    ctx.arc(f.goals[i], f.goals[i + 1], 0.12, 0, 2 * Math.PI);
    ctx.stroke();
  }
}

function updateMission(m) {
  if (!m) return;
  setCell("ms-name", m.name);
  setCell("ms-status", m.status, m.status === "FAILED" ? "bad" : (m.status === "CANCELED" ? "warn" : ""));
  setCell("ms-doing", m.feedback || m.behaviour || "–");
  setCell("ms-elapsed", m.elapsed.toFixed(0) + " s");
  setCell("ms-reason", m.reason || "–", m.reason ? "warn" : "");
}

// --- panels -------------------------------------------------------------------------------------------------
const fmt = (v, unit, digits = 2) => (v === null || v === undefined ? "–" : v.toFixed(digits) + unit);

function setCell(id, text, cls) { const el = $(id); el.textContent = text; el.className = cls || ""; }

function updatePanels(st) {
  $("clock").textContent = "t = " + st.t.toFixed(1) + " s";
  const nav = st.nav;
  setCell("st-task", nav.task ? nav.task.replace(/_/g, " ") : "–");
  setCell("st-status", nav.status, nav.status === "FAILED" ? "bad" : "");
  setCell("st-dist", fmt(nav.distance_remaining, " m"));
  setCell("st-eta", fmt(nav.eta, " s", 0));
  setCell("st-rec", String(nav.recoveries), nav.recoveries > 0 ? "warn" : "");
  setCell("st-wp", nav.current_waypoint === null ? "–"
    : (nav.current_waypoint + 1) + " / " + nav.waypoint_count + (nav.waypoint_name ? " (" + nav.waypoint_name + ")" : ""));
  setCell("st-reason", nav.reason || "–", nav.reason ? "warn" : "");
  $("wp-count").textContent = "(" + st.waypoints.length + ")";
  updateMission(st.mission);
  const h = st.health;
  const rate = (id, topic, low) => {
    const v = h.rates[topic];
    setCell(id, v.toFixed(1) + " Hz", v < low ? "bad" : "");
  };
  rate("h-scan", "/scan", 5);
  rate("h-odom", "/odom", 10);
  rate("h-cmd", "/cmd_vel", 0);
  setCell("h-tf", h.tf_age === null ? "unavailable" : h.tf_age.toFixed(3) + " s",
    h.tf_age === null || h.tf_age > 0.5 ? "bad" : "");
  const loc = h.localization;
  setCell("h-loc", loc ? `x ${loc.std_x.toFixed(3)} m, y ${loc.std_y.toFixed(3)} m, yaw ${loc.std_yaw.toFixed(3)} rad`
    : "n/a (no localization covariance published)");
  setCell("h-rtf", h.real_time_factor.toFixed(2) + (h.running ? "" : " (stopped)"), h.running ? "" : "bad");
  setCell("h-coll", String(h.collisions), h.collisions > 0 ? "bad" : "");
  if (h.error) message("simulation stopped: " + h.error);
  updateEstopUi();
}

function updateEstopUi() {
  const latched = !!(S.state && S.state.estop.latched);
  $("estop").classList.toggle("latched", latched);
  $("estop").textContent = latched ? "E-STOPPED" : "E-STOP";
  $("release").disabled = !(latched && S.authorized);
  $("estop-badge").classList.toggle("hidden", !latched);
  const holder = latched ? (S.state.estop.holder || "lock topic") : "";
  $("estop-badge").textContent = latched ? `E-STOP LATCHED (${holder})` : "E-STOP LATCHED";
}

// --- input ----------------------------------------------------------------------------------------------------
let press = null;

canvas.addEventListener("pointerdown", (ev) => {
  if (!S.view) return;
  press = { x: ev.offsetX, y: ev.offsetY };
  canvas.setPointerCapture(ev.pointerId);
});

canvas.addEventListener("pointerup", (ev) => {
  if (!press || !S.view) return;
  const [wx, wy] = cssToWorld(press.x, press.y);
  const dx = ev.offsetX - press.x, dy = ev.offsetY - press.y;
  const body = { x: +wx.toFixed(3), y: +wy.toFixed(3) };
  if (Math.hypot(dx, dy) > 12) body.theta = +Math.atan2(-dy, dx).toFixed(4);
  press = null;
  if (S.mode === "goal") command("POST", "/api/goal", body);
  else command("POST", "/api/waypoints", body);
});

function setMode(mode) {
  S.mode = mode;
  $("mode-goal").classList.toggle("active", mode === "goal");
  $("mode-wp").classList.toggle("active", mode === "waypoint");
  $("hint").textContent = mode === "goal" ? "click: goal · click+drag: goal with heading"
    : "click: add waypoint · then Go";
}

$("mode-goal").onclick = () => setMode("goal");
$("mode-wp").onclick = () => setMode("waypoint");
$("go").onclick = () => command("POST", "/api/waypoints/go", { mode: $("go-mode").value });
$("clear-wp").onclick = () => command("DELETE", "/api/waypoints");
$("cancel").onclick = () => command("POST", "/api/cancel");
$("estop").onclick = () => command("POST", "/api/estop", { reason: "dashboard e-stop button" });
$("release").onclick = () => command("POST", "/api/estop/release");
$("costmap").onchange = (ev) => { S.costmap = ev.target.value; markDirty(); };
for (const k of ["scan", "plan", "trail"]) {
  $("show-" + k).onchange = (ev) => { S.show[k] = ev.target.checked; markDirty(); };
}
$("token-set").onclick = async () => {
  const t = $("token-input").value.trim();
  if (await checkToken(t)) {
    S.token = t;
    sessionStorage.setItem("navstack-token", t);
    $("token-input").value = "";
    setAuthorized(true);
    message("");
  } else {
    message("token refused (HTTP 401)");
  }
};
window.addEventListener("resize", resize);

// for tests and scripting: map <-> page coordinates and the latest state
window.navstack = {
  worldToClient(x, y) {
    const r = canvas.getBoundingClientRect();
    const [px, py] = worldToCss(x, y);
    return [r.left + px, r.top + py];
  },
  clientToWorld(cx, cy) {
    const r = canvas.getBoundingClientRect();
    return cssToWorld(cx - r.left, cy - r.top);
  },
  state: () => S.state,
  ready: () => !!(S.view && S.state && S.layers.map && S.renders > 0),
  authorized: () => S.authorized,
  colors: COLORS,
};

S.dirty = false;
setMode("goal");
initToken();
connect();
