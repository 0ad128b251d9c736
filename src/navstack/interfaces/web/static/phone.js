// navstack phone page: sends the browser's Geolocation fixes (watchPosition) to
// /api/phone/location, "Come to me" drives the robot to the last fix, STOP sends the
// message "Stop" (e-stop), Release releases an e-stop this phone latched.  The token comes
// in the URL fragment (#token=..., never sent to the server) and stays in sessionStorage.
"use strict";
const $ = (id) => document.getElementById(id);
const P = { token: null, last: null, lastPos: null, sent: 0, lastSent: 0, watch: null, status: null };

function readToken() {
  const m = /(?:^|[#&])token=([^&]+)/.exec(location.hash);
  if (m) {
    sessionStorage.setItem("navstack-token", decodeURIComponent(m[1]));
    history.replaceState(null, "", location.pathname);
  }
  return sessionStorage.getItem("navstack-token");
}

function message(text) { $("msg").textContent = text; }

async function call(method, path, body) {
  const opts = { method, headers: { Authorization: "Bearer " + P.token } };
  if (body !== undefined) {
    opts.headers["Content-Type"] = "application/json";
    opts.body = JSON.stringify(body);
  }
  const r = await fetch(path, opts);
  let data = {};
  try { data = await r.json(); } catch (e) { /* empty body */ }
  if (!r.ok) message(`${path}: HTTP ${r.status} ${data.error || ""}`);
  return { status: r.status, data };
}

function fix(pos) {
  const c = pos.coords;
  const f = { lat: c.latitude, lon: c.longitude, accuracy: Math.max(c.accuracy, 0.01) };
  if (c.altitude !== null && c.altitude !== undefined) f.alt = c.altitude;
  if (c.altitudeAccuracy) f.altitude_accuracy = c.altitudeAccuracy;
  return f;
}

async function send(pos, force) {
  P.lastPos = pos;
  P.last = fix(pos);
  $("pos").textContent = `${P.last.lat.toFixed(6)}, ${P.last.lon.toFixed(6)} ` +
    `(±${P.last.accuracy.toFixed(0)} m)`;
  const now = Date.now();
  if (!force && now - P.lastSent < 1000) return;  // at most one fix per second
  P.lastSent = now;
  const r = await call("POST", "/api/phone/location", P.last);
  if (r.status === 200) $("sent").textContent = String(++P.sent);
}

function position() {
  // the newest fix of the running watch if there is one (a second request may not get a
  // fresh fix while the position has not changed), else ask for one
  if (P.lastPos && Date.now() - P.lastPos.timestamp < 10000) return Promise.resolve(P.lastPos);
  return new Promise((resolve, reject) => navigator.geolocation.getCurrentPosition(
    resolve, reject, { enableHighAccuracy: true, maximumAge: 5000, timeout: 20000 }));
}

$("share").onclick = () => {
  if (P.watch !== null) return;
  P.watch = navigator.geolocation.watchPosition((p) => send(p, false),
    (e) => message("location: " + e.message),
    { enableHighAccuracy: true, maximumAge: 0, timeout: 20000 });
  $("share").textContent = "Sharing my location";
};

$("come").onclick = async () => {
  try {
    await send(await position(), true);
  } catch (e) {
    message("location: " + e.message);
    return;
  }
  const r = await call("POST", "/api/phone/come", {});
  if (r.status === 200) message(`coming to ${r.data.target.map((v) => v.toFixed(1)).join(", ")}`);
};

$("stop").onclick = () => call("POST", "/api/phone/message", { text: "Stop" });
$("release").onclick = () => call("POST", "/api/phone/release", {});

async function poll() {
  try {
    const r = await fetch("/api/state");
    if (r.ok) {
      const s = await r.json();
      P.status = s;
      $("nav").textContent = s.nav ? `${s.nav.status}` +
        (s.nav.distance_remaining !== null ? ` · ${s.nav.distance_remaining.toFixed(1)} m` : "") : "–";
      $("estop-state").textContent = s.estop.latched ?
        `LATCHED (${s.estop.holder || "lock topic"})` : "released";
    }
  } catch (e) { /* server gone: keep the last view */ }
}

P.token = readToken();
$("access").textContent = P.token ? "token set" : "no token: open the URL with #token=...";
$("access").className = "badge " + (P.token ? "good" : "warn");
setInterval(poll, 1000);
poll();
window.navstackPhone = { sent: () => P.sent, last: () => P.last, state: () => P.status };
