"use strict";
// The studio's page: it uses only the JSON API the README documents.
const TOKEN = new URLSearchParams(location.search).get("token") || "";
const $ = (id) => document.getElementById(id);
let options = [], state = null, info = null, imgName = "preview", mode = "look";
let view = { x: 10, y: 10, k: 1 }, fitted = false, shownVersion = -1;

async function api(method, path, body, raw) {
  const opt = { method, headers: { "Authorization": "Bearer " + TOKEN } };
  if (body !== undefined) {
    opt.body = raw ? body : JSON.stringify(body);
    opt.headers["Content-Type"] = raw ? "image/png" : "application/json";
  }
  const r = await fetch(path, opt);
  const j = await r.json().catch(() => ({ error: "HTTP " + r.status }));
  if (!r.ok) throw new Error(j.error || ("HTTP " + r.status));
  return j;
}

function setStatus(text, cls) { const s = $("status"); s.textContent = text; s.className = "status " + cls; }

// ---- controls ----------------------------------------------------------------------------------
function buildControls() {
  const groups = {};
  for (const o of options) {
    if (o.name === "threshold") continue; // the slider above
    (groups[o.group] = groups[o.group] || []).push(o);
  }
  const order = ["Size and material", "Picture", "Clean-up", "Mesh", "Bridges", "Outputs"];
  const names = Object.keys(groups).sort((a, b) => {
    const ia = order.findIndex((p) => a.startsWith(p.split(" ")[0])), ib = order.findIndex((p) => b.startsWith(p.split(" ")[0]));
    return (ia < 0 ? 99 : ia) - (ib < 0 ? 99 : ib);
  });
  const root = $("groups");
  root.innerHTML = "";
  for (const g of names) {
    const d = document.createElement("details");
    d.open = /picture|bridge|size|material|mesh/i.test(g);
    d.innerHTML = "<summary></summary>";
    d.firstChild.textContent = g;
    for (const o of groups[g]) {
      const row = document.createElement("div");
      row.className = "opt";
      const label = document.createElement("label");
      label.textContent = o.name;
      label.title = o.help;
      let input;
      if (o.kind === "flag") {
        input = document.createElement("input");
        input.type = "checkbox";
        input.onchange = () => send({ [o.name]: input.checked ? "true" : "false" });
      } else if (o.choices.length && o.kind === "value" && !o.name.includes("emit")) {
        input = document.createElement("select");
        for (const c of [""].concat(o.choices)) {
          const op = document.createElement("option");
          op.value = c; op.textContent = c || "(default)";
          input.appendChild(op);
        }
        input.onchange = () => send({ [o.name]: input.value });
      } else {
        input = document.createElement("input");
        input.placeholder = o.default.join(",") || "(none)";
        input.title = o.help + (o.kind === "list" ? "\n(repeatable: separate values with ';')" : "");
        input.onchange = () => {
          const v = input.value.trim();
          send({ [o.name]: o.kind === "list" ? (v ? v.split(";").map((s) => s.trim()) : []) : (v === "" ? "" : v) });
        };
      }
      input.id = "opt-" + o.name;
      input.dataset.name = o.name;
      label.htmlFor = input.id;
      row.append(label, input);
      d.appendChild(row);
    }
    root.appendChild(d);
  }
}

function showParams(p) {
  for (const o of options) {
    const el = $("opt-" + o.name);
    if (!el || el === document.activeElement) continue;
    const v = p[o.name];
    el.classList.remove("bad");
    if (o.kind === "flag") el.checked = v === "true";
    else if (o.kind === "list") el.value = (v || []).join("; ");
    else {
      const shown = (v === o.default.join(",")) ? "" : v;
      // A profile given by path (or one added since the page loaded) joins the list.
      if (el.tagName === "SELECT" && shown && ![...el.options].some((op) => op.value === shown)) {
        const op = document.createElement("option");
        op.value = shown; op.textContent = shown;
        el.appendChild(op);
      }
      el.value = shown;
    }
  }
}

let pending = 0;
async function send(changes) {
  setStatus("updating", "updating");
  pending++;
  try {
    const s = await api("POST", "/api/params", changes);
    show(s);
  } catch (e) {
    for (const k of Object.keys(changes)) { const el = $("opt-" + k); if (el) el.classList.add("bad"); }
    alertMsg(e.message);
    refresh();
  } finally { pending--; }
}

function alertMsg(m) {
  const r = $("report");
  const d = document.createElement("div");
  d.className = "msg"; d.textContent = m;
  r.prepend(d);
  setTimeout(() => d.remove(), 8000);
}

// ---- threshold over the histogram --------------------------------------------------------------
function drawHist() {
  const c = $("hist"), g = c.getContext("2d");
  g.clearRect(0, 0, c.width, c.height);
  if (!state || !state.histogram) return;
  const h = state.histogram, max = Math.max(...h.slice(1, 255), 1);
  g.fillStyle = "#888";
  for (let i = 0; i < 256; i++) {
    const v = Math.min(1, Math.sqrt(h[i] / max)) * c.height;
    g.fillRect(i, c.height - v, 1, v);
  }
  const mark = (x, color, dash) => { g.strokeStyle = color; g.setLineDash(dash); g.beginPath(); g.moveTo(x + .5, 0); g.lineTo(x + .5, c.height); g.stroke(); };
  mark(state.otsu, "#06c", [4, 3]);
  const lvl = state.report ? state.report.threshold_level : null;
  if (lvl !== null && lvl !== undefined) mark(lvl, "#c00", []);
}

$("threshold-slider").oninput = () => { $("level-text").textContent = "level " + $("threshold-slider").value + " (releasing applies)"; };
$("threshold-slider").onchange = () => send({ threshold: $("threshold-slider").value });
$("otsu-btn").onclick = () => send({ threshold: "otsu" });

// ---- images, zoom and pan ----------------------------------------------------------------------
function applyView() { $("layer").style.transform = `translate(${view.x}px,${view.y}px) scale(${view.k})`; }
function fit() {
  if (!state || !state.width_px) return;
  const st = $("stage"), w = state.width_px, h = state.height_px;
  view.k = Math.min((st.clientWidth - 20) / w, (st.clientHeight - 20) / h);
  view.x = (st.clientWidth - w * view.k) / 2; view.y = (st.clientHeight - h * view.k) / 2;
  applyView();
}
$("fit").onclick = fit;
function loadImages(v) {
  const q = "?token=" + TOKEN + "&v=" + v;
  $("img").src = "/api/image/" + imgName + ".png" + q;
  $("before").src = "/api/image/picture.png" + q;
}
for (const b of document.querySelectorAll("[data-img]")) b.onclick = () => {
  imgName = b.dataset.img;
  document.querySelectorAll("[data-img]").forEach((x) => x.classList.toggle("on", x === b));
  if (state) loadImages(state.shown);
};
$("compare").oninput = () => { $("before").style.clipPath = `inset(0 0 0 ${$("compare").value}%)`; };

const stage = $("stage");
stage.addEventListener("wheel", (e) => {
  e.preventDefault();
  const r = stage.getBoundingClientRect(), mx = e.clientX - r.left, my = e.clientY - r.top;
  const f = Math.exp(-e.deltaY * 0.0015), k = Math.min(64, Math.max(0.05, view.k * f));
  view.x = mx - (mx - view.x) * (k / view.k); view.y = my - (my - view.y) * (k / view.k); view.k = k;
  applyView();
}, { passive: false });

function toPx(e) { // working pixel under the pointer
  const r = stage.getBoundingClientRect();
  return [(e.clientX - r.left - view.x) / view.k, (e.clientY - r.top - view.y) / view.k];
}

let drag = null;
stage.addEventListener("pointerdown", (e) => {
  const [px, py] = toPx(e);
  drag = { x: e.clientX, y: e.clientY, vx: view.x, vy: view.y, px, py, moved: false };
  stage.setPointerCapture(e.pointerId);
  if (mode === "brush") paintAt(px, py);
});
stage.addEventListener("pointermove", (e) => {
  if (!drag) return hover(e);
  drag.moved = drag.moved || Math.abs(e.clientX - drag.x) + Math.abs(e.clientY - drag.y) > 3;
  if (mode === "look" || mode === "delete" || mode === "pin") {
    view.x = drag.vx + e.clientX - drag.x; view.y = drag.vy + e.clientY - drag.y; applyView();
  } else if (mode === "brush") { const [px, py] = toPx(e); paintAt(px, py); }
});
stage.addEventListener("pointerup", (e) => {
  const d = drag; drag = null;
  if (!d) return;
  const [px, py] = toPx(e);
  if (mode === "pin" && !d.moved && state && state.mm_per_px) {
    send_bridges({ pin: [+(px * state.mm_per_px).toFixed(3), +(py * state.mm_per_px).toFixed(3)] });
  } else if (mode === "orbit" && d.moved) {
    const named = { front: "0,0", back: "180,0", left: "-90,0", right: "90,0", side: "90,0", top: "0,90", bottom: "0,-90", "three-quarter": "30,20" };
    const cur = current("view") || "0,0";
    const v = (named[cur.trim().toLowerCase()] || cur).split(",").map(Number);
    const az = ((v[0] || 0) + (e.clientX - d.x) * 0.5) % 360, el = Math.max(-89, Math.min(89, (v[1] || 0) - (e.clientY - d.y) * 0.5));
    send({ view: az.toFixed(1) + "," + el.toFixed(1) });
  } else if (mode === "light" && state && state.width_px) {
    // Where the light is dropped on the picture is where it comes from, as a photographer says
    // it: the centre is from the camera, the left edge from the left (azimuth -90), the top edge
    // from above (elevation 90), relative to the view (make's --light AZ,EL).
    const az = Math.max(-90, Math.min(90, (px / state.width_px * 2 - 1) * 90));
    const el = Math.max(-90, Math.min(90, -(py / state.height_px * 2 - 1) * 90));
    send({ light: az.toFixed(0) + "," + el.toFixed(0) });
  }
});
function current(name) { return state && state.params ? state.params[name] : ""; }

for (const b of document.querySelectorAll("[data-mode]")) b.onclick = () => {
  mode = b.dataset.mode;
  document.querySelectorAll("[data-mode]").forEach((x) => x.classList.toggle("on", x === b));
  $("brush-tools").hidden = mode !== "brush";
  stage.style.cursor = mode === "look" ? "grab" : "crosshair";
};

// ---- bridges: hover, delete, pin ---------------------------------------------------------------
function drawOverlay() {
  const svg = $("overlay");
  svg.innerHTML = "";
  if (!state || !state.report) return;
  const r = state.report, mm = state.mm_per_px;
  svg.setAttribute("width", r.width_px); svg.setAttribute("height", r.height_px);
  svg.setAttribute("viewBox", `0 0 ${r.width_px} ${r.height_px}`);
  const NS = "http://www.w3.org/2000/svg";
  r.bridges.forEach((b, i) => {
    const p = document.createElementNS(NS, "polygon");
    p.setAttribute("points", b.polygon_px.map((q) => (q[0] + .5) + "," + (q[1] + .5)).join(" "));
    p.dataset.index = i;
    p.addEventListener("click", (e) => { if (mode === "delete") { e.stopPropagation(); send_bridges({ delete: i }); } });
    svg.appendChild(p);
  });
  for (const v of (r.check && r.check.violations) || []) {
    const c = document.createElementNS(NS, "circle");
    c.setAttribute("cx", v.x_mm / mm); c.setAttribute("cy", v.y_mm / mm); c.setAttribute("r", Math.max(4, 1.5 / mm));
    c.setAttribute("class", "violation");
    const t = document.createElementNS(NS, "title"); t.textContent = v.kind + ": " + (v.width_mm ? v.width_mm.toFixed(2) : "?") + " mm, needs " + v.required_mm + " mm"; c.appendChild(t);
    svg.appendChild(c);
  }
  for (const s of current("bridge-at") || []) {
    const [x, y] = s.split(",").map(Number);
    const c = document.createElementNS(NS, "circle");
    c.setAttribute("cx", x / mm); c.setAttribute("cy", y / mm); c.setAttribute("r", 3 / view.k + 2); c.setAttribute("class", "pin");
    svg.appendChild(c);
  }
}

function hover(e) {
  const tip = $("tip");
  const t = e.target;
  if (!(t instanceof SVGPolygonElement) || !state || !state.report) { tip.hidden = true; return; }
  const b = state.report.bridges[+t.dataset.index];
  const island = Math.max(b.nodes[0], b.nodes[1]);
  const s = state.report.strength && state.report.strength.islands.find((x) => x.island === island);
  tip.textContent = `bridge ${t.dataset.index}${b.support ? " (support)" : ""}${b.strength ? " (strength)" : ""}\n` +
    `holds island ${island} (joins ${b.nodes[0]}–${b.nodes[1]})\n` +
    `width ${b.width_mm.toFixed(2)} mm, length ${(b.length_px * state.mm_per_px).toFixed(2)} mm\n` +
    `cost ${b.cost.total.toFixed(3)} = intensity ${b.cost.intensity.toFixed(3)}\n  + length ${b.cost.length.toFixed(3)} + curvature ${b.cost.curvature.toFixed(3)}\n  + variance ${b.cost.variance.toFixed(3)}\n` +
    (s ? `island sag ${s.sag_mm.toFixed(2)} mm (limit ${s.limit_mm} mm)` : "") +
    (mode === "delete" ? "\nclick: delete" : "");
  const r = stage.getBoundingClientRect();
  tip.style.left = (e.clientX - r.left + 14) + "px"; tip.style.top = (e.clientY - r.top + 14) + "px";
  tip.hidden = false;
}

async function send_bridges(body) {
  setStatus("updating", "updating");
  try { show(await api("POST", "/api/bridges", body)); } catch (e) { alertMsg(e.message); refresh(); }
}

// ---- keep-out brush ----------------------------------------------------------------------------
function paintAt(x, y) {
  const c = $("paint"), g = c.getContext("2d");
  g.fillStyle = "#000";
  g.beginPath(); g.arc(x, y, +$("brush-r").value, 0, 2 * Math.PI); g.fill();
}
function resetPaint() {
  const c = $("paint");
  if (!state || !state.width_px) return;
  if (c.width !== state.width_px || c.height !== state.height_px) { c.width = state.width_px; c.height = state.height_px; }
}
$("brush-apply").onclick = () => {
  const c = $("paint"), out = document.createElement("canvas");
  out.width = c.width; out.height = c.height;
  const g = out.getContext("2d");
  g.fillStyle = "#fff"; g.fillRect(0, 0, out.width, out.height); g.drawImage(c, 0, 0);
  out.toBlob(async (blob) => {
    setStatus("updating", "updating");
    try { show(await api("POST", "/api/keepout", blob, true)); } catch (e) { alertMsg(e.message); }
  }, "image/png");
};
$("brush-clear").onclick = async () => {
  const c = $("paint"); c.getContext("2d").clearRect(0, 0, c.width, c.height);
  try { show(await api("POST", "/api/keepout", new Blob([]), true)); } catch (e) { alertMsg(e.message); }
};

// ---- report ------------------------------------------------------------------------------------
function esc(s) { return String(s).replace(/[&<>"]/g, (c) => ({ "&": "&amp;", "<": "&lt;", ">": "&gt;", '"': "&quot;" }[c])); }
function showReport() {
  const el = $("report");
  if (!state) return;
  let h = "";
  if (state.error) h += `<div class="msg">${esc(state.error)}</div>`;
  if (state.refused) h += `<div class="msg">make would refuse this: ${esc(state.refused)}</div>`;
  const r = state.report;
  if (r) {
    // The preview comes first; the trace's measures (fidelity, check, job time) follow.
    const f = r.fidelity || {}, s = r.strength || {}, c = r.check || {}, wait = "<i>updating</i>";
    const pct = (x) => x === undefined ? wait : x.toFixed(2) + " %";
    const rows = [
      ["changed", pct(f.changed_pct)],
      ["  clean-up removed", pct(f.cleanup_removed_pct)],
      ["  clean-up added", pct(f.cleanup_added_pct)],
      ["  bridges", pct(f.bridges_pct)],
      ["threshold level", r.threshold_level + (state.otsu !== undefined ? ` (Otsu ${state.otsu})` : "")],
      ["islands", r.islands],
      ["bridges", r.bridges.length + " (" + r.bridges.filter((b) => b.support).length + " support)"],
      ["islands needing strength bridges", s.islands_with_extra === undefined ? "–" : s.islands_with_extra + " (" + s.extra_bridges + " added)"],
      ["size", r.width_mm.toFixed(1) + " × " + r.height_mm.toFixed(1) + " mm"],
      ["working pixel", r.mm_per_px.toFixed(3) + " mm" + (r.scale_factor > 1 ? ` (×${r.scale_factor})` : "")],
      ["material", r.material],
      ["width check", !r.check ? wait : c.violations && c.violations.length ? `<span class="warn">${c.violations.length} violation(s)</span>` : '<span class="ok">passed</span>'],
      ["narrowest bridge / web / hole", [c.narrowest_bridge_mm, c.narrowest_web_mm, c.narrowest_hole_mm].map((x) => x == null ? "–" : x.toFixed(2)).join(" / ") + " mm"],
      ["job time", state.checking ? wait : r.gcode ? (r.gcode.estimate.total_s / 60).toFixed(1) + " min on " + esc(r.gcode.machine) : "– (choose a machine and emit gcode)"],
      ["computed in", state.ms.toFixed(0) + " ms: " + (state.ran || []).join(", ")],
    ];
    h += "<table>" + rows.map(([k, v]) => `<tr><td>${esc(k)}</td><td>${v}</td></tr>`).join("") + "</table>";
    if (c.violations && c.violations.length) h += "<h3>violations</h3><ul>" + c.violations.slice(0, 30).map((v) => `<li>${esc(v.kind)} at ${v.x_mm.toFixed(1)}, ${v.y_mm.toFixed(1)} mm: ${v.width_mm ? v.width_mm.toFixed(2) : "?"} of ${v.required_mm} mm</li>`).join("") + "</ul>";
  }
  h += `<div id="exported"></div>`;
  el.innerHTML = h;
}

// ---- state -------------------------------------------------------------------------------------
function show(s) {
  // A version's checked state never gives way to its own preview (answers may cross).
  if (state && s.shown === state.shown && s.checking && !state.checking) return;
  state = s;
  $("command").value = s.command;
  $("undo").disabled = !s.can_undo; $("redo").disabled = !s.can_redo;
  showParams(s.params);
  const t = s.params.threshold;
  if (/^\d+$/.test(t)) $("threshold-slider").value = t;
  $("level-text").textContent = "threshold " + t + (s.report ? " → level " + s.report.threshold_level : "");
  if (s.updating || s.checking) setStatus("updating", "updating");
  else if (s.error) setStatus("error", "error");
  else setStatus("ready", "ready");
  // The preview is loaded as soon as it is there, and again once checked (the trace may widen
  // a neck).
  const key = s.checking ? s.shown + "-preview" : String(s.shown);
  if (!s.updating && key !== shownVersion && !s.error) {
    shownVersion = key;
    loadImages(key);
    resetPaint();
    if (!fitted) { fitted = true; setTimeout(fit, 0); }
  }
  document.body.dataset.version = s.shown;
  document.body.dataset.updating = s.updating || s.checking ? "yes" : "no";
  drawHist(); drawOverlay(); showReport();
}

async function refresh() { try { show(await api("GET", "/api/state")); } catch (e) { setStatus("error", "error"); } }

$("undo").onclick = async () => { try { show(await api("POST", "/api/undo")); } catch (e) { alertMsg(e.message); } };
$("redo").onclick = async () => { try { show(await api("POST", "/api/redo")); } catch (e) { alertMsg(e.message); } };
document.addEventListener("keydown", (e) => {
  if ((e.ctrlKey || e.metaKey) && e.key.toLowerCase() === "z" && document.activeElement.tagName !== "INPUT") {
    e.preventDefault(); (e.shiftKey ? $("redo") : $("undo")).click();
  }
});
$("export").onclick = async () => {
  $("export").disabled = true;
  try {
    const r = await api("POST", "/api/export");
    const d = $("exported");
    d.innerHTML = `<h3>exported to ${esc(r.dir)}</h3><div class="files">${r.files.map(esc).join("<br>")}</div>`;
    d.dataset.files = r.files.join(",");
    $("command").value = r.command;
  } catch (e) { alertMsg(e.message); }
  $("export").disabled = false;
};
$("copy").onclick = () => { $("command").select(); (navigator.clipboard ? navigator.clipboard.writeText($("command").value) : Promise.reject()).catch(() => document.execCommand("copy")); };

async function start() {
  info = await api("GET", "/api/options");
  options = info.options;
  document.body.classList.toggle("is-mesh", /\.obj$/i.test(info.input));
  for (const b of document.querySelectorAll(".mesh")) b.hidden = !/\.obj$/i.test(info.input);
  buildControls();
  await refresh();
  const es = new EventSource("/api/events?token=" + TOKEN);
  es.addEventListener("asked", () => setStatus("updating", "updating"));
  es.addEventListener("done", () => refresh());
}
start().catch((e) => { setStatus("error", "error"); alertMsg(e.message); });
