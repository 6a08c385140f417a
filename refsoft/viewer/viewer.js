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
  function gridOf(k) { return D.grids.length ? D.grids[n ? D.steps[k].grid : 0] : null; }
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
      if (D.grids[a.grid] !== g || D.grids[b.grid] !== g) continue;
      hctx.strokeStyle = PATH[b.phase] || "#ffffff";
      hctx.beginPath(); hctx.moveTo(...centre(g, z, a.pixel)); hctx.lineTo(...centre(g, z, b.pixel)); hctx.stroke();
    }
    if (D.kind === "hierarchy") {
      for (let k = 0; k < cur; k++) box(hctx, g, z, null, "rgba(255,255,255,0.35)", 1, D.steps[k].rect);
    }
    D.images.forEach((p) => { const [x, y] = centre(g, z, p); hctx.strokeStyle = "#ff66ff"; hctx.lineWidth = 2;
      hctx.beginPath(); hctx.arc(x, y, Math.max(z, 6), 0, 2 * Math.PI); hctx.stroke(); });
    if (D.grids[D.steps[0] ? D.steps[0].grid : 0] === g) { hctx.fillStyle = "#28dc3c"; const [x, y] = centre(g, z, D.start);
      hctx.fillRect(x - 4, y - 4, 9, 9); }
    if (cur === n - 1) { hctx.fillStyle = "#e61e1e"; const [x, y] = centre(g, z, D.end); hctx.fillRect(x - 4, y - 4, 9, 9); }
    if (n) {
      const s = D.steps[cur];
      s.cells.forEach((c, i) => { if (c.status !== "outside" && c.status !== "uncovered" || c.rect)
        box(hctx, g, z, c.pixel, i === s.chosen ? "#ff8c00" : "#ffdc00", i === s.chosen ? 3 : 1.5, c.rect); });
      box(hctx, g, z, s.pixel, "#ffffff", 2, s.rect);
    }
    if (hoverPix) box(hctx, g, z, hoverPix, "#ff00ff", 3, null);
    $("heat-title").textContent = g.title;
    drawBar(g, layers[li]);
  }

  function drawBar(g, L) {
    const bar = $("bar"), ctx = bar.getContext("2d");
    bar.width = 520; bar.height = 46;
    ctx.clearRect(0, 0, bar.width, bar.height);
    for (let x = 0; x < 460; x++) { const c = ramp(x / 459); ctx.fillStyle = `rgb(${c[0]},${c[1]},${c[2]})`;
      ctx.fillRect(30 + x, 4, 1, 16); }
    ctx.fillStyle = "#222"; ctx.font = "13px sans-serif"; ctx.textAlign = "center";
    for (let i = 0; i <= 4; i++) { const x = 30 + 459 * i / 4; ctx.fillRect(x, 20, 1, 5);
      ctx.fillText((L.lo + (L.hi - L.lo) * i / 4).toPrecision(3), x, 38); }
    $("bar-label").textContent = g.label + " (uncovered: dark grey)";
    $("formula").textContent = g.formula;
  }

  // --- the side view (SVG) ---
  const SVG = "http://www.w3.org/2000/svg";
  function el(tag, attrs, parent) { const e = document.createElementNS(SVG, tag);
    for (const k in attrs) e.setAttribute(k, attrs[k]); parent.appendChild(e); return e; }
  function drawSide() {
    const sv = $("side"); sv.innerHTML = "";
    const S = D.side, pts = S.points.map((p) => p.xy);
    D.steps.forEach((s) => { if (s.side) pts.push(s.side.xy); });
    const xs = pts.map((p) => p[0]), ys = pts.map((p) => p[1]);
    let x0 = Math.min(...xs), x1 = Math.max(...xs), y0 = Math.min(...ys), y1 = Math.max(...ys);
    const ext = Math.max(x1 - x0, y1 - y0, 1e-9), pad = 0.12 * ext;
    x0 -= pad; x1 += pad; y0 -= pad; y1 += pad;
    const W = 420, sc = W / Math.max(x1 - x0, y1 - y0);
    const H = Math.max(160, (y1 - y0) * sc);
    sv.setAttribute("viewBox", `0 0 ${W} ${H}`); sv.setAttribute("width", W); sv.setAttribute("height", H);
    const X = (p) => (p[0] - x0) * sc, Y = (p) => H - (p[1] - y0) * sc, len = 0.18 * ext;
    el("defs", {}, sv).innerHTML = '<marker id="ah" viewBox="0 0 10 10" refX="9" refY="5" markerWidth="7" ' +
      'markerHeight="7" orient="auto-start-reverse"><path d="M0,0L10,5L0,10z" fill="context-stroke"/></marker>';
    if (S.line) el("line", {x1: X(S.line[0]), y1: Y(S.line[0]), x2: X(S.line[1]), y2: Y(S.line[1]),
                            stroke: "#999", "stroke-dasharray": "4 3"}, sv);
    S.rays.forEach((r) => el("line", {x1: X(r[0]), y1: Y(r[0]), x2: X(r[1]), y2: Y(r[1]), stroke: "#555"}, sv));
    const colours = ["#1f77b4", "#d62728"];
    S.arrows.forEach((a, i) => { const e = [a.from[0] + len * a.dir[0], a.from[1] + len * a.dir[1]];
      el("line", {x1: X(a.from), y1: Y(a.from), x2: X(e), y2: Y(e), stroke: colours[i % 2], "stroke-width": 2,
                  "marker-end": "url(#ah)"}, sv);
      el("text", {x: X(e) + 6, y: Y(e) + 14 * i, fill: colours[i % 2], "font-size": 13}, sv).textContent = a.name; });
    S.points.forEach((p) => { el("circle", {cx: X(p.xy), cy: Y(p.xy), r: 4, fill: "#222"}, sv);
      el("text", {x: X(p.xy) + 6, y: Y(p.xy) - 6, "font-size": 13}, sv).textContent = p.name; });
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
    ["#", "step", "phase", "pixel"].concat(D.columns).concat(["move"]).forEach((h) => {
      const th = document.createElement("th"); th.textContent = h; head.appendChild(th); });
    const body = t.createTBody();
    D.steps.forEach((s, k) => {
      const tr = body.insertRow(); tr.dataset.step = k;
      [k + 1, s.label, s.phase, `(${s.pixel[0]}, ${s.pixel[1]})`].forEach((v) => { tr.insertCell().textContent = v; });
      for (let i = 0; i < D.columns.length; i++) {
        const td = tr.insertCell(), c = s.cells[i];
        if (!c) continue;
        td.textContent = c.text; td.title = `${c.name} (${c.pixel[0]}, ${c.pixel[1]})`;
        td.className = "cand " + c.status + (i === s.chosen ? " chosen" : "");
        td.dataset.pix = c.pixel.join(",");
        td.addEventListener("mouseenter", () => { go(k); hoverPix = c.pixel; drawHeat(); });
        td.addEventListener("mouseleave", () => { hoverPix = null; drawHeat(); });
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
    $("step-label").textContent = `step ${cur + 1} of ${n}: ${s.label}, ${s.phase}, pixel (${s.pixel[0]}, ${s.pixel[1]})`;
    document.querySelectorAll("#steps tr.current").forEach((e) => e.classList.remove("current"));
    const row = document.querySelector(`#steps tr[data-step="${cur}"]`);
    row.classList.add("current");
    if (row.scrollIntoView && !timer) row.scrollIntoView({block: "nearest"});
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
  });

  $("title").textContent = D.title;
  $("meta").textContent = D.meta.map((m) => `${m[0]}: ${m[1]}`).join(" · ");
  $("stop").textContent = D.stop;
  $("result").textContent = D.result.join("; ");
  $("side-caption").textContent = D.side.caption;
  buildTable();
  if (n) go(0); else { drawHeat(); drawSide(); }
  window.refsoftViewer = {go: go, current: () => cur, steps: n, hover: () => hoverPix};
})();
