// trace.html's script: draws the data of refsoft/viewer/data.py (embedded as JSON in the page).
// Plain canvas and SVG, no library, nothing fetched.
"use strict";
(function () {
  const D = JSON.parse(document.getElementById("trace-data").textContent);
  const RAMP = [[68, 1, 84], [59, 82, 139], [33, 145, 140], [94, 201, 98], [253, 231, 37]];  // viridis
  const PATH = {standard: "#ffffff", inverse: "#00e6ff", linear: "#ffffff", bisection: "#ff8c00",
                popped: "#ffffff", chosen: "#ff3030"};
  const $ = (id) => document.getElementById(id);
  const n = D.steps.length;
  let cur = 0, hoverPix = null, timer = null;

  // --- heat maps: each grid's colours once, at one canvas pixel per grid pixel ---
  function transform(g, v) {
    if (v === null) return null;
    if (g.transform === "nines") return Math.max(0, -Math.log10(Math.min(2, Math.max(1e-7, 1 - v))));
    return v;
  }
  function ramp(t) {
    const x = Math.min(1, Math.max(0, t)) * (RAMP.length - 1);
    const i = Math.min(Math.floor(x), RAMP.length - 2), f = x - i;
    return RAMP[i].map((a, k) => Math.round((1 - f) * a + f * RAMP[i + 1][k]));
  }
  const layers = D.grids.map((g) => {
    const t = g.values.map((v) => transform(g, v));
    const fin = t.filter((v) => v !== null);
    const lo = g.transform === "nines" ? 0 : (fin.length ? Math.min(...fin) : 0);
    const hi = fin.length ? Math.max(...fin) : 1;
    const c = document.createElement("canvas");
    c.width = g.w; c.height = g.h;
    const ctx = c.getContext("2d"), img = ctx.createImageData(g.w, g.h);
    t.forEach((v, i) => {
      const rgb = v === null ? [40, 40, 46] : ramp((v - lo) / Math.max(hi - lo, 1e-12));
      img.data.set([rgb[0], rgb[1], rgb[2], 255], 4 * i);
    });
    ctx.putImageData(img, 0, 0);
    return {canvas: c, lo: lo, hi: hi};
  });

  const heat = $("heat"), hctx = heat.getContext("2d");
  const SIZE = 520;
  function zoomOf(g) { return Math.max(1, Math.floor(SIZE / Math.max(g.w, g.h))); }
  // the map shown: the current step's own, or the one picked in the menu (several maps)
  let picked = -1;
  function gridOf(k) { return D.grids.length ? D.grids[picked >= 0 ? picked : (n ? D.steps[k].grid : 0)] : null; }
  function centre(g, z, pix) { return [(pix[1] - g.c0 + 0.5) * z, (pix[0] - g.r0 + 0.5) * z]; }
  function box(ctx, g, z, pix, colour, w, rect) {
    ctx.strokeStyle = colour; ctx.lineWidth = w;
    if (rect) { ctx.strokeRect((rect[1] - g.c0) * z, (rect[0] - g.r0) * z, rect[3] * z, rect[2] * z); return; }
    const [x, y] = centre(g, z, pix), h = Math.max(z / 2, 4);
    ctx.strokeRect(x - h, y - h, 2 * h, 2 * h);
  }

  function drawHeat() {
    const g = gridOf(cur);
    if (!g) { heat.width = 300; heat.height = 40; hctx.fillText("no heat map: nothing was searched", 10, 20); return; }
    const z = zoomOf(g), li = D.grids.indexOf(g);
    heat.width = g.w * z; heat.height = g.h * z;
    hctx.imageSmoothingEnabled = false;
    hctx.drawImage(layers[li].canvas, 0, 0, heat.width, heat.height);
    // the path so far on this grid
    hctx.lineWidth = 2;
    for (let k = 1; k <= cur && D.kind !== "hierarchy"; k++) {
      const a = D.steps[k - 1], b = D.steps[k];
      // an LDT face's texels are its own; the walk's maps share the G-buffer's pixels
      if (D.kind === "ldt" && (D.grids[a.grid] !== g || D.grids[b.grid] !== g)) continue;
      hctx.strokeStyle = PATH[b.phase] || "#ffffff";
      hctx.beginPath(); hctx.moveTo(...centre(g, z, a.pixel)); hctx.lineTo(...centre(g, z, b.pixel)); hctx.stroke();
    }
    if (D.kind === "hierarchy") {
      for (let k = 0; k < cur; k++) box(hctx, g, z, null, "rgba(255,255,255,0.35)", 1, D.steps[k].rect);
    }
    D.images.forEach((p) => { const [x, y] = centre(g, z, p); hctx.strokeStyle = "#ff66ff"; hctx.lineWidth = 2;
      hctx.beginPath(); hctx.arc(x, y, Math.max(z, 6), 0, 2 * Math.PI); hctx.stroke(); });
    if (D.kind !== "ldt" || D.grids[D.steps[0] ? D.steps[0].grid : 0] === g) { hctx.fillStyle = "#28dc3c"; const [x, y] = centre(g, z, D.start);
      hctx.fillRect(x - 4, y - 4, 9, 9); }
    if (cur === n - 1) { hctx.fillStyle = "#e61e1e"; const [x, y] = centre(g, z, D.end); hctx.fillRect(x - 4, y - 4, 9, 9); }
    if (n && (D.kind !== "ldt" || D.grids[D.steps[cur].grid] === g)) {  // the step's marks, on its own map
      const s = D.steps[cur];
      s.cells.forEach((c, i) => { if (c.status !== "outside" && c.status !== "uncovered" || c.rect)
        box(hctx, g, z, c.pixel, i === s.chosen ? "#ff8c00" : c.status === "rejected" ? "#999999" : "#ffdc00",
            i === s.chosen ? 3 : 1.5, c.rect); });
      box(hctx, g, z, s.pixel, "#ffffff", 2, s.rect);
    }
    if (hoverPix) box(hctx, g, z, hoverPix, "#ff00ff", 3, null);
    $("heat-title").textContent = g.title;
    drawTicks(g, z);
    drawBar(g, layers[li]);
  }

  // about n round values in [lo, hi] (as the PNG's axes)
  function ticks(lo, hi, k) {
    const raw = Math.max(hi - lo, 1e-12) / k, p = Math.pow(10, Math.floor(Math.log10(raw)));
    const step = p * [1, 2, 5, 10].find((m) => raw <= m * p), out = [];
    for (let v = Math.ceil(lo / step) * step; v <= hi + 1e-9; v += step) out.push(v);
    return out;
  }
  function drawTicks(g, z) {
    const hb = $("heat-box");
    hb.querySelectorAll(".tick, .axis").forEach((e) => e.remove());
    const put = (cls, text, x, y) => { const e = document.createElement("span"); e.className = cls;
      e.textContent = text; e.style.left = x + "px"; e.style.top = y + "px"; hb.appendChild(e); return e; };
    // the canvas sits 40 px from the box's left and 18 px from its top (the style's padding)
    ticks(g.r0, g.r0 + g.h - 1, 5).forEach((r) => put("tick", r, 2, 18 + (r - g.r0 + 0.5) * z - 7));
    ticks(g.c0, g.c0 + g.w - 1, 5).forEach((c) => put("tick", c, 40 + (c - g.c0 + 0.5) * z - 8, 18 + g.h * z + 3));
    const unit = D.kind === "ldt" ? "texel" : "pixel";
    put("axis", `row (${unit})`, 2, 0);
    put("axis", `column (${unit})`, 40 + g.w * z / 2 - 40, 18 + g.h * z + 16);
  }

  function drawBar(g, L) {
    const bar = $("bar"), ctx = bar.getContext("2d");
    bar.width = 520; bar.height = 46;
    ctx.clearRect(0, 0, bar.width, bar.height);
    $("formula").textContent = g.formula;
    if (g.empty) {  // nothing to scale: no colour bar
      ctx.fillStyle = "rgb(40,40,46)"; ctx.fillRect(30, 4, 460, 16);
      $("bar-label").textContent = D.kind === "ldt" ? "no texel of this face covered (all dark grey)" :
        "no pixel covered (all dark grey)";
      return;
    }
    for (let x = 0; x < 460; x++) { const c = ramp(x / 459); ctx.fillStyle = `rgb(${c[0]},${c[1]},${c[2]})`;
      ctx.fillRect(30 + x, 4, 1, 16); }
    ctx.fillStyle = "#222"; ctx.font = "13px sans-serif"; ctx.textAlign = "center";
    for (let i = 0; i <= 4; i++) { const x = 30 + 459 * i / 4; ctx.fillRect(x, 20, 1, 5);
      ctx.fillText((L.lo + (L.hi - L.lo) * i / 4).toPrecision(3), x, 38); }
    $("bar-label").textContent = g.label + " (uncovered: dark grey)";
  }

  // --- the side view (SVG) ---
  const SVG = "http://www.w3.org/2000/svg";
  function el(tag, attrs, parent) { const e = document.createElementNS(SVG, tag);
    for (const k in attrs) e.setAttribute(k, attrs[k]); parent.appendChild(e); return e; }
  function drawSide() {
    const sv = $("side"); sv.innerHTML = "";
    const S = D.side, pts = S.points.filter((p) => !p.far).map((p) => p.xy);
    D.steps.forEach((s) => { if (s.side) pts.push(s.side.xy); });
    // a far point (an eye much farther than the rest) sits at the edge, in its direction from P
    const near = Math.max(...pts.map((p) => Math.hypot(p[0], p[1])), 1e-9);
    const at = (p) => p.far ? p.xy.map((v) => v * 1.1 * near / Math.hypot(p.xy[0], p.xy[1])) : p.xy;
    S.points.forEach((p) => { if (p.far) pts.push(at(p)); });
    const xs = pts.map((p) => p[0]), ys = pts.map((p) => p[1]);
    let x0 = Math.min(...xs), x1 = Math.max(...xs), y0 = Math.min(...ys), y1 = Math.max(...ys);
    const ext = Math.max(x1 - x0, y1 - y0, 1e-9), pad = 0.12 * ext;
    x0 -= pad; x1 += pad + 0.3 * ext; y0 -= pad; y1 += pad;  // room on the right for the labels
    const W = 420, sc = W / Math.max(x1 - x0, y1 - y0);
    const H = Math.max(160, (y1 - y0) * sc);
    sv.setAttribute("viewBox", `0 0 ${W} ${H}`); sv.setAttribute("width", W); sv.setAttribute("height", H);
    const X = (p) => (p[0] - x0) * sc, Y = (p) => H - (p[1] - y0) * sc, len = 0.18 * ext;
    el("defs", {}, sv).innerHTML = '<marker id="ah" viewBox="0 0 10 10" refX="9" refY="5" markerWidth="7" ' +
      'markerHeight="7" orient="auto-start-reverse"><path d="M0,0L10,5L0,10z" fill="context-stroke"/></marker>';
    if (S.line) el("line", {x1: X(S.line[0]), y1: Y(S.line[0]), x2: X(S.line[1]), y2: Y(S.line[1]),
                            stroke: "#999", "stroke-dasharray": "4 3"}, sv);
    const farOf = (xy) => { const p = S.points.find((q) => q.far && q.xy[0] === xy[0] && q.xy[1] === xy[1]);
      return p ? at(p) : xy; };
    S.rays.forEach((r) => { const a = farOf(r[0]), b = farOf(r[1]);
      el("line", {x1: X(a), y1: Y(a), x2: X(b), y2: Y(b), stroke: "#555"}, sv); });
    const colours = ["#1f77b4", "#d62728"];
    S.arrows.forEach((a, i) => { const e = [a.from[0] + len * a.dir[0], a.from[1] + len * a.dir[1]];
      el("line", {x1: X(a.from), y1: Y(a.from), x2: X(e), y2: Y(e), stroke: colours[i % 2], "stroke-width": 2,
                  "marker-end": "url(#ah)"}, sv);
      el("text", {x: X(e) + 6, y: Y(e) + 14 * i, fill: colours[i % 2], "font-size": 13}, sv).textContent = a.name; });
    S.points.forEach((p) => { const xy = at(p); el("circle", {cx: X(xy), cy: Y(xy), r: 4, fill: "#222"}, sv);
      el("text", {x: X(xy) + 6, y: Y(xy) - 6, "font-size": 13}, sv).textContent = p.name + (p.far ? " (far off)" : ""); });
    const s = n ? D.steps[cur].side : null;
    if (s) {
      el("circle", {cx: X(s.xy), cy: Y(s.xy), r: 5, fill: "none", stroke: "#ff8c00", "stroke-width": 2, id: "side-step"}, sv);
      if (s.normal) { const e = [s.xy[0] + 0.6 * len * s.normal[0], s.xy[1] + 0.6 * len * s.normal[1]];
        el("line", {x1: X(s.xy), y1: Y(s.xy), x2: X(e), y2: Y(e), stroke: "#ff8c00", "marker-end": "url(#ah)"}, sv); }
    }
  }

  // --- the table: a row per step, a cell per candidate ---
  function buildTable() {
    const t = $("steps"), head = t.createTHead().insertRow();
    const named = D.label_column ? [D.label_column] : [];
    ["step", "phase"].concat(named, ["pixel"], D.columns, [D.last_column]).forEach((h) => {
      const th = document.createElement("th"); th.textContent = h; head.appendChild(th); });
    const body = t.createTBody();
    D.steps.forEach((s, k) => {
      const tr = body.insertRow(); tr.dataset.step = k;
      [k + 1, s.phase].concat(D.label_column ? [s.label] : [], [`(${s.pixel[0]}, ${s.pixel[1]})`])
        .forEach((v) => { tr.insertCell().textContent = v; });
      for (let i = 0; i < D.columns.length; i++) {
        const td = tr.insertCell(), c = s.cells[i];
        if (!c) continue;
        td.textContent = c.text; td.title = `${c.name} (${c.pixel[0]}, ${c.pixel[1]})`;
        td.className = "cand " + c.status + (i === s.chosen ? " chosen" : "");
        td.dataset.pix = c.pixel.join(",");
        // hovering only highlights (the cell and its pixel); a click or a key changes the step
        td.addEventListener("mouseenter", () => { hoverPix = c.pixel; td.classList.add("linked"); drawHeat(); });
        td.addEventListener("mouseleave", () => { hoverPix = null; td.classList.remove("linked"); drawHeat(); });
      }
      const m = tr.insertCell();
      m.textContent = s.chosen === null ? (s.note || "stay") : (s.note || `→ ${s.cells[s.chosen].name}`);
      tr.addEventListener("click", () => go(k));
    });
  }
  function linkFromPicture(pix) {
    document.querySelectorAll("#steps .linked").forEach((e) => e.classList.remove("linked"));
    if (!pix) return;
    const key = pix.join(",");
    document.querySelectorAll(`#steps tr[data-step="${cur}"] td.cand`).forEach((td) => {
      if (td.dataset.pix === key) td.classList.add("linked"); });
    D.steps.forEach((s, k) => { if (s.pixel.join(",") === key)
      document.querySelector(`#steps tr[data-step="${k}"]`).classList.add("linked"); });
  }
  heat.addEventListener("mousemove", (ev) => {
    const g = gridOf(cur); if (!g) return;
    const z = zoomOf(g), r = heat.getBoundingClientRect();
    const row = g.r0 + Math.floor((ev.clientY - r.top) / z), col = g.c0 + Math.floor((ev.clientX - r.left) / z);
    hoverPix = [row, col];
    const v = g.values[(row - g.r0) * g.w + (col - g.c0)];
    $("hover").textContent = `pixel (${row}, ${col}): ` + (v === null || v === undefined ? "not covered" :
      `${v}` + (g.transform === "nines" ? `, −log10(1 − s) = ${transform(g, v).toFixed(3)}` : ""));
    linkFromPicture(hoverPix); drawHeat();
  });
  heat.addEventListener("mouseleave", () => { hoverPix = null; $("hover").textContent = ""; linkFromPicture(null); drawHeat(); });

  // --- stepping ---
  function go(k) {
    if (!n) return;
    cur = Math.max(0, Math.min(n - 1, k));
    $("slider").value = cur;
    const s = D.steps[cur];
    const what = s.label === s.phase ? s.phase : `${s.phase} ${s.label}`;
    $("step-label").textContent = `step ${cur + 1} of ${n}: ${what}, pixel (${s.pixel[0]}, ${s.pixel[1]})`;
    document.querySelectorAll("#steps tr.current").forEach((e) => e.classList.remove("current"));
    const row = document.querySelector(`#steps tr[data-step="${cur}"]`);
    row.classList.add("current");
    // keep the current row in view inside the table's box, without scrolling the page
    const box = $("table-box"), b = box.getBoundingClientRect(), r = row.getBoundingClientRect();
    if (r.top < b.top || r.bottom > b.bottom) box.scrollTop += r.top - b.top - b.height / 2;
    drawHeat(); drawSide();
  }
  function play() {
    if (timer) { clearInterval(timer); timer = null; $("play").textContent = "▶ play"; return; }
    if (cur === n - 1) go(0);
    $("play").textContent = "❚❚ pause";
    timer = setInterval(() => { if (cur >= n - 1) play(); else go(cur + 1); }, 250);
  }
  $("slider").max = Math.max(n - 1, 0);
  $("slider").addEventListener("input", (e) => go(+e.target.value));
  $("prev").addEventListener("click", () => go(cur - 1));
  $("next").addEventListener("click", () => go(cur + 1));
  $("play").addEventListener("click", play);
  document.addEventListener("keydown", (e) => {
    if (e.key === "ArrowRight") { go(cur + 1); e.preventDefault(); }
    else if (e.key === "ArrowLeft") { go(cur - 1); e.preventDefault(); }
    else if (e.key === " ") { play(); e.preventDefault(); }
    else if (e.key === "Home") { go(0); e.preventDefault(); }
    else if (e.key === "End") { go(n - 1); e.preventDefault(); }
  });

  $("title").textContent = D.title;
  $("meta").textContent = D.meta.map((m) => `${m[0]}: ${m[1]}`).join(" · ");
  $("stop").textContent = D.stop;
  $("result").textContent = D.result.join("; ");
  $("side-caption").textContent = D.side.caption;
  $("legend").textContent = D.legend;
  if (D.grids.length > 1) {  // several maps: the step's own by default, or one picked
    const sel = $("grid-choice");
    sel.add(new Option("the current step's own", "-1"));
    D.grids.forEach((g, i) => sel.add(new Option(g.title, String(i))));
    sel.addEventListener("change", () => { picked = +sel.value; drawHeat(); });
    $("grid-pick").hidden = false;
  }
  buildTable();
  if (n) go(0); else { drawHeat(); drawSide(); }
  window.refsoftViewer = {go: go, current: () => cur, steps: n, hover: () => hoverPix};
})();
