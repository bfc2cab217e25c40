"use strict";
// The studio's page: it uses only the JSON API the README documents.
const TOKEN = new URLSearchParams(location.search).get("token") || "";
const $ = (id) => document.getElementById(id);
let options = [], state = null, info = null, imgName = "preview", mode = "look";
let view = { x: 10, y: 10, k: 1 }, fitted = false, shownVersion = -1;
// Which stencil of a set the viewer shows (1-based, in painting order, the fill-in last), or
// "composite" for the painted result; of tiles, "map" (the seams over the whole picture) or a
// tile's stencil (1-based, in cutting order, each tile's layers in painting order).
let pick = 1, pickKind = "one";

// How the page presents some of make's options (the rest are text fields with make's own help):
// a range for the picture's adjustments and the mesh's light, a list where make takes few values.
const PRESENT = {
  brightness: { range: [-100, 100, 1] }, contrast: { range: [-100, 100, 1] },
  gamma: { range: [0.2, 4, 0.05] }, smooth: { range: [0, 5, 0.1] }, abstract: { range: [0, 1, 0.05] },
  "local-threshold": { range: [0, 30, 0.5] }, ambient: { range: [0, 1, 0.05] }, fill: { range: [0, 1, 0.05] },
  rotate: { choices: ["0", "90", "180", "270"] }, up: { choices: ["Y", "Z", "X", "-Y", "-Z", "-X"] },
  layers: { choices: ["2", "3", "4", "5", "6"] }, view: { list: "view-names" },
};

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
    // The mesh's options do nothing to a picture: shown only for a mesh.
    d.hidden = /^mesh/i.test(g) && !/\.obj$/i.test(info.input);
    d.innerHTML = "<summary></summary>";
    d.firstChild.textContent = g;
    for (const o of groups[g]) {
      const row = document.createElement("div");
      row.className = "opt";
      const label = document.createElement("label");
      label.textContent = o.name;
      label.title = o.help;
      let input, box;
      const pr = PRESENT[o.name] || {};
      if (pr.range) {
        // A slider with its value beside it; releasing it applies (as the threshold's).
        input = document.createElement("input");
        input.type = "range";
        [input.min, input.max, input.step] = pr.range;
        const out = document.createElement("output");
        input.oninput = () => { out.textContent = input.value; };
        input.onchange = () => send({ [o.name]: input.value });
        input.title = o.help;
        box = document.createElement("span");
        box.className = "range";
        box.append(input, out);
      } else if (pr.choices) {
        input = document.createElement("select");
        for (const c of [""].concat(pr.choices)) {
          const op = document.createElement("option");
          op.value = c; op.textContent = c || "(" + (o.default.join(",") || "none") + ")";
          input.appendChild(op);
        }
        input.title = o.help;
        input.onchange = () => send({ [o.name]: input.value });
      } else if (o.kind === "flag") {
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
      if (pr.list) input.setAttribute("list", pr.list);
      input.id = "opt-" + o.name;
      input.dataset.name = o.name;
      label.htmlFor = input.id;
      row.append(label, box || input);
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
    else if (el.type === "range") {
      el.value = v === "" ? (o.default[0] || el.min) : v;
      el.nextSibling.textContent = el.value;
    }
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
  if (state.set) { for (const l of state.set.layers) mark(l.level, l.color, []); return; }
  if (state.otsu !== undefined) mark(state.otsu, "#06c", [4, 3]);
  const lvl = state.report ? state.report.threshold_level : null;
  if (lvl !== null && lvl !== undefined) mark(lvl, "#c00", []);
}

$("threshold-slider").oninput = () => { $("level-text").textContent = "level " + $("threshold-slider").value + " (releasing applies)"; };
$("threshold-slider").onchange = () => send({ threshold: $("threshold-slider").value });
$("otsu-btn").onclick = () => send({ threshold: "otsu" });
$("auto-btn").onclick = () => send({ threshold: "auto" });

// ---- images, zoom and pan ----------------------------------------------------------------------
function applyView() { $("layer").style.transform = `translate(${view.x}px,${view.y}px) scale(${view.k})`; }
// The shown image's size in its own pixels: the working image, or the composite (the picture's
// size, without the marks' band).
function shownSize() {
  if (state && state.set && pick === "composite") return state.composite_px;
  if (state && state.tiles && pick !== "map") return [state.report.width_px, state.report.height_px];
  return [state.width_px, state.height_px];
}
function fit() {
  if (!state || !state.width_px) return;
  const st = $("stage"), [w, h] = shownSize();
  view.k = Math.min((st.clientWidth - 20) / w, (st.clientHeight - 20) / h);
  view.x = (st.clientWidth - w * view.k) / 2; view.y = (st.clientHeight - h * view.k) / 2;
  applyView();
}
$("fit").onclick = fit;
function loadImages(v) {
  const q = "?token=" + TOKEN + "&v=" + v;
  const set = state && state.set, comp = set && pick === "composite";
  // Tiles: the map (make's tiles.png, smaller than the working picture) is stretched over the
  // whole picture's working pixels, where the seams are drawn.
  const tiles = state && state.tiles, map = tiles && pick === "map";
  const pre = set && !comp ? "s" + pick + "-" : tiles && !map ? "t" + pick + "-" : "";
  $("img").src = "/api/image/" + (comp ? "composite" : map ? "tiles" : pre + imgName) + ".png" + q;
  $("img").style.width = map ? state.width_px + "px" : "";
  $("img").style.height = map ? state.height_px + "px" : "";
  $("before").hidden = comp || map;
  if (!comp && !map) $("before").src = "/api/image/" + pre + "picture.png" + q;
}

// A set: the selector lists its stencils and the composite; the report and the overlay follow
// the stencil shown.
function showPick() {
  const sel = $("layer-pick"), set = state && state.set, tiles = state && state.tiles;
  $("layer-pick-box").hidden = !set && !tiles;
  // A new kind of result (one stencil, a set, tiles) shows its first view: tiles their map.
  const kind = tiles ? "tiles" : set ? "set" : "one";
  if (kind !== pickKind) { pickKind = kind; pick = tiles ? "map" : 1; setTimeout(fit, 0); }
  if (tiles) return showTilePick(sel, tiles);
  if (!set) { pick = 1; return; }
  const names = set.layers.map((l) => `layer ${l.layer} (level ${l.level}, ${l.color})`);
  if (set.fill_in) names.push("fill-in");
  const n = names.length;
  if (pick !== "composite" && !(pick >= 1 && pick <= n)) pick = 1;
  const want = names.map((t, i) => [String(i + 1), t]).concat([["composite", "composite (painted)"]]);
  setChoices(sel, want);
  state.report = state.layer_reports[pick === "composite" ? 0 : pick - 1];
}
function setChoices(sel, want) {
  if (sel.options.length !== want.length || [...sel.options].some((o, i) => o.textContent !== want[i][1])) {
    sel.innerHTML = "";
    for (const [v, t] of want) { const o = document.createElement("option"); o.value = v; o.textContent = t; sel.appendChild(o); }
  }
  sel.value = String(pick);
}
// Tiles: the map of the seams, or one tile's stencil (each of its layers, with layers).
function showTilePick(sel, tiles) {
  const names = [];
  for (const t of tiles.tiles) {
    const at = `tile ${t.number} (row ${t.row}, column ${t.col})`;
    if (t.layers.length) for (const l of t.layers) names.push(at + ` layer ${l.layer}`);
    else names.push(at);
  }
  if (pick !== "map" && !(pick >= 1 && pick <= names.length)) pick = "map";
  setChoices(sel, [["map", "tiles: drag a seam's handle to move it"]].concat(names.map((t, i) => [String(i + 1), t])));
  state.report = state.tile_reports[pick === "map" ? 0 : pick - 1];
}
$("layer-pick").onchange = () => {
  const v = $("layer-pick").value;
  pick = v === "composite" || v === "map" ? v : +v;
  if (state) { showPick(); loadImages(state.shown); setTimeout(fit, 0); drawOverlay(); showReport(); }
};
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
  // A seam's handle (tiles, on the map) is dragged whatever the mode.
  const seam = e.target.dataset && e.target.dataset.seam !== undefined ? +e.target.dataset.seam : null;
  drag = { x: e.clientX, y: e.clientY, vx: view.x, vy: view.y, px, py, moved: false, seam };
  stage.setPointerCapture(e.pointerId);
  if (mode === "brush" && seam === null) paintAt(px, py);
});

// The crop rectangle dragged on the shown picture, in mm of the whole picture as make's --crop
// takes it: the shown frame is the current crop turned by --rotate, so the corners are turned
// back and the current crop's corner added.
function cropFrom(a, b) {
  const mm = state.mm_per_px, W = state.width_px * mm, H = state.height_px * mm;
  const q = (+(current("rotate") || "0") / 90) % 4;
  const [cw, ch] = q % 2 ? [H, W] : [W, H];
  const back = ([u, v]) => [[u, v], [v, ch - u], [cw - u, ch - v], [cw - v, u]][q];
  const [x1, y1] = back([a[0] * mm, a[1] * mm]), [x2, y2] = back([b[0] * mm, b[1] * mm]);
  const c = (current("crop") || "").split(",").map(Number);
  const [ox, oy] = c.length === 4 ? [c[0], c[1]] : [0, 0];
  const r = (v) => +v.toFixed(2);
  return [ox + Math.min(x1, x2), oy + Math.min(y1, y2), Math.abs(x2 - x1), Math.abs(y2 - y1)].map(r).join(",");
}
function showCropBox(d, e) {
  const b = $("crop-box");
  if (!d) { b.hidden = true; return; }
  const [px, py] = toPx(e);
  b.hidden = false;
  Object.assign(b.style, { left: Math.min(px, d.px) + "px", top: Math.min(py, d.py) + "px", width: Math.abs(px - d.px) + "px", height: Math.abs(py - d.py) + "px", borderWidth: 2 / view.k + "px" });
}
stage.addEventListener("pointermove", (e) => {
  if (!drag) return hover(e);
  drag.moved = drag.moved || Math.abs(e.clientX - drag.x) + Math.abs(e.clientY - drag.y) > 3;
  if (drag.seam !== null) moveSeamLine(drag.seam, toPx(e));
  else if (mode === "look" || mode === "delete" || mode === "pin") {
    view.x = drag.vx + e.clientX - drag.x; view.y = drag.vy + e.clientY - drag.y; applyView();
  } else if (mode === "brush") { const [px, py] = toPx(e); paintAt(px, py); }
  else if (mode === "crop") showCropBox(drag, e);
});
stage.addEventListener("pointerup", (e) => {
  const d = drag; drag = null;
  if (!d) return;
  const [px, py] = toPx(e);
  if (d.seam !== null) {
    if (d.moved) send(seamMoved(d.seam, [px, py]));
  } else if (mode === "crop") {
    showCropBox(null);
    if (d.moved && state && state.mm_per_px && !state.set) send({ crop: cropFrom([d.px, d.py], [px, py]) });
    else if (state && state.set) alertMsg("crop the picture with one stencil shown, or type the crop (mm) in Picture");
  } else if (mode === "delete" && !d.moved) {
    // The bridge under the pointer, found here: the stage captured the pointer on the way down,
    // so the click lands on the stage, never on the bridge's own shape.
    const hit = document.elementsFromPoint(e.clientX, e.clientY)
      .find((el) => el.closest("#overlay") && el.dataset.index !== undefined);
    if (hit) send_bridges({ delete: +hit.dataset.index });
  } else if (mode === "pin" && !d.moved && state && state.mm_per_px) {
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
$("uncrop").onclick = () => send({ crop: "" });
function current(name) { return state && state.params ? state.params[name] : ""; }

for (const b of document.querySelectorAll("[data-mode]")) b.onclick = () => {
  if (state && (state.set || state.tiles) && ["delete", "pin", "brush"].includes(b.dataset.mode)) {
    alertMsg(state.set ? "a set's bridges are chosen per layer: keep them away with no-bridge-near discs (Bridges)"
      : "tiles' bridges are chosen per tile: keep them away with no-bridge-near discs (Bridges)");
    return;
  }
  mode = b.dataset.mode;
  document.querySelectorAll("[data-mode]").forEach((x) => x.classList.toggle("on", x === b));
  $("brush-tools").hidden = mode !== "brush";
  stage.style.cursor = mode === "look" ? "grab" : "crosshair";
};

// ---- tiles: the seams, their handles, the tiles' numbers ----------------------------------------
// Each seam's path (make's, in working pixels of the whole picture), its straight line dashed
// with a handle in its middle, and each tile's number at the middle of its box.
function drawSeams(svg) {
  const NS = "http://www.w3.org/2000/svg", W = state.width_px, H = state.height_px, mm = state.mm_per_px;
  svg.setAttribute("width", W); svg.setAttribute("height", H);
  svg.setAttribute("viewBox", `0 0 ${W} ${H}`);
  const el = (name, attrs, cls) => {
    const x = document.createElementNS(NS, name);
    for (const [k, v] of Object.entries(attrs)) x.setAttribute(k, v);
    x.setAttribute("class", cls); svg.appendChild(x); return x;
  };
  state.tiles.seams.forEach((s, i) => {
    const vertical = s.axis === "vertical", at = (s.at_mm + state.tiles.marks_band_mm) / mm;
    el("polyline", { points: s.points_px.map((q) => q[0] + "," + q[1]).join(" ") }, "seam").dataset.index = i;
    const line = vertical ? { x1: at, y1: 0, x2: at, y2: H } : { x1: 0, y1: at, x2: W, y2: at };
    el("line", line, "seam-line").id = "seam-line-" + i;
    const h = el("circle", { cx: vertical ? at : W / 2, cy: vertical ? H / 2 : at, r: 8 / view.k + 4 }, "seam-handle");
    h.id = "seam-handle-" + i; h.dataset.seam = i; h.style.cursor = vertical ? "ew-resize" : "ns-resize";
    const t = document.createElementNS(NS, "title");
    t.textContent = `${s.axis} seam at ${s.at_mm.toFixed(1)} mm (it wanders up to ${s.band_mm.toFixed(1)} mm each way): drag to move`;
    h.appendChild(t);
  });
  // Near the top of each tile's box (the map numbers its middle): its number in cutting order.
  for (const t of state.tiles.tiles) {
    const [x, y, w, h] = t.box_px, size = Math.max(8, Math.min(w, h) / 12);
    el("text", { x: x + w / 2, y: y + 1.5 * size, "font-size": size }, "tile-number").textContent = `tile ${t.number}`;
  }
}
// While a seam's handle is dragged: its straight line and handle follow the pointer.
function moveSeamLine(i, [px, py]) {
  const s = state.tiles.seams[i], vertical = s.axis === "vertical";
  const line = $("seam-line-" + i), h = $("seam-handle-" + i);
  if (!line || !h) return;
  if (vertical) { line.setAttribute("x1", px); line.setAttribute("x2", px); h.setAttribute("cx", px); }
  else { line.setAttribute("y1", py); line.setAttribute("y2", py); h.setAttribute("cy", py); }
}
// The change a seam dropped at a working pixel asks for: every seam along that axis at its
// straight line, the moved one at the new place (make's --seam-x / --seam-y, mm).
function seamMoved(i, [px, py]) {
  const s = state.tiles.seams[i], vertical = s.axis === "vertical", mm = state.mm_per_px;
  const size = (vertical ? state.width_px : state.height_px) * mm;
  // The map is the picture grown by the marks' band; the seam options are on the picture.
  const band = state.tiles.marks_band_mm, to = Math.max(0, Math.min(size - 2 * band, (vertical ? px : py) * mm - band));
  const places = state.tiles.seams.map((t, k) => [t, k]).filter(([t]) => t.axis === s.axis)
    .map(([t, k]) => +(k === i ? to : t.at_mm).toFixed(1));
  return { [vertical ? "seam-x" : "seam-y"]: places.join(",") };
}

// ---- bridges: hover, delete, pin ---------------------------------------------------------------
function drawOverlay() {
  const svg = $("overlay");
  svg.innerHTML = "";
  // The tip described a bridge of the result just replaced: hidden until the pointer moves again.
  $("tip").hidden = true;
  if (state && state.tiles && pick === "map") return drawSeams(svg);
  if (!state || !state.report || (state.set && pick === "composite")) return;
  const r = state.report, mm = state.mm_per_px;
  svg.setAttribute("width", r.width_px); svg.setAttribute("height", r.height_px);
  svg.setAttribute("viewBox", `0 0 ${r.width_px} ${r.height_px}`);
  const NS = "http://www.w3.org/2000/svg";
  r.bridges.forEach((b, i) => {
    const p = document.createElementNS(NS, "polygon");
    p.setAttribute("points", b.polygon_px.map((q) => (q[0] + .5) + "," + (q[1] + .5)).join(" "));
    p.dataset.index = i;
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
  // Saved at the picture's pixels in the stencil's frame (cropped and turned; make stretches a
  // keep-out picture over the working image), so it is never taken for the whole picture's frame.
  const c = $("paint"), out = document.createElement("canvas"), f = (state && state.report && state.report.scale_factor) || 1;
  out.width = Math.max(1, Math.round(c.width / f)); out.height = Math.max(1, Math.round(c.height / f));
  const g = out.getContext("2d");
  g.fillStyle = "#fff"; g.fillRect(0, 0, out.width, out.height); g.drawImage(c, 0, 0, out.width, out.height);
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
  if (state.notice) h += `<div class="msg">${esc(state.notice)}</div>`;
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
      ["likeness", r.likeness == null ? "–" : r.likeness.toFixed(3)],
      ["islands", r.islands],
      ["islands dropped (yellow)", r.dropped_islands ? r.dropped_islands.length + " (" + r.dropped_islands.reduce((a, d) => a + d.area_mm2, 0).toFixed(1) + " mm²)" : "0" + (current("keep-all-islands") === "true" ? " (keep-all-islands)" : "")],
      ["bridges", r.bridges.length + " (" + r.bridges.filter((b) => b.support).length + " support)"],
      ["islands needing strength bridges", s.islands_with_extra === undefined ? "–" : s.islands_with_extra + " (" + s.extra_bridges + " added)"],
      ["size", r.width_mm.toFixed(1) + " × " + r.height_mm.toFixed(1) + " mm"],
      ["working pixel", r.mm_per_px.toFixed(3) + " mm" + (r.scale_factor > 1 ? ` (×${r.scale_factor})` : "")],
      ["material", r.material],
      ["width check", !r.check ? wait : c.violations && c.violations.length ? `<span class="warn">${c.violations.length} violation(s)</span>` : '<span class="ok">passed</span>'],
      ["narrowest bridge / web / hole", [c.narrowest_bridge_mm, c.narrowest_web_mm, c.narrowest_hole_mm].map((x) => x == null ? "–" : x.toFixed(2)).join(" / ") + " mm"],
      ["job time", state.checking ? wait : r.gcode ? (r.gcode.estimate.total_s / 60).toFixed(1) + " min on " + esc(r.gcode.machine) : "– (choose a machine and emit gcode)"],
      ["planner fed", !r.gcode ? "–" : !r.gcode.feeding ? '<span class="ok">yes</span>' : r.gcode.feeding.still.length ? `<span class="warn">starves in ${r.gcode.feeding.still.length} place(s) at ${r.gcode.feeding.baud} baud (lines ${r.gcode.feeding.still[0].first_line}-${r.gcode.feeding.still[0].last_line} first)</span>` : `feed lowered in ${r.gcode.feeding.slowed.length} place(s) (lines ${r.gcode.feeding.slowed[0].first_line}-${r.gcode.feeding.slowed[0].last_line} first, ${r.gcode.feeding.slowed[0].now_mm_min} mm/min): the serial line keeps up`],
      ["computed in", state.ms.toFixed(0) + " ms: " + (state.ran || []).join(", ")],
    ];
    if (state.set) {
      const st = state.set, cp = st.composite;
      h += `<h3>set: ${st.layers.length} layer(s), ${esc(st.method)}, surface <i class="swatch" style="background:${esc(st.surface_color)}"></i></h3><table class="layers"><tr><td>layer</td><td>level</td><td>cut %</td><td>bridges</td><td>hidden %</td></tr>` +
        st.layers.map((l) => `<tr><td><i class="swatch" style="background:${esc(l.color)}"></i> ${esc(l.folder || ".")}</td><td>${l.level}</td><td>${l.cut_pct.toFixed(1)}</td><td>${l.bridges}</td><td>${l.hidden_pct.toFixed(0)}${l.check_passed ? "" : ' <span class="warn">check failed</span>'}</td></tr>`).join("") + "</table>" +
        `<table><tr><td>composite likeness</td><td>${cp.likeness.toFixed(3)} (posterised ${cp.posterised_likeness.toFixed(3)})</td></tr><tr><td>painted in its tone</td><td>${cp.tone_agreement_pct.toFixed(1)} %</td></tr>` +
        (st.fill_in ? `<tr><td>fill-in paints</td><td>${st.fill_in.covered_pct.toFixed(1)} % of the bridges</td></tr>` : "") + "</table>" +
        `<h3>${pick === "composite" ? "layer 1" : esc(pick > st.layers.length ? "fill-in" : "layer " + pick)}</h3>`;
    }
    if (state.tiles) {
      const ti = state.tiles;
      h += `<h3>tiles: ${ti.grid[0]} × ${ti.grid[1]}, ${ti.width_mm.toFixed(0)} × ${ti.height_mm.toFixed(0)} mm, overlap ${ti.overlap_mm} mm</h3><table class="layers"><tr><td>tile</td><td>place (mm)</td><td>sheet (mm)</td><td>bridges</td></tr>` +
        ti.tiles.map((t) => `<tr><td>${t.number}: ${esc(t.folder)}</td><td>${t.x_mm.toFixed(0)}, ${t.y_mm.toFixed(0)}</td><td>${t.sheet_mm[0].toFixed(0)} × ${t.sheet_mm[1].toFixed(0)}</td><td>${t.bridges}${t.check_passed ? "" : ' <span class="warn">check failed</span>'}</td></tr>`).join("") + "</table>" +
        "<table>" + ti.seams.map((m) => `<tr><td>${m.axis} seam at ${m.at_mm.toFixed(1)} mm</td><td>${m.length_mm.toFixed(0)} mm, ${m.through_cut_mm.toFixed(1)} mm through the cut</td></tr>`).join("") + "</table>" +
        `<h3>${pick === "map" ? "tile 1" : "tile stencil " + pick}</h3>`;
    }
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
  showPick();
  const t = s.params.threshold, lvl = s.report ? s.report.threshold_level : null;
  // The slider shows the level used, whichever way it was chosen (a number, otsu or auto).
  if (/^\d+$/.test(t)) $("threshold-slider").value = t;
  else if (lvl != null) $("threshold-slider").value = lvl;
  $("level-text").textContent = s.set ? "levels " + s.set.layers.map((l) => l.level).join(", ") : "threshold " + (t || "by picture") + (lvl != null ? " → level " + lvl : "");
  const ch = s.report && s.report.threshold_choice;
  $("choice-text").textContent = ch ? `auto: likeness ${ch.likeness.toFixed(3)}; at 128 ${ch.likeness_128.toFixed(3)}, at Otsu's ${ch.otsu_level} ${ch.likeness_otsu.toFixed(3)}` : "";
  document.body.dataset.set = s.set ? s.set.layers.length + (s.set.fill_in ? 1 : 0) : "";
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
  for (const b of document.querySelectorAll(".picture")) b.hidden = /\.obj$/i.test(info.input);
  buildControls();
  await refresh();
  const es = new EventSource("/api/events?token=" + TOKEN);
  es.addEventListener("asked", () => setStatus("updating", "updating"));
  es.addEventListener("done", () => refresh());
}
start().catch((e) => { setStatus("error", "error"); alertMsg(e.message); });
