// The explorer's page: plain JavaScript, no build step. It asks the server for slices
// of each view in turn (coarse to fine), draws them on canvases, and keeps each view's
// zoom history. A newer request of a view makes the server cancel the older one.

const TOKEN = new URLSearchParams(location.search).get("token");
const TAB = Array.from(crypto.getRandomValues(new Uint8Array(8)), (b) => b.toString(16).padStart(2, "0")).join("");
const $ = (id) => document.getElementById(id);
let INFO = null;
const overrides = {}; // model parameters changed on the page: name -> text

class Cancelled extends Error {}

function showError(msg) {
  const e = $("error");
  e.textContent = msg;
  e.hidden = !msg;
}

// The request at work per path: a newer one aborts it here (the server cancels its
// work on seeing the newer one).
const inFlight = {};

async function api(path, fields, binary = false) {
  const q = new URLSearchParams({ tab: TAB });
  if (TOKEN) q.set("token", TOKEN);
  for (const [k, v] of Object.entries(fields)) q.set(k, String(v));
  for (const [k, v] of Object.entries(overrides)) q.set("p." + k, v);
  if (inFlight[path]) inFlight[path].abort();
  const ctl = (inFlight[path] = new AbortController());
  let r;
  try {
    r = await fetch(path + "?" + q.toString(), { signal: ctl.signal });
  } catch (e) {
    if (e.name === "AbortError") throw new Cancelled();
    throw e;
  } finally {
    if (inFlight[path] === ctl) delete inFlight[path];
  }
  if (r.status === 409) throw new Cancelled();
  if (!r.ok) {
    let msg = r.statusText;
    try { msg = (await r.json()).error; } catch (_) { /* not JSON */ }
    throw new Error(msg);
  }
  return binary ? new Float32Array(await r.arrayBuffer()) : r.json();
}

// The CLI's --param and Python's params= for the page's overrides.
function paramFlags() {
  const kv = Object.entries(overrides).map(([k, v]) => `${k}=${v}`);
  return kv.length ? ` --param ${kv.join(",")}` : "";
}
function paramKw() {
  const kv = Object.entries(overrides).map(([k, v]) => `"${k}": ${v}`);
  return kv.length ? `, params={${kv.join(", ")}}` : "";
}

const rangeValue = (lo, hi, n, i) => (n <= 1 ? lo : lo + ((hi - lo) * i) / (n - 1));

function formValues(form) {
  const v = {};
  for (const el of form.elements) if (el.name) v[el.name] = el.value.trim();
  return v;
}
function fillForm(form, v) {
  for (const el of form.elements) if (el.name && v[el.name] !== undefined) el.value = v[el.name];
}
function fillSelect(sel, names, value) {
  sel.innerHTML = "";
  for (const n of names) sel.add(new Option(n, n, false, n === value));
}
const num = (s) => Number(s);

// Box zoom and click on an overlay canvas: calls onBox(x0, y0, x1, y1) in pixels or
// onClick(x, y).
function pointer(overlay, onBox, onClick) {
  const ctx = overlay.getContext("2d");
  let start = null;
  const at = (e) => {
    const r = overlay.getBoundingClientRect();
    return [((e.clientX - r.left) * overlay.width) / r.width, ((e.clientY - r.top) * overlay.height) / r.height];
  };
  overlay.addEventListener("mousedown", (e) => { start = at(e); });
  overlay.addEventListener("mousemove", (e) => {
    if (!start) return;
    const [x, y] = at(e);
    ctx.clearRect(0, 0, overlay.width, overlay.height);
    ctx.strokeStyle = "#d33";
    ctx.strokeRect(start[0], start[1], x - start[0], y - start[1]);
  });
  overlay.addEventListener("mouseup", (e) => {
    if (!start) return;
    const [x, y] = at(e);
    ctx.clearRect(0, 0, overlay.width, overlay.height);
    const [x0, y0] = start;
    start = null;
    if (Math.abs(x - x0) > 5 && Math.abs(y - y0) > 5) onBox(Math.min(x, x0), Math.min(y, y0), Math.max(x, x0), Math.max(y, y0));
    else onClick(x, y);
  });
}

// A view's history of windows: back, forward, reset.
class History {
  constructor(first) { this.list = [first]; this.i = 0; }
  get now() { return this.list[this.i]; }
  push(v) { this.list = this.list.slice(0, this.i + 1); this.list.push(v); this.i++; }
  back() { if (this.i > 0) this.i--; }
  forward() { if (this.i < this.list.length - 1) this.i++; }
  reset() { this.i = 0; }
}

// An .npy file (format 1.0) of a little-endian array.
function npy(array, shape, descr) {
  let header = `{'descr': '${descr}', 'fortran_order': False, 'shape': (${shape.join(", ")}${shape.length === 1 ? "," : ""}), }`;
  const total = 10 + header.length + 1;
  header += " ".repeat((64 - (total % 64)) % 64) + "\n";
  const head = new Uint8Array(10 + header.length);
  head.set([0x93, 78, 85, 77, 80, 89, 1, 0, header.length & 255, header.length >> 8]);
  for (let i = 0; i < header.length; i++) head[10 + i] = header.charCodeAt(i);
  return new Blob([head, array.buffer], { type: "application/octet-stream" });
}

function axes(ctx, w, h, xlo, xhi, ylo, yhi, xlabel, ylabel) {
  ctx.fillStyle = "#333";
  ctx.font = "11px sans-serif";
  ctx.fillText(`${fmt(xlo)}`, 2, h - 3);
  const t = `${fmt(xhi)}  ${xlabel}`;
  ctx.fillText(t, w - ctx.measureText(t).width - 2, h - 3);
  ctx.fillText(`${fmt(yhi)}  ${ylabel}`, 2, 11);
  ctx.fillText(`${fmt(ylo)}`, 2, h - 15);
}
const fmt = (v) => (Math.abs(v) >= 1e4 || (Math.abs(v) < 1e-2 && v !== 0) ? v.toExponential(3) : Number(v.toPrecision(5)).toString());

// ---------------------------------------------------------------- bifurcation view
const bif = {
  form: $("bif-form"), canvas: $("bif-canvas"), gen: 0, hist: null, data: null,
  settings: { param: "omega", lo: "125", hi: "145", omega: "133", coord: "vx_s", n: "400", k: "4", transient: "200", periods: "32" },
};
bif.margin = 16;

function bifPlan(n) {
  // Passes coarse to fine: stride S (about n/8 columns), then S/2, ... 1.
  let s = 1;
  while (s * 2 <= n / 8) s *= 2;
  const passes = [{ from: 0, step: s }];
  for (let t = s / 2; t >= 1; t /= 2) passes.push({ from: t, step: 2 * t });
  return passes.map((p) => ({ ...p, total: p.from >= n ? 0 : Math.floor((n - 1 - p.from) / p.step) + 1 }));
}

async function bifCompute() {
  const gen = ++bif.gen;
  const s = bif.settings, w = bif.hist.now;
  const n = num(s.n), k = num(s.k), per = num(s.periods), cost = k * (num(s.transient) + per);
  bif.data = { n, k, per, lo: w.lo, hi: w.hi, cols: new Array(n), autoY: w.ylo === undefined, ylo: w.ylo, yhi: w.yhi };
  bifCommand();
  bifDraw();
  $("bif-status").textContent = "computing";
  let target = 3000; // lane-periods of the first slice: about 0.3 s on two CPU cores
  const t0 = performance.now();
  let done = 0;
  try {
    for (const pass of bifPlan(n)) {
      let i = 0;
      while (i < pass.total) {
        const count = Math.max(1, Math.min(pass.total - i, Math.floor(target / cost)));
        const from = pass.from + i * pass.step;
        const t = performance.now();
        const vals = await api("/api/bifurcation", {
          param: s.param, lo: w.lo, hi: w.hi, n, from, step: pass.step, count, k, omega: s.omega,
          coord: s.coord, transient: s.transient, periods: per,
        }, true);
        if (gen !== bif.gen) return;
        for (let c = 0; c < count; c++) bif.data.cols[from + c * pass.step] = vals.subarray(c * k * per, (c + 1) * k * per);
        const dt = Math.max(1, performance.now() - t);
        // Aim at a slice of about 0.4 s at the rate the last one had.
        target = Math.min(5e7, Math.max(500, ((count * cost) / dt) * 400));
        i += count;
        done += count;
        bifDraw();
        $("bif-status").textContent = `${done} of ${n} columns, ${((performance.now() - t0) / 1000).toFixed(1)} s`;
      }
    }
    $("bif-status").textContent = `${n} columns x ${k} starts in ${((performance.now() - t0) / 1000).toFixed(1)} s`;
  } catch (e) {
    if (!(e instanceof Cancelled) && gen === bif.gen) { showError(e.message); $("bif-status").textContent = "stopped"; }
  }
}

function bifYRange() {
  const d = bif.data;
  if (!d.autoY) return [d.ylo, d.yhi];
  let lo = Infinity, hi = -Infinity;
  for (const col of d.cols) if (col) for (const v of col) if (Number.isFinite(v)) { if (v < lo) lo = v; if (v > hi) hi = v; }
  if (!(lo < hi)) { lo = (lo === Infinity ? 0 : lo) - 1e-6; hi = lo + 2e-6; }
  const pad = 0.05 * (hi - lo);
  return [lo - pad, hi + pad];
}

function bifDraw() {
  const d = bif.data, cv = bif.canvas, ctx = cv.getContext("2d");
  const W = cv.width, H = cv.height, m = bif.margin;
  const [ylo, yhi] = bifYRange();
  d.view = { ylo, yhi };
  // Hits per pixel, each point a 2 x 2 block; darker where more points fall.
  const hits = new Uint16Array(W * H);
  for (let c = 0; c < d.n; c++) {
    const col = d.cols[c];
    if (!col) continue;
    const x = Math.round(m + ((W - 2 * m) * (d.n === 1 ? 0.5 : c / (d.n - 1))));
    for (const v of col) {
      if (!Number.isFinite(v)) continue;
      const y = Math.round(H - m - ((H - 2 * m) * (v - ylo)) / (yhi - ylo));
      if (y < 0 || y >= H - 1 || x >= W - 1) continue;
      for (const o of [y * W + x, y * W + x + 1, (y + 1) * W + x, (y + 1) * W + x + 1]) if (hits[o] < 65535) hits[o]++;
    }
  }
  const img = ctx.createImageData(W, H);
  const px = img.data;
  for (let i = 0; i < hits.length; i++) {
    const k = hits[i], o = 4 * i;
    const t = k === 0 ? 0 : Math.min(1, 0.55 + 0.15 * Math.log2(k));
    px[o] = 255 - 225 * t; px[o + 1] = 255 - 195 * t; px[o + 2] = 255 - 120 * t; px[o + 3] = 255;
  }
  ctx.putImageData(img, 0, 0);
  axes(ctx, W, H, d.lo, d.hi, ylo, yhi, bif.settings.param, bif.settings.coord);
}

function bifCommand() {
  const s = bif.settings, w = bif.hist.now;
  const range = `${w.lo}:${w.hi}:${s.n}`;
  let cli, py;
  if (s.param === "omega") {
    cli = `jeffcott bifurcation --omega ${range} --sweep none --ics ${s.k} --coord ${s.coord} --brute-transient ${s.transient} --periods ${s.periods}${paramFlags()}`;
    py = `jeffcott.bifurcation("${range}", sweep="none", ics=${s.k}, brute_transient=${s.transient}, periods=${s.periods}${paramKw()})`;
  } else {
    cli = `jeffcott continuation --vary ${s.param}:${range} --omega ${s.omega} --ics ${s.k} --transient ${s.transient} --periods ${s.periods}${paramFlags()}`;
    py = `jeffcott.continuation("${s.param}:${range}", omega=${s.omega}, ics=${s.k}, transient=${s.transient}, periods=${s.periods}${paramKw()})`;
  }
  $("bif-cmd").textContent = `At full resolution (with catalogued attractors):\n${cli}\n${py}`;
}

function bifStart(fresh) {
  const v = formValues(bif.form);
  bif.settings = v;
  if (fresh || !bif.hist) bif.hist = new History({ lo: num(v.lo), hi: num(v.hi) });
  document.querySelectorAll("#bif .omega-only").forEach((el) => { el.hidden = v.param === "omega"; });
  bifCompute();
}

// A window's edge rounded to a thousandth of its width, so commands stay readable.
function tidy(v, width) {
  const step = Math.pow(10, Math.floor(Math.log10(width / 1000)));
  return Number((Math.round(v / step) * step).toPrecision(12));
}

function bifBox(x0, y0, x1, y1) {
  const d = bif.data, cv = bif.canvas, m = bif.margin;
  if (!d || !d.view) return;
  const xv = (x) => d.lo + ((d.hi - d.lo) * (x - m)) / (cv.width - 2 * m);
  const yv = (y) => d.view.ylo + ((d.view.yhi - d.view.ylo) * (cv.height - m - y)) / (cv.height - 2 * m);
  const wx = xv(x1) - xv(x0);
  bif.hist.push({ lo: tidy(xv(x0), wx), hi: tidy(xv(x1), wx), ylo: yv(y1), yhi: yv(y0) });
  fillForm(bif.form, { lo: bif.hist.now.lo, hi: bif.hist.now.hi });
  bif.settings.lo = String(bif.hist.now.lo); bif.settings.hi = String(bif.hist.now.hi);
  bifCompute();
}

function bifClick(x, y) {
  const d = bif.data, cv = bif.canvas, m = bif.margin;
  if (!d || !d.view) return;
  let best = null;
  for (let c = 0; c < d.n; c++) {
    const col = d.cols[c];
    if (!col) continue;
    const cx = m + ((cv.width - 2 * m) * (d.n === 1 ? 0.5 : c / (d.n - 1)));
    if (Math.abs(cx - x) > 6) continue;
    for (let i = 0; i < col.length; i++) {
      const cy = cv.height - m - ((cv.height - 2 * m) * (col[i] - d.view.ylo)) / (d.view.yhi - d.view.ylo);
      const dist = Math.hypot(cx - x, cy - y);
      if (dist < 8 && (!best || dist < best.dist)) best = { dist, c, lane: Math.floor(i / d.per) };
    }
  }
  if (!best) return;
  const s = bif.settings, v = rangeValue(d.lo, d.hi, d.n, best.c);
  const wref = s.param === "omega" ? 0.5 * (d.lo + d.hi) : num(s.omega);
  const fields = { start: best.lane, k: d.k, wref, omega: s.param === "omega" ? v : s.omega, transient: s.transient };
  const extra = s.param === "omega" ? {} : { ["p." + s.param]: v };
  trajectory({ ...fields, ...extra }, `start ${best.lane} of ${d.k} at ${s.param} = ${fmt(v)}`);
}

// ---------------------------------------------------------------- basin view
const basin = {
  form: $("basin-form"), canvas: $("basin-canvas"), gen: 0, hist: null, data: null,
  settings: { omega: "133", x: "x_r", xlo: "-0.006", xhi: "0.006", y: "vx_r", ylo: "-1", yhi: "1", n: "128", transient: "250", periods: "32" },
};
const PALETTE = ["#1f77b4", "#ff7f0e", "#2ca02c", "#d62728", "#9467bd", "#8c564b", "#e377c2", "#bcbd22", "#17becf", "#7f7f7f"];
const color = (label) => (label < 0 ? "#000000" : PALETTE[label % PALETTE.length]);

async function basinCompute() {
  const gen = ++basin.gen;
  const s = basin.settings, w = basin.hist.now, n = num(s.n);
  basinCommand();
  $("basin-status").textContent = "computing";
  const levels = [];
  for (let l = Math.max(2, Math.floor(n / 8)); l < n; l *= 2) levels.push(l);
  levels.push(n);
  const t0 = performance.now();
  try {
    for (const level of levels) {
      const r = await api("/api/basin", {
        omega: s.omega, x: s.x, xlo: w.xlo, xhi: w.xhi, y: s.y, ylo: w.ylo, yhi: w.yhi, n: level,
        transient: s.transient, periods: s.periods,
      });
      if (gen !== basin.gen) return;
      basin.data = r;
      basinDraw();
      $("basin-status").textContent = `${level} x ${level} in ${((performance.now() - t0) / 1000).toFixed(1)} s${level < n ? ", refining" : ""}`;
    }
  } catch (e) {
    if (!(e instanceof Cancelled) && gen === basin.gen) { showError(e.message); $("basin-status").textContent = "stopped"; }
  }
}

function basinDraw() {
  const r = basin.data, cv = basin.canvas, ctx = cv.getContext("2d");
  const cw = cv.width / r.nx, ch = cv.height / r.ny;
  for (let iy = 0; iy < r.ny; iy++) {
    for (let ix = 0; ix < r.nx; ix++) {
      ctx.fillStyle = color(r.labels[iy * r.nx + ix]);
      // Row 0 is the lowest y: drawn at the bottom.
      ctx.fillRect(Math.floor(ix * cw), Math.floor(cv.height - (iy + 1) * ch), Math.ceil(cw), Math.ceil(ch));
    }
  }
  const tb = $("legend").tBodies[0];
  tb.innerHTML = "";
  for (const a of r.attractors) {
    const tr = tb.insertRow();
    tr.innerHTML = `<td><span class="swatch" style="background:${color(a.id)}"></span></td><td>${a.class}</td><td>${a.period ?? "-"}</td><td>${a.fraction.toFixed(3)}</td>`;
  }
  if (r.diverged_fraction > 0) {
    const tr = tb.insertRow();
    tr.innerHTML = `<td><span class="swatch" style="background:#000"></span></td><td>diverged</td><td>-</td><td>${r.diverged_fraction.toFixed(3)}</td>`;
  }
}

function basinCommand() {
  const s = basin.settings, w = basin.hist.now;
  const cli = `jeffcott basin --omega ${s.omega} --x ${s.x}:${w.xlo}:${w.xhi}:${s.n} --y ${s.y}:${w.ylo}:${w.yhi}:${s.n} --transient ${s.transient} --periods ${s.periods}${paramFlags()}`;
  const py = `jeffcott.basin(${s.omega}, "${s.x}:${w.xlo}:${w.xhi}:${s.n}", "${s.y}:${w.ylo}:${w.yhi}:${s.n}", transient=${s.transient}, periods=${s.periods}${paramKw()})`;
  $("basin-cmd").textContent = `${cli}\n${py}`;
}

function basinStart(fresh) {
  const v = formValues(basin.form);
  basin.settings = v;
  if (fresh || !basin.hist) basin.hist = new History({ xlo: num(v.xlo), xhi: num(v.xhi), ylo: num(v.ylo), yhi: num(v.yhi) });
  basinCompute();
}

function basinBox(x0, y0, x1, y1) {
  const w = basin.hist.now, cv = basin.canvas;
  const xv = (x) => w.xlo + ((w.xhi - w.xlo) * x) / cv.width;
  const yv = (y) => w.ylo + ((w.yhi - w.ylo) * (cv.height - y)) / cv.height;
  const wx = xv(x1) - xv(x0), wy = yv(y0) - yv(y1);
  basin.hist.push({ xlo: tidy(xv(x0), wx), xhi: tidy(xv(x1), wx), ylo: tidy(yv(y1), wy), yhi: tidy(yv(y0), wy) });
  fillForm(basin.form, basin.hist.now);
  basinCompute();
}

function basinClick(x, y) {
  const r = basin.data, cv = basin.canvas;
  if (!r) return;
  const ix = Math.min(r.nx - 1, Math.floor((x * r.nx) / cv.width));
  const iy = Math.min(r.ny - 1, Math.floor(((cv.height - y) * r.ny) / cv.height));
  const x0 = r.base.slice();
  const names = INFO.coords.map((c) => c.name);
  x0[names.indexOf(r.x)] = r.xs[ix];
  x0[names.indexOf(r.y)] = r.ys[iy];
  const label = r.labels[iy * r.nx + ix];
  trajectory({ omega: basin.settings.omega, x0: x0.join(","), transient: basin.settings.transient },
    `cell (${ix}, ${iy}), ${r.x} = ${fmt(r.xs[ix])}, ${r.y} = ${fmt(r.ys[iy])}, label ${label}`);
}

// ---------------------------------------------------------------- trajectory
let trajGen = 0;
async function trajectory(fields, where) {
  const gen = ++trajGen;
  $("traj-summary").textContent = `computing the trajectory of ${where} ...`;
  try {
    const t = await api("/api/trajectory", { periods: 64, ...fields });
    if (gen !== trajGen) return;
    trajDraw(t, where, fields);
  } catch (e) {
    if (!(e instanceof Cancelled) && gen === trajGen) showError(e.message);
  }
}

function plotXY(id, series, opts = {}) {
  const cv = $(id), ctx = cv.getContext("2d"), W = cv.width, H = cv.height, m = 18;
  ctx.clearRect(0, 0, W, H);
  let xlo = Infinity, xhi = -Infinity, ylo = Infinity, yhi = -Infinity;
  for (const s of series) for (const [x, y] of s.pts) { xlo = Math.min(xlo, x); xhi = Math.max(xhi, x); ylo = Math.min(ylo, y); yhi = Math.max(yhi, y); }
  if (opts.square) { const r = Math.max(xhi - xlo, yhi - ylo) / 2, cx = (xlo + xhi) / 2, cy = (ylo + yhi) / 2; xlo = cx - r; xhi = cx + r; ylo = cy - r; yhi = cy + r; }
  if (!(xhi > xlo)) { xlo -= 1; xhi += 1; }
  if (!(yhi > ylo)) { ylo -= 1; yhi += 1; }
  const X = (x) => m + ((W - 2 * m) * (x - xlo)) / (xhi - xlo), Y = (y) => H - m - ((H - 2 * m) * (y - ylo)) / (yhi - ylo);
  for (const s of series) {
    ctx.strokeStyle = ctx.fillStyle = s.color;
    if (s.kind === "dots") for (const [x, y] of s.pts) ctx.fillRect(X(x) - 1.5, Y(y) - 1.5, 3, 3);
    else if (s.kind === "stems") for (const [x, y] of s.pts) { ctx.beginPath(); ctx.moveTo(X(x), Y(0)); ctx.lineTo(X(x), Y(y)); ctx.stroke(); }
    else { ctx.beginPath(); s.pts.forEach(([x, y], i) => (i ? ctx.lineTo(X(x), Y(y)) : ctx.moveTo(X(x), Y(y)))); ctx.stroke(); }
  }
  axes(ctx, W, H, xlo, xhi, ylo, yhi, opts.xlabel || "", opts.ylabel || "");
}

function trajDraw(t, where, fields) {
  const rows = t.timeseries;
  let text = `${where}: ${t.class}`;
  if (t.period) text += ` (period ${t.period})`;
  text += `, status ${t.status}, in contact ${(100 * t.contact_fraction).toFixed(1)} % of the record`;
  if (t.floquet && t.floquet.multipliers) {
    const mags = t.floquet.multipliers.map(([re, im]) => Math.hypot(re, im)).sort((a, b) => b - a);
    text += `. Floquet multipliers |m|: ${mags.map((v) => v.toFixed(4)).join(", ")} (${t.floquet.stable ? "stable" : "unstable"})`;
  } else if (t.floquet && t.floquet.error) text += `. Shooting failed: ${t.floquet.error}`;
  $("traj-summary").textContent = text;
  const circle = [];
  for (let i = 0; i <= 128; i++) circle.push([t.delta * Math.cos((2 * Math.PI * i) / 128), t.delta * Math.sin((2 * Math.PI * i) / 128)]);
  plotXY("traj-orbit", [{ pts: circle, color: "#aaa" }, { pts: rows.map((r) => [r[1] - r[5], r[3] - r[7]]), color: "#1f77b4" }], { square: true, xlabel: "x_r - x_s", ylabel: "y_r - y_s" });
  plotXY("traj-section", [{ pts: t.poincare.map((p) => [p[0], p[1]]), color: "#d62728", kind: "dots" }], { xlabel: "x_r", ylabel: "vx_r" });
  plotXY("traj-series", [{ pts: rows.map((r) => [r[0], r[1]]), color: "#1f77b4" }, { pts: rows.map((r) => [r[0], r[5]]), color: "#ff7f0e" }], { xlabel: "t [s]", ylabel: "x [m]" });
  plotXY("traj-spectrum", [{ pts: (t.spectrum || []).map((s) => [s[0], s[1]]), color: "#1f77b4", kind: "stems" }], { xlabel: "order", ylabel: "rotor amplitude [m]" });
  plotXY("traj-force", [{ pts: (t.contact || []).map((c) => [c[0], c[1]]), color: "#2ca02c" }], { xlabel: "t [s]", ylabel: "F_n [N]" });
  const names = INFO.coords.map((c) => c.name);
  const init = t.x0.map((v, i) => `${names[i]}=${v}`).join(",");
  const pinit = t.x0.map((v, i) => `"${names[i]}": ${v}`).join(", ");
  let pflags = paramFlags(), pkw = paramKw();
  for (const [k, v] of Object.entries(fields)) if (k.startsWith("p.")) { pflags += ` --param ${k.slice(2)}=${v}`; pkw += `, params={**params, "${k.slice(2)}": ${v}}`; }
  $("traj-cmd").textContent = `jeffcott simulate --omega ${t.omega} --init ${init} --transient ${fields.transient} --periods 64${pflags}\njeffcott.simulate(${t.omega}, init={${pinit}}, transient=${fields.transient}, periods=64${pkw})`;
}

// ---------------------------------------------------------------- parameters
function paramsTable() {
  const tb = $("params").tBodies[0];
  tb.innerHTML = "";
  for (const p of INFO.params) {
    const tr = tb.insertRow();
    tr.title = `${p.name}: ${p.meaning}; ${p.allowed}; default ${p.default}`;
    const allowed = p.allowed.replace("must be finite and ", "").replace("must be finite", "any");
    tr.innerHTML = `<td>${p.symbol}</td><td><input name="${p.name}" value="${p.value}"></td><td>${p.unit}</td><td class="allowed">${allowed}</td>`;
  }
}

function applyParams() {
  for (const k of Object.keys(overrides)) delete overrides[k];
  for (const input of $("params").querySelectorAll("input")) {
    input.classList.remove("bad");
    const p = INFO.params.find((q) => q.name === input.name);
    if (input.value.trim() !== String(p.value)) overrides[input.name] = input.value.trim();
  }
  showError("");
  bifStart(false);
  basinStart(false);
}

// ---------------------------------------------------------------- start
// The buttons above each view: action, label, tooltip.
const BAR = [
  ["back", "Back", "the previous window"],
  ["forward", "Forward", "the next window"],
  ["reset", "Reset", "the first window"],
  ["npy", "Save .npy", "the view's data into the server's --out"],
  ["png", "Save .png", "the picture into the server's --out"],
];
async function main() {
  try {
    INFO = await api("/api/info", {});
  } catch (e) {
    showError(e.message);
    return;
  }
  $("device").textContent = `${INFO.version} · lanes on ${INFO.device} (${INFO.precision})`;
  const names = INFO.coords.map((c) => c.name);
  fillSelect(bif.form.elements.param, ["omega", ...INFO.params.map((p) => p.name)], "omega");
  fillSelect(bif.form.elements.coord, names, bif.settings.coord);
  fillSelect(basin.form.elements.x, names, basin.settings.x);
  fillSelect(basin.form.elements.y, names, basin.settings.y);
  const delta = INFO.params.find((p) => p.name === "delta").value;
  basin.settings.xlo = String(-delta); basin.settings.xhi = String(delta);
  // One column per pixel of the plot: a zoom is recomputed at the screen's resolution.
  bif.settings.n = String(bif.canvas.width - 2 * bif.margin);
  fillForm(bif.form, bif.settings);
  fillForm(basin.form, basin.settings);
  paramsTable();
  bif.form.addEventListener("submit", (e) => { e.preventDefault(); showError(""); bifStart(true); });
  basin.form.addEventListener("submit", (e) => { e.preventDefault(); showError(""); basinStart(true); });
  $("params-apply").addEventListener("click", applyParams);
  $("params-reset").addEventListener("click", () => { paramsTable(); applyParams(); });
  pointer($("bif-overlay"), bifBox, bifClick);
  pointer($("basin-overlay"), basinBox, basinClick);
  for (const [view, redo] of [[bif, bifCompute], [basin, basinCompute]]) {
    const sec = view.form.parentElement;
    sec.querySelector(".bar").prepend(...BAR.map(([act, label, title]) => {
      const b = document.createElement("button");
      Object.assign(b, { textContent: label, title });
      b.dataset.act = act;
      return b;
    }));
    sec.querySelector(".bar").addEventListener("click", (e) => {
      const act = e.target.dataset && e.target.dataset.act;
      if (!act) return;
      if (act === "npy" || act === "png") return save(view, act);
      view.hist[act]();
      const w = view.hist.now;
      fillForm(view.form, w);
      Object.assign(view.settings, Object.fromEntries(Object.entries(w).map(([k, v]) => [k, String(v)])));
      redo();
    });
  }
  // A closed or reloaded page stops its work at once.
  window.addEventListener("pagehide", () => {
    const q = new URLSearchParams({ tab: TAB });
    if (TOKEN) q.set("token", TOKEN);
    navigator.sendBeacon("/api/close?" + q.toString());
  });
  bifStart(true);
  basinStart(true);
}

// Saves a view's data or picture into the server's --out, with the command that
// computes it at full resolution beside it.
async function save(view, kind) {
  const name = view === bif ? "bifurcation" : "basin";
  let blob;
  if (kind === "png") blob = await new Promise((ok) => view.canvas.toBlob(ok));
  else if (view === bif) {
    const d = bif.data, out = new Float32Array(d.n * d.k * d.per).fill(NaN);
    d.cols.forEach((c, i) => c && out.set(c, i * d.k * d.per));
    blob = npy(out, [d.n, d.k, d.per], "<f4");
  } else {
    const r = basin.data;
    blob = npy(Int32Array.from(r.labels), [r.ny, r.nx], "<i4");
  }
  const q = new URLSearchParams({ tab: TAB, view: name, kind, note: $(name === "bifurcation" ? "bif-cmd" : "basin-cmd").textContent });
  if (TOKEN) q.set("token", TOKEN);
  const r = await fetch("/api/save?" + q.toString(), { method: "POST", body: blob });
  const j = await r.json();
  if (!r.ok) showError(j.error);
  else $(name === "bifurcation" ? "bif-status" : "basin-status").textContent = `saved ${j.saved}`;
}

main();
