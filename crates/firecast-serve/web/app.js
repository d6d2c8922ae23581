// FireCast web app: forecast map, live fire, threat report, runs browser.
// Plain ES2022, no dependencies; talks to the JSON API described in docs/web-app.md.
'use strict';

(() => {

// ============================================================================
// Constants
// ============================================================================

/** Okabe–Ito colours (colour-blind safe), ordered for white backgrounds. */
const PALETTE = ['#0072B2', '#D55E00', '#009E73', '#CC79A7', '#E69F00', '#56B4E9', '#000000', '#F0E442'];
const AGENT_ORDER = ['ppo', 'rule', 'rule-concentric', 'chaser', 'none'];
const AGENT_LABELS = {
  'ppo': 'Trained PPO agent',
  'rule': 'Rule-based plan (circle)',
  'rule-concentric': 'Rule-based plan (concentric circles)',
  'chaser': 'Chaser (flies to flames)',
  'none': 'No suppression',
};
const SIDE_COLORS = { left: '#0072B2', right: '#D55E00' };
const FONT = '12px system-ui, -apple-system, "Segoe UI", Roboto, "Helvetica Neue", Arial, sans-serif';
const FONT_BOLD = 'bold 12px system-ui, -apple-system, "Segoe UI", Roboto, "Helvetica Neue", Arial, sans-serif';
const KM_PER_DEG = 111.32;
const KM_PER_MILE = 1.609344;
const FEET_PER_MILE = 5280;

// ============================================================================
// Small utilities
// ============================================================================

/** Creates an element: h('div', {class: 'x', onclick: fn}, child, 'text', [more]). */
function h(tag, attrs, ...children) {
  const e = document.createElement(tag);
  if (attrs) {
    for (const [k, v] of Object.entries(attrs)) {
      if (v === null || v === undefined || v === false) continue;
      if (k === 'class') e.className = v;
      else if (k === 'style' && typeof v === 'object') Object.assign(e.style, v);
      else if (k === 'dataset') Object.assign(e.dataset, v);
      else if (k.startsWith('on') && typeof v === 'function') e.addEventListener(k.slice(2), v);
      else if (k === 'text') e.textContent = v;
      else if (v === true) e.setAttribute(k, '');
      else e.setAttribute(k, String(v));
    }
  }
  append(e, children);
  return e;
}

function append(e, children) {
  for (const c of [children].flat(Infinity)) {
    if (c === null || c === undefined || c === false) continue;
    e.append(c instanceof Node ? c : String(c));
  }
  return e;
}

/** Replaces an element's children, skipping null/false. */
function fill(e, ...children) {
  e.replaceChildren();
  return append(e, children);
}

const enc = encodeURIComponent;

function qs(obj) {
  const p = new URLSearchParams();
  for (const [k, v] of Object.entries(obj)) {
    if (v === null || v === undefined || v === '') continue;
    p.set(k, String(v));
  }
  return p.toString();
}

function clamp(v, lo, hi) { return Math.max(lo, Math.min(hi, v)); }

/** An error the API answered ({"error": {"code", "message"}}) or a failed request. */
class ApiError extends Error {
  constructor(code, message, status) {
    super(message);
    this.code = code;
    this.status = status;
  }
}

/** fetch + JSON; throws ApiError with the server's code and message on any failure. */
async function api(path, { method = 'GET', text = false } = {}) {
  let res;
  try {
    res = await fetch(path, {
      method,
      credentials: 'same-origin',
      headers: text ? {} : { 'Accept': 'application/json' },
      cache: 'no-store',
    });
  } catch (e) {
    throw new ApiError('network', `The FireCast server could not be reached (${e.message || e}).`, 0);
  }
  const raw = await res.text().catch(() => '');
  if (!res.ok) throw errorFromResponse(res, raw);
  if (text) return raw;
  try {
    return JSON.parse(raw);
  } catch {
    throw new ApiError('bad_response', `The server's answer to ${path} is not JSON: ${raw.slice(0, 200)}`, res.status);
  }
}

function errorFromResponse(res, raw) {
  let body = null;
  try { body = JSON.parse(raw); } catch { /* not JSON */ }
  if (body && body.error && (body.error.message || body.error.code)) {
    return new ApiError(body.error.code || 'error', body.error.message || body.error.code, res.status);
  }
  const text = (raw || '').trim().slice(0, 300);
  return new ApiError(`http_${res.status}`, `HTTP ${res.status} ${res.statusText || ''}${text ? ': ' + text : ''}`.trim(), res.status);
}

/** Reads at most maxBytes of a response body (previews of big files). */
async function fetchHead(path, maxBytes) {
  let res;
  try {
    res = await fetch(path, { credentials: 'same-origin', cache: 'no-store' });
  } catch (e) {
    throw new ApiError('network', `The FireCast server could not be reached (${e.message || e}).`, 0);
  }
  if (!res.ok) throw errorFromResponse(res, await res.text().catch(() => ''));
  if (!res.body || !res.body.getReader) {
    const t = await res.text();
    return { text: t.slice(0, maxBytes), truncated: t.length > maxBytes };
  }
  const reader = res.body.getReader();
  const chunks = [];
  let n = 0;
  let truncated = false;
  for (;;) {
    const { done, value } = await reader.read();
    if (done) break;
    chunks.push(value);
    n += value.length;
    if (n >= maxBytes) { truncated = true; reader.cancel().catch(() => {}); break; }
  }
  const all = new Uint8Array(n);
  let o = 0;
  for (const c of chunks) { all.set(c, o); o += c.length; }
  return { text: new TextDecoder().decode(all.subarray(0, Math.min(n, maxBytes))), truncated };
}

/** The visible error box (class `error`) for a failed request. */
function errorBox(err, what) {
  const code = err && err.code;
  const message = (err && err.message) || String(err);
  return h('div', { class: 'error', role: 'alert', 'data-code': code || null },
    what ? h('strong', null, `${what}: `) : null,
    message,
    code && !String(code).startsWith('http_') && code !== 'network' ? h('span', { class: 'code' }, ` [${code}]`) : null);
}

function showError(container, err, what) {
  container.replaceChildren(errorBox(err, what));
}

function loading(text) { return h('div', { class: 'loading' }, text); }

/** What a page holds (timers, sockets, listeners), released when the page is left. */
class Scope {
  constructor() { this.alive = true; this.fns = []; }
  add(fn) { this.fns.push(fn); }
  interval(fn, ms) { const t = setInterval(fn, ms); this.add(() => clearInterval(t)); return t; }
  timeout(fn, ms) { const t = setTimeout(fn, ms); this.add(() => clearTimeout(t)); return t; }
  listen(target, ev, fn, opts) { target.addEventListener(ev, fn, opts); this.add(() => target.removeEventListener(ev, fn, opts)); }
  onResize(fn) {
    let pending = false;
    this.listen(window, 'resize', () => {
      if (pending) return;
      pending = true;
      requestAnimationFrame(() => { pending = false; if (this.alive) fn(); });
    });
  }
  close() {
    this.alive = false;
    for (const f of this.fns.splice(0).reverse()) {
      try { f(); } catch (e) { console.error(e); }
    }
  }
}

// ---------- formatting ----------

const nf0 = new Intl.NumberFormat('en-US', { maximumFractionDigits: 0 });
const nf1 = new Intl.NumberFormat('en-US', { minimumFractionDigits: 1, maximumFractionDigits: 1 });

function fmtAcres(a) {
  if (!Number.isFinite(a)) return '—';
  return a > 0 && a < 10 ? nf1.format(a) : nf0.format(Math.round(a));
}

function fmtHours(hours) {
  if (!Number.isFinite(hours)) return '—';
  return `${nf1.format(hours)} h`;
}

function fmtPct(p) {
  if (!Number.isFinite(p)) return '—';
  const v = p * 100;
  if (v > 0 && v < 0.1) return '<0.1 %';
  if (v < 10 && v !== 0) return `${v.toFixed(1)} %`;
  if (v > 99.9 && v < 100) return '>99.9 %';
  return `${Math.round(v)} %`;
}

/** A number for tables: 4 significant digits, exponent for very small or big values. */
function fmtNum(v) {
  if (v === null || v === undefined) return '—';
  if (typeof v !== 'number') return String(v);
  if (!Number.isFinite(v)) return String(v);
  if (Number.isInteger(v) && Math.abs(v) < 1e9) return nf0.format(v);
  const a = Math.abs(v);
  if (a !== 0 && (a < 1e-3 || a >= 1e7)) return v.toExponential(3);
  return Number(v.toPrecision(4)).toLocaleString('en-US', { maximumFractionDigits: 6 });
}

function fmtDuration(secs) {
  if (secs === null || secs === undefined || !Number.isFinite(secs)) return '—';
  if (secs < 60) return `${secs < 10 ? secs.toFixed(1) : Math.round(secs)} s`;
  const m = Math.floor(secs / 60);
  const s = Math.round(secs % 60);
  if (m < 60) return `${m} min ${String(s).padStart(2, '0')} s`;
  const hh = Math.floor(m / 60);
  return `${hh} h ${String(m % 60).padStart(2, '0')} min`;
}

function fmtBytes(n) {
  if (!Number.isFinite(n)) return '—';
  if (n < 1024) return `${n} B`;
  const u = ['KiB', 'MiB', 'GiB', 'TiB'];
  let v = n / 1024;
  let i = 0;
  while (v >= 1024 && i < u.length - 1) { v /= 1024; i++; }
  return `${v < 10 ? v.toFixed(1) : Math.round(v)} ${u[i]}`;
}

function fmtLat(lat, digits = 4) {
  return `${Math.abs(lat).toFixed(digits)}° ${lat >= 0 ? 'N' : 'S'}`;
}
function fmtLon(lon, digits = 4) {
  return `${Math.abs(lon).toFixed(digits)}° ${lon >= 0 ? 'E' : 'W'}`;
}
function fmtPlace(lat, lon, digits = 4) { return `${fmtLat(lat, digits)}, ${fmtLon(lon, digits)}`; }

function compass(deg) {
  const names = ['N', 'NNE', 'NE', 'ENE', 'E', 'ESE', 'SE', 'SSE', 'S', 'SSW', 'SW', 'WSW', 'W', 'WNW', 'NW', 'NNW'];
  return names[Math.round((((deg % 360) + 360) % 360) / 22.5) % 16];
}

/** Seconds since the epoch of a timestamp the server wrote (number or text), or NaN. */
function parseTime(t) {
  if (t === null || t === undefined || t === '') return NaN;
  if (typeof t === 'number') return t > 1e12 ? t / 1000 : t;
  let s = String(t).trim();
  if (/^\d+(\.\d+)?$/.test(s)) { const v = Number(s); return v > 1e12 ? v / 1000 : v; }
  // "YYYY-MM-DD HH:MM:SS" without a zone: the registry writes UTC.
  if (/^\d{4}-\d{2}-\d{2}[ T]\d{2}:\d{2}(:\d{2}(\.\d+)?)?$/.test(s)) s = s.replace(' ', 'T') + 'Z';
  const ms = Date.parse(s);
  return Number.isFinite(ms) ? ms / 1000 : NaN;
}

function fmtTimestamp(t) {
  if (t === null || t === undefined || t === '') return '—';
  if (typeof t === 'number') {
    const d = new Date(parseTime(t) * 1000);
    return d.toISOString().replace('T', ' ').replace(/\.\d+Z$/, ' UTC');
  }
  return String(t).replace(/^(\d{4}-\d{2}-\d{2}[ T]\d{2}:\d{2}:\d{2})\.\d+$/, '$1');
}

/**
 * A run id short enough for a table cell that still tells neighbouring runs apart: registry ids
 * (`20261127T162113118-560bd8`) keep their time of day and random suffix (`16:21:13·560bd8`);
 * other long ids keep their head and tail. The full id goes in the title.
 */
function shortId(id) {
  if (!id) return '—';
  const s = String(id);
  const m = s.match(/^\d{8}T(\d{2})(\d{2})(\d{2})\d*-([0-9a-z]+)$/i);
  if (m) return `${m[1]}:${m[2]}:${m[3]}·${m[4]}`;
  return s.length > 16 ? `${s.slice(0, 7)}…${s.slice(-7)}` : s;
}

function statusBadge(status, title) {
  const s = String(status || 'unknown');
  return h('span', { class: `badge status-${s.replace(/[^a-z0-9_-]/gi, '')}`, title: title || null, 'data-status': s }, s);
}

function runLink(id, full) {
  return h('a', { href: `#/runs/${enc(id)}`, title: id, class: 'mono' }, full ? id : shortId(id));
}

/** Parameters as dotted names: {a: {b: 1}} → [["a.b", 1]]. */
function flatten(obj, prefix = '', out = []) {
  if (obj === null || typeof obj !== 'object' || Array.isArray(obj)) {
    out.push([prefix || '(value)', obj]);
    return out;
  }
  const keys = Object.keys(obj);
  if (keys.length === 0 && prefix) out.push([prefix, {}]);
  for (const k of keys) {
    const v = obj[k];
    const name = prefix ? `${prefix}.${k}` : k;
    if (v !== null && typeof v === 'object' && !Array.isArray(v)) flatten(v, name, out);
    else out.push([name, v]);
  }
  return out;
}

function fmtValue(v) {
  if (v === null || v === undefined) return '—';
  if (typeof v === 'number') return String(v);
  if (typeof v === 'string') return v;
  if (typeof v === 'boolean') return v ? 'true' : 'false';
  return JSON.stringify(v);
}

// ============================================================================
// Charts (canvas 2D)
// ============================================================================

function niceNum(range, round) {
  if (!(range > 0)) return 1;
  const exp = Math.floor(Math.log10(range));
  const f = range / Math.pow(10, exp);
  let nf;
  if (round) nf = f < 1.5 ? 1 : f < 3 ? 2 : f < 7 ? 5 : 10;
  else nf = f <= 1 ? 1 : f <= 2 ? 2 : f <= 5 ? 5 : 10;
  return nf * Math.pow(10, exp);
}

/** Ticks for [min, max]: {lo, hi, step, ticks}. */
function niceTicks(min, max, count = 5) {
  if (!Number.isFinite(min) || !Number.isFinite(max)) { min = 0; max = 1; }
  if (min === max) {
    const d = Math.abs(min) > 0 ? Math.abs(min) * 0.1 : 1;
    min -= d; max += d;
  }
  const step = niceNum(niceNum(max - min, false) / Math.max(1, count - 1), true);
  const lo = Math.floor(min / step + 1e-9) * step;
  const hi = Math.ceil(max / step - 1e-9) * step;
  const ticks = [];
  for (let v = lo; v <= hi + step * 1e-6; v += step) ticks.push(Math.abs(v) < step * 1e-9 ? 0 : v);
  return { lo, hi, step, ticks };
}

function tickLabel(v, step) {
  if (v === 0) return '0';
  const a = Math.abs(v);
  if (a >= 1e6 || a < 1e-4) return v.toExponential(Math.max(0, Math.min(3, -Math.floor(Math.log10(step)) + Math.floor(Math.log10(a)))));
  const decimals = Math.max(0, Math.min(8, -Math.floor(Math.log10(step) + 1e-9)));
  return v.toLocaleString('en-US', { minimumFractionDigits: decimals, maximumFractionDigits: decimals });
}

function logTickLabel(v) {
  const e = Math.round(Math.log10(v));
  if (Math.abs(v - Math.pow(10, e)) < 1e-9 * v && (e < -3 || e > 5)) return `1e${e}`;
  if (v >= 1e-3 && v < 1e6) return Number(v.toPrecision(3)).toLocaleString('en-US', { maximumFractionDigits: 6 });
  return v.toExponential(0);
}

/** EMA smoothing with bias correction (as TensorBoard does). */
function ema(ys, a) {
  if (!(a > 0)) return ys;
  const out = new Array(ys.length);
  let last = 0;
  let n = 0;
  for (let i = 0; i < ys.length; i++) {
    const y = ys[i];
    if (y === null || !Number.isFinite(y)) { out[i] = y; continue; }
    last = last * a + (1 - a) * y;
    n++;
    out[i] = last / (1 - Math.pow(a, n));
  }
  return out;
}

/**
 * Draws a line chart on a canvas sized to its CSS width.
 * opts: {series: [{label, xs, ys, color, dash, width, alpha, legend}], xLabel, yLabel,
 *        logY, xMin, xMax, yMin, yMax, height, vline, empty}
 */
function drawChart(canvas, opts) {
  const dpr = window.devicePixelRatio || 1;
  const cssW = Math.max(160, Math.round(canvas.clientWidth || (canvas.parentElement && canvas.parentElement.clientWidth) || 400));
  const cssH = opts.height || 240;
  canvas.style.height = `${cssH}px`;
  if (canvas.width !== Math.round(cssW * dpr) || canvas.height !== Math.round(cssH * dpr)) {
    canvas.width = Math.round(cssW * dpr);
    canvas.height = Math.round(cssH * dpr);
  }
  const ctx = canvas.getContext('2d');
  ctx.setTransform(dpr, 0, 0, dpr, 0, 0);
  ctx.clearRect(0, 0, cssW, cssH);
  ctx.fillStyle = '#fff';
  ctx.fillRect(0, 0, cssW, cssH);
  ctx.font = FONT;
  ctx.textBaseline = 'middle';

  const logY = !!opts.logY;
  const series = (opts.series || []).filter(Boolean);
  // Data range.
  let xmin = Infinity, xmax = -Infinity, ymin = Infinity, ymax = -Infinity;
  let dropped = 0;
  for (const s of series) {
    for (let i = 0; i < s.xs.length; i++) {
      const x = s.xs[i];
      const y = s.ys[i];
      if (y === null || !Number.isFinite(x) || !Number.isFinite(y)) continue;
      if (logY && y <= 0) { dropped++; continue; }
      if (x < xmin) xmin = x;
      if (x > xmax) xmax = x;
      if (y < ymin) ymin = y;
      if (y > ymax) ymax = y;
    }
  }
  const hasData = xmin <= xmax;
  if (opts.xMin !== undefined) xmin = Math.min(opts.xMin, hasData ? xmin : opts.xMin);
  if (opts.xMax !== undefined) xmax = Math.max(opts.xMax, hasData ? xmax : opts.xMax);
  if (opts.yMin !== undefined && !logY) ymin = Math.min(opts.yMin, hasData ? ymin : opts.yMin);
  if (opts.yMax !== undefined && !logY) ymax = Math.max(opts.yMax, hasData ? ymax : opts.yMax);
  if (!Number.isFinite(xmin) || !Number.isFinite(xmax)) { xmin = 0; xmax = 1; }
  if (!Number.isFinite(ymin) || !Number.isFinite(ymax)) { ymin = logY ? 1 : 0; ymax = logY ? 10 : 1; }
  if (xmin === xmax) { xmin -= 0.5; xmax += 0.5; }

  // Y ticks.
  let yLo, yHi, yTicks, yLabels;
  if (logY) {
    let e0 = Math.floor(Math.log10(ymin));
    let e1 = Math.ceil(Math.log10(ymax));
    if (e0 === e1) e1 = e0 + 1;
    yLo = Math.pow(10, e0);
    yHi = Math.pow(10, e1);
    yTicks = [];
    const decades = e1 - e0;
    const mult = decades <= 2 ? [1, 2, 5] : [1];
    const stride = Math.max(1, Math.ceil(decades / 6));
    for (let e = e0; e <= e1; e += stride) for (const m of mult) {
      const v = m * Math.pow(10, e);
      if (v >= yLo * 0.999 && v <= yHi * 1.001) yTicks.push(v);
    }
    yLabels = yTicks.map(logTickLabel);
  } else {
    const t = niceTicks(ymin, ymax, 5);
    yLo = t.lo; yHi = t.hi; yTicks = t.ticks;
    yLabels = yTicks.map((v) => tickLabel(v, t.step));
  }
  const xt = niceTicks(xmin, xmax, Math.max(3, Math.min(8, Math.floor(cssW / 90))));
  const xTicks = xt.ticks.filter((v) => v >= xmin - 1e-9 * Math.abs(xt.step) && v <= xmax + 1e-9 * Math.abs(xt.step));
  const xLabels = xTicks.map((v) => tickLabel(v, xt.step));

  // Legend layout (top, wrapping).
  const legendItems = series.filter((s) => s.label && s.legend !== false);
  const legendRows = [];
  let row = [];
  let rowW = 0;
  const maxLegendW = cssW - 16;
  for (const s of legendItems) {
    const w = 26 + ctx.measureText(s.label).width + 14;
    if (row.length && rowW + w > maxLegendW) { legendRows.push(row); row = []; rowW = 0; }
    row.push({ s, w });
    rowW += w;
  }
  if (row.length) legendRows.push(row);
  const legendH = legendRows.length * 17 + (legendRows.length ? 4 : 0);

  const yLabelW = Math.max(...yLabels.map((l) => ctx.measureText(l).width), 10);
  const padL = Math.ceil(yLabelW) + 10 + (opts.yLabel ? 18 : 0);
  const padR = 14;
  const padT = 8 + legendH;
  const padB = 22 + (opts.xLabel ? 18 : 0);
  const pw = Math.max(10, cssW - padL - padR);
  const ph = Math.max(10, cssH - padT - padB);
  const X = (x) => padL + ((x - xmin) / (xmax - xmin)) * pw;
  const Y = logY
    ? (y) => padT + ph - ((Math.log10(y) - Math.log10(yLo)) / (Math.log10(yHi) - Math.log10(yLo))) * ph
    : (y) => padT + ph - ((y - yLo) / (yHi - yLo)) * ph;

  // Grid and axes.
  ctx.strokeStyle = '#e6e8eb';
  ctx.lineWidth = 1;
  ctx.fillStyle = '#4a525b';
  ctx.textAlign = 'right';
  yTicks.forEach((v, i) => {
    const y = Math.round(Y(v)) + 0.5;
    ctx.beginPath(); ctx.moveTo(padL, y); ctx.lineTo(padL + pw, y); ctx.stroke();
    ctx.fillText(yLabels[i], padL - 6, y);
  });
  ctx.textAlign = 'center';
  ctx.textBaseline = 'top';
  xTicks.forEach((v, i) => {
    const x = Math.round(X(v)) + 0.5;
    ctx.beginPath(); ctx.moveTo(x, padT); ctx.lineTo(x, padT + ph); ctx.stroke();
    ctx.fillText(xLabels[i], clamp(x, padL + 8, padL + pw - 8), padT + ph + 5);
  });
  ctx.strokeStyle = '#9aa2ab';
  ctx.beginPath();
  ctx.moveTo(padL + 0.5, padT); ctx.lineTo(padL + 0.5, padT + ph + 0.5); ctx.lineTo(padL + pw, padT + ph + 0.5);
  ctx.stroke();
  ctx.fillStyle = '#2b3138';
  if (opts.xLabel) {
    ctx.textBaseline = 'bottom';
    ctx.fillText(opts.xLabel, padL + pw / 2, cssH - 3);
  }
  if (opts.yLabel) {
    ctx.save();
    ctx.translate(12, padT + ph / 2);
    ctx.rotate(-Math.PI / 2);
    ctx.textBaseline = 'middle';
    ctx.textAlign = 'center';
    let label = opts.yLabel;
    while (ctx.measureText(label).width > ph && label.length > 4) label = label.slice(0, -2);
    if (label !== opts.yLabel) label += '…';
    ctx.fillText(label, 0, 0);
    ctx.restore();
  }

  // Series.
  ctx.save();
  ctx.beginPath();
  ctx.rect(padL, padT - 2, pw + 2, ph + 4);
  ctx.clip();
  for (const s of series) {
    ctx.strokeStyle = s.color || PALETTE[0];
    ctx.globalAlpha = s.alpha === undefined ? 1 : s.alpha;
    ctx.lineWidth = s.width || 2;
    ctx.setLineDash(s.dash || []);
    ctx.lineJoin = 'round';
    ctx.beginPath();
    let pen = false;
    let points = 0;
    let lastPt = null;
    for (let i = 0; i < s.xs.length; i++) {
      const x = s.xs[i];
      const y = s.ys[i];
      if (y === null || !Number.isFinite(x) || !Number.isFinite(y) || (logY && y <= 0)) { pen = false; continue; }
      const px = X(x);
      const py = Y(y);
      if (pen) ctx.lineTo(px, py); else ctx.moveTo(px, py);
      pen = true;
      points++;
      lastPt = [px, py];
    }
    ctx.stroke();
    if (points === 1 && lastPt) {
      ctx.setLineDash([]);
      ctx.fillStyle = s.color || PALETTE[0];
      ctx.beginPath(); ctx.arc(lastPt[0], lastPt[1], 3, 0, Math.PI * 2); ctx.fill();
    }
  }
  ctx.restore();
  ctx.globalAlpha = 1;
  ctx.setLineDash([]);

  if (opts.vline !== undefined && Number.isFinite(opts.vline)) {
    const x = Math.round(X(opts.vline)) + 0.5;
    if (x >= padL && x <= padL + pw + 1) {
      ctx.strokeStyle = 'rgba(40,40,40,.55)';
      ctx.lineWidth = 1;
      ctx.setLineDash([3, 3]);
      ctx.beginPath(); ctx.moveTo(x, padT); ctx.lineTo(x, padT + ph); ctx.stroke();
      ctx.setLineDash([]);
    }
  }

  // Legend.
  ctx.textAlign = 'left';
  ctx.textBaseline = 'middle';
  legendRows.forEach((r, ri) => {
    let x = padL;
    const y = 8 + ri * 17 + 6;
    for (const { s, w } of r) {
      ctx.strokeStyle = s.color || PALETTE[0];
      ctx.lineWidth = 2.5;
      ctx.setLineDash(s.dash || []);
      ctx.beginPath(); ctx.moveTo(x, y); ctx.lineTo(x + 20, y); ctx.stroke();
      ctx.setLineDash([]);
      ctx.fillStyle = '#2b3138';
      ctx.fillText(s.label, x + 26, y);
      x += w;
    }
  });

  if (!hasData) {
    ctx.fillStyle = '#6b7480';
    ctx.textAlign = 'center';
    ctx.font = FONT;
    ctx.fillText(opts.empty || 'no data yet', padL + pw / 2, padT + ph / 2);
  } else if (logY && dropped > 0) {
    ctx.fillStyle = '#8a5a00';
    ctx.textAlign = 'right';
    ctx.textBaseline = 'top';
    ctx.fillText(`${dropped} value${dropped > 1 ? 's' : ''} ≤ 0 not shown (log scale)`, padL + pw - 4, padT + 4);
  }
}

// ============================================================================
// Shared data
// ============================================================================

let coveragePromise = null;
function getCoverage() {
  if (!coveragePromise) {
    coveragePromise = api('/api/coverage').catch((e) => { coveragePromise = null; throw e; });
  }
  return coveragePromise;
}

const probabilityMaps = new Map(); // date -> Promise<map>
function getProbabilityMap(date) {
  if (!probabilityMaps.has(date)) {
    const p = api(`/api/probabilityMap?${qs({ date })}`).catch((e) => { probabilityMaps.delete(date); throw e; });
    probabilityMaps.set(date, p);
  }
  return probabilityMaps.get(date);
}

function agentList(coverage) {
  const byId = new Map();
  for (const a of (coverage && Array.isArray(coverage.agents) ? coverage.agents : [])) byId.set(a.id, a);
  const ids = [...AGENT_ORDER, ...[...byId.keys()].filter((id) => !AGENT_ORDER.includes(id))];
  return ids.map((id) => {
    const a = byId.get(id);
    return {
      id,
      label: AGENT_LABELS[id] || (a && a.label) || id,
      available: a ? a.available !== false : !coverage,
      reason: a && a.reason ? a.reason : (a || !coverage ? '' : 'not offered by this server'),
    };
  });
}

function defaultLeftAgent(coverage) {
  const ppo = agentList(coverage).find((a) => a.id === 'ppo');
  return ppo && ppo.available ? 'ppo' : 'chaser';
}

// Sequential colour scale (yellow → orange → red → dark red), readable for colour-blind users.
const PROB_STOPS = [
  [0.0, [255, 255, 204]], [0.125, [255, 237, 160]], [0.25, [254, 217, 118]], [0.375, [254, 178, 76]],
  [0.5, [253, 141, 60]], [0.625, [252, 78, 42]], [0.75, [227, 26, 28]], [0.875, [189, 0, 38]], [1.0, [128, 0, 38]],
];
function probColor(p) {
  const v = clamp(p, 0, 1);
  for (let i = 1; i < PROB_STOPS.length; i++) {
    const [p1, c1] = PROB_STOPS[i];
    if (v <= p1) {
      const [p0, c0] = PROB_STOPS[i - 1];
      const t = (v - p0) / (p1 - p0);
      return c0.map((c, k) => Math.round(c + (c1[k] - c) * t));
    }
  }
  return PROB_STOPS[PROB_STOPS.length - 1][1];
}
function probCss(p, alpha = 1) {
  const [r, g, b] = probColor(p);
  return alpha === 1 ? `rgb(${r},${g},${b})` : `rgba(${r},${g},${b},${alpha})`;
}
/** A text colour with contrast on white for a probability. */
function probTextCss(p) {
  return p < 0.35 ? '#8a5a00' : probCss(Math.max(p, 0.6));
}
// The day's chance relative to the usual day, on the colour scale: days at or below the usual
// day stay pale (¼× at 0, 1× at 0.2), warmer colours only above it (2× at 0.47, 4× at 0.73, 8×
// at 1): an orange cell is one above the usual day. Log scale on each side.
const REL_USUAL_AT = 0.2;
function relPosition(rel) {
  if (!(rel > 0)) return 0;
  if (rel <= 1) return clamp(REL_USUAL_AT * (Math.log2(rel) + 2) / 2, 0, REL_USUAL_AT);
  return clamp(REL_USUAL_AT + (1 - REL_USUAL_AT) * Math.log2(rel) / 3, REL_USUAL_AT, 1);
}
/** A text colour for the day's chance by its multiple of the usual day: quiet below 1.5×,
 *  amber below twice it, red beyond (a usual day is not an alarm). */
function relTextCss(rel) {
  if (!(rel >= 1.5)) return '#3c4450';
  if (rel < 2) return '#8a5a00';
  return probCss(rel <= 4 ? 0.75 : 0.95);
}
function fmtTimes(rel) {
  if (!Number.isFinite(rel)) return '—';
  return `${rel < 10 ? rel.toFixed(1) : rel.toFixed(0)}×`;
}
/** A small daily probability as a percent people can read (0.036 %, 1.2 %). */
function fmtDailyPct(p) {
  if (!Number.isFinite(p)) return '—';
  const pct = p * 100;
  if (pct >= 10) return `${pct.toFixed(0)} %`;
  if (pct >= 1) return `${pct.toFixed(1)} %`;
  return `${pct.toPrecision(2)} %`;
}
/** The map's values to colour: the day's chance relative to the usual day where the map has it. */
function mapValues(map) {
  if (map && Array.isArray(map.daily_probability) && Number.isFinite(map.usual_daily) && map.usual_daily > 0) {
    return { rows: map.daily_probability, relative: true, usual: map.usual_daily };
  }
  return { rows: map ? map.probability : null, relative: false };
}

function defaultDate(cov) {
  const last = cov.last_date;
  const first = cov.first_date;
  if (!last) return '';
  const summer = `${last.slice(0, 4)}-08-01`;
  if (summer >= first && summer <= last) return summer;
  return last;
}

// ============================================================================
// Router
// ============================================================================

let currentScope = null;

function parseHash() {
  const raw = location.hash.replace(/^#/, '') || '/';
  const i = raw.indexOf('?');
  const path = (i >= 0 ? raw.slice(0, i) : raw) || '/';
  const params = new URLSearchParams(i >= 0 ? raw.slice(i + 1) : '');
  return { path, params };
}

function setNav(which) {
  for (const a of document.querySelectorAll('.topnav a')) {
    a.classList.toggle('active', a.dataset.nav === which);
    if (a.dataset.nav === which) a.setAttribute('aria-current', 'page'); else a.removeAttribute('aria-current');
  }
}

function route() {
  if (currentScope) currentScope.close();
  const scope = new Scope();
  currentScope = scope;
  const app = document.getElementById('app');
  app.replaceChildren();
  const { path, params } = parseHash();
  let m;
  try {
    if (path === '/' || path === '') {
      setNav('forecast'); document.title = 'FireCast — forecast';
      pageForecast(app, params, scope);
    } else if (path === '/fire') {
      setNav('forecast'); document.title = 'FireCast — live fire';
      pageFire(app, params, scope);
    } else if (path === '/runs') {
      setNav('runs'); document.title = 'FireCast — runs';
      pageRuns(app, params, scope);
    } else if ((m = path.match(/^\/runs\/(.+)$/))) {
      setNav('runs'); document.title = 'FireCast — run';
      pageRun(app, m[1], scope);
    } else if (path === '/compare') {
      setNav('runs'); document.title = 'FireCast — compare runs';
      pageCompare(app, params, scope);
    } else if (path === '/tables/forecast') {
      setNav('table3'); document.title = 'FireCast — Table III';
      pageTableForecast(app, params, scope);
    } else if (path === '/tables/rl') {
      setNav('table4'); document.title = 'FireCast — Table IV';
      pageTableRl(app, params, scope);
    } else if (path === '/datasets') {
      setNav('datasets'); document.title = 'FireCast — datasets';
      pageDatasets(app, params, scope);
    } else if ((m = path.match(/^\/datasets\/(.+)$/))) {
      setNav('datasets'); document.title = 'FireCast — dataset';
      pageDataset(app, m[1], scope);
    } else {
      setNav('');
      document.title = 'FireCast';
      app.append(h('div', { class: 'card' },
        errorBox(new ApiError('not_found', `There is no page at #${path}.`), 'Not found'),
        h('p', null, h('a', { href: '#/' }, 'Go to the forecast map'), ' · ', h('a', { href: '#/runs' }, 'Browse runs'))));
    }
  } catch (e) {
    console.error(e);
    app.append(errorBox(e, 'This page failed'));
  }
}

function replaceHash(hash) {
  if (location.hash !== hash) history.replaceState(history.state, '', hash);
}

// ============================================================================
// Page 1: forecast and map
// ============================================================================

function pageForecast(root, params, scope) {
  const st = {
    cov: null,
    img: null,
    imgFailed: false,
    lat: parseFloat(params.get('lat')),
    lon: parseFloat(params.get('lon')),
    date: params.get('date') || '',
    forecast: null,
    map: null,
    seq: 0,
    mapSeq: 0,
    hover: null,
    view: null, // projection of the last draw
  };

  const dateInput = h('input', { type: 'date', id: 'date', 'data-testid': 'date', disabled: true, 'aria-label': 'Day of the forecast' });
  const canvas = h('canvas', { id: 'map', 'data-testid': 'map', width: 900, height: 600, role: 'img', 'aria-label': 'Map of the data area: click to pick a place' });
  const mapWrap = h('div', { class: 'map-wrap' }, canvas);
  const mapStatus = h('div', { id: 'map-status' });
  const readout = h('div', { class: 'map-readout', id: 'map-readout' }, 'Click the map to pick a place.');
  const legendCanvas = h('canvas', { width: 200, height: 14, style: { width: '200px', height: '14px' } });
  const legend = h('div', { class: 'map-legend', id: 'map-legend' },
    h('strong', { id: 'legend-title' }, 'ignition chance'), h('span', { id: 'legend-min' }, ''), legendCanvas, h('span', { id: 'legend-max' }, ''),
    h('span', { class: 'muted', id: 'legend-note' }, ''));
  const covStatus = h('div', { id: 'coverage-status' }, loading('Loading the data coverage…'));

  const forecastBody = h('div', { id: 'forecast-body' },
    h('div', { class: 'placeholder' }, h('strong', null, 'Pick a place on the map'), ' and a day to see the chance of a wildfire igniting there.'));
  const startBtn = h('button', { id: 'start-fire', 'data-testid': 'start-fire', class: 'primary big', disabled: true, type: 'button' }, 'Start the fire');
  const forecastPanel = h('section', { class: 'card', id: 'forecast', 'data-testid': 'forecast', 'aria-live': 'polite' },
    h('h2', null, 'Ignition forecast'), forecastBody, startBtn,
    h('p', { class: 'note' }, 'Starting the fire opens a live simulation of how it would spread here on this day, with a trained helicopter agent beside a rule-based plan.'));

  root.append(
    h('div', { class: 'page-title' }, h('h1', null, 'Forecast & fire')),
    h('p', { class: 'lede' }, 'Pick a day and click a place inside the GRIDMET data box: FireCast forecasts the chance that a wildfire ignites there, maps that chance over the whole area, and can start the fire to show how it spreads with and without helicopter suppression.'),
    h('div', { class: 'forecast-grid' },
      h('section', { class: 'card', id: 'map-card' },
        h('div', { class: 'toolbar' },
          h('label', { class: 'field', for: 'date' }, h('span', null, 'Day'), dateInput),
          h('span', { class: 'muted small', id: 'date-range' }, '')),
        covStatus, mapWrap, legend, readout, mapStatus),
      forecastPanel));

  startBtn.addEventListener('click', () => {
    if (!Number.isFinite(st.lat) || !Number.isFinite(st.lon) || !st.date) return;
    const left = defaultLeftAgent(st.cov);
    location.hash = `#/fire?${qs({ lat: st.lat.toFixed(4), lon: st.lon.toFixed(4), date: st.date, left, right: 'rule', seed: 0 })}`;
  });

  dateInput.addEventListener('change', () => {
    const v = dateInput.value;
    if (!v) return;
    st.date = v;
    updateHash();
    if (Number.isFinite(st.lat)) pick(st.lat, st.lon);
  });

  function updateHash() {
    const q = { date: st.date };
    if (Number.isFinite(st.lat)) { q.lat = st.lat.toFixed(4); q.lon = st.lon.toFixed(4); }
    replaceHash(`#/?${qs(q)}`);
  }

  // ---------- projection ----------
  function bounds() {
    const b = st.cov && st.cov.basemap;
    if (b && Number.isFinite(b.lat_min) && b.lat_max > b.lat_min && b.lon_max > b.lon_min) return b;
    const c = st.cov;
    const padLat = (c.lat_max - c.lat_min) * 0.1 || 0.1;
    const padLon = (c.lon_max - c.lon_min) * 0.1 || 0.1;
    return { lat_min: c.lat_min - padLat, lat_max: c.lat_max + padLat, lon_min: c.lon_min - padLon, lon_max: c.lon_max + padLon };
  }

  function aspect() {
    const b = bounds();
    if (b.width > 0 && b.height > 0) return b.width / b.height;
    const latc = (b.lat_min + b.lat_max) / 2;
    return ((b.lon_max - b.lon_min) * Math.cos(latc * Math.PI / 180)) / (b.lat_max - b.lat_min);
  }

  function draw() {
    if (!st.cov) return;
    const b = bounds();
    const dpr = window.devicePixelRatio || 1;
    let cssW = Math.max(200, mapWrap.clientWidth || 900);
    let cssH = cssW / aspect();
    const maxH = Math.max(300, window.innerHeight * 0.78);
    if (cssH > maxH) { cssH = maxH; cssW = cssH * aspect(); }
    canvas.style.width = `${Math.round(cssW)}px`;
    canvas.style.height = `${Math.round(cssH)}px`;
    canvas.width = Math.round(cssW * dpr);
    canvas.height = Math.round(cssH * dpr);
    const ctx = canvas.getContext('2d');
    ctx.setTransform(dpr, 0, 0, dpr, 0, 0);
    const W = cssW;
    const H = cssH;
    const X = (lon) => ((lon - b.lon_min) / (b.lon_max - b.lon_min)) * W;
    const Y = (lat) => ((b.lat_max - lat) / (b.lat_max - b.lat_min)) * H;
    st.view = { W, H, b };

    // Base map.
    ctx.fillStyle = '#d8d5cc';
    ctx.fillRect(0, 0, W, H);
    if (st.img && st.img.complete && st.img.naturalWidth > 0) {
      ctx.imageSmoothingEnabled = true;
      ctx.drawImage(st.img, 0, 0, W, H);
    } else if (st.imgFailed) {
      ctx.fillStyle = '#6b7480';
      ctx.font = FONT;
      ctx.textAlign = 'center';
      ctx.fillText('base map unavailable', W / 2, H / 2);
    }

    // Probability cells.
    const c = st.cov;
    const values = mapValues(st.map);
    if (st.map && Array.isArray(values.rows)) {
      const cell = c.cell_deg || 1 / 24;
      const lats = st.map.lats || c.lats;
      const lons = st.map.lons || c.lons;
      // Cells at full opacity on their own layer, then the layer at once (no seams where cells overlap).
      const layer = document.createElement('canvas');
      layer.width = canvas.width;
      layer.height = canvas.height;
      const lctx = layer.getContext('2d');
      lctx.setTransform(dpr, 0, 0, dpr, 0, 0);
      for (let r = 0; r < values.rows.length; r++) {
        const rowVals = values.rows[r];
        if (!rowVals) continue;
        for (let k = 0; k < rowVals.length; k++) {
          const v = rowVals[k];
          if (v === null || v === undefined || !Number.isFinite(v)) continue;
          const p = values.relative ? relPosition(v / values.usual) : v;
          const x0 = Math.floor(X(lons[k] - cell / 2));
          const x1 = Math.ceil(X(lons[k] + cell / 2));
          const y0 = Math.floor(Y(lats[r] + cell / 2));
          const y1 = Math.ceil(Y(lats[r] - cell / 2));
          lctx.fillStyle = probCss(p);
          lctx.fillRect(x0, y0, x1 - x0, y1 - y0);
        }
      }
      ctx.save();
      ctx.setTransform(1, 0, 0, 1, 0, 0);
      ctx.globalAlpha = 0.6;
      ctx.drawImage(layer, 0, 0);
      ctx.restore();
    }

    drawGraticule(ctx, W, H, b, X, Y);

    // GRIDMET data box.
    const bx0 = X(c.lon_min), bx1 = X(c.lon_max), by0 = Y(c.lat_max), by1 = Y(c.lat_min);
    ctx.lineWidth = 4;
    ctx.strokeStyle = 'rgba(255,255,255,.9)';
    ctx.strokeRect(bx0, by0, bx1 - bx0, by1 - by0);
    ctx.lineWidth = 2;
    ctx.strokeStyle = '#111';
    ctx.strokeRect(bx0, by0, bx1 - bx0, by1 - by0);
    ctx.font = FONT_BOLD;
    const label = 'GRIDMET data';
    const lw = ctx.measureText(label).width + 10;
    const lx = clamp(bx0, 2, W - lw - 2);
    const ly = by0 - 20 >= 2 ? by0 - 20 : by0 + 2;
    ctx.fillStyle = '#111';
    ctx.fillRect(lx, ly, lw, 18);
    ctx.fillStyle = '#fff';
    ctx.textAlign = 'left';
    ctx.textBaseline = 'middle';
    ctx.fillText(label, lx + 5, ly + 9);

    // The forecast's GRIDMET cell, then the marker.
    if (st.forecast && Number.isFinite(st.forecast.cell_lat)) {
      const cell = c.cell_deg || 1 / 24;
      const cx0 = X(st.forecast.cell_lon - cell / 2), cx1 = X(st.forecast.cell_lon + cell / 2);
      const cy0 = Y(st.forecast.cell_lat + cell / 2), cy1 = Y(st.forecast.cell_lat - cell / 2);
      ctx.lineWidth = 1.5;
      ctx.strokeStyle = '#fff';
      ctx.setLineDash([4, 3]);
      ctx.strokeRect(cx0, cy0, cx1 - cx0, cy1 - cy0);
      ctx.setLineDash([]);
    }
    if (Number.isFinite(st.lat) && Number.isFinite(st.lon)) drawMarker(ctx, X(st.lon), Y(st.lat));

    drawNorthArrow(ctx, W);
    drawScaleBar(ctx, W, H, b);
  }

  function drawMarker(ctx, x, y) {
    ctx.save();
    ctx.translate(x, y);
    ctx.fillStyle = 'rgba(0,0,0,.25)';
    ctx.beginPath(); ctx.ellipse(0, 0, 7, 3, 0, 0, Math.PI * 2); ctx.fill();
    ctx.beginPath();
    ctx.moveTo(0, 0);
    ctx.bezierCurveTo(-4, -8, -10, -12, -10, -20);
    ctx.arc(0, -20, 10, Math.PI, 0);
    ctx.bezierCurveTo(10, -12, 4, -8, 0, 0);
    ctx.closePath();
    ctx.fillStyle = '#d9480f';
    ctx.fill();
    ctx.lineWidth = 2;
    ctx.strokeStyle = '#fff';
    ctx.stroke();
    ctx.fillStyle = '#fff';
    ctx.beginPath(); ctx.arc(0, -20, 4, 0, Math.PI * 2); ctx.fill();
    ctx.restore();
  }

  function drawGraticule(ctx, W, H, b, X, Y) {
    const span = Math.max(b.lat_max - b.lat_min, b.lon_max - b.lon_min);
    const steps = [0.01, 0.02, 0.05, 0.1, 0.2, 0.25, 0.5, 1, 2, 5, 10];
    let step = steps[steps.length - 1];
    for (const s of steps) { if (span / s <= 7) { step = s; break; } }
    const digits = step >= 1 ? 0 : step >= 0.1 ? (step === 0.25 ? 2 : 1) : 2;
    ctx.save();
    ctx.strokeStyle = 'rgba(255,255,255,.55)';
    ctx.lineWidth = 1;
    ctx.setLineDash([2, 4]);
    ctx.font = FONT;
    const labels = [];
    for (let lat = Math.ceil(b.lat_min / step) * step; lat <= b.lat_max; lat += step) {
      const y = Math.round(Y(lat)) + 0.5;
      ctx.beginPath(); ctx.moveTo(0, y); ctx.lineTo(W, y); ctx.stroke();
      labels.push({ text: fmtLat(lat, digits), x: 4, y, align: 'left' });
    }
    for (let lon = Math.ceil(b.lon_min / step) * step; lon <= b.lon_max; lon += step) {
      const x = Math.round(X(lon)) + 0.5;
      ctx.beginPath(); ctx.moveTo(x, 0); ctx.lineTo(x, H); ctx.stroke();
      labels.push({ text: fmtLon(lon, digits), x, y: H - 10, align: 'center' });
    }
    ctx.setLineDash([]);
    ctx.textBaseline = 'middle';
    for (const l of labels) {
      if (l.align === 'left' && l.y > H - 84 && l.x < 200) continue; // the scale bar's corner
      const w = ctx.measureText(l.text).width;
      let x0 = l.align === 'left' ? l.x : l.x - w / 2;
      if (l.y < 10 || l.y > H - 4 || x0 + w < 0 || x0 > W) continue;
      if (l.align === 'center' && (x0 < 60 || x0 + w > W - 4)) continue; // leave the corner to the latitude labels
      x0 = clamp(x0, 2, W - w - 2);
      ctx.fillStyle = 'rgba(255,255,255,.8)';
      ctx.fillRect(x0 - 3, l.y - 8, w + 6, 16);
      ctx.fillStyle = '#222';
      ctx.textAlign = 'left';
      ctx.fillText(l.text, x0, l.y);
    }
    ctx.restore();
  }

  function drawNorthArrow(ctx, W) {
    const x = W - 30;
    const y = 16;
    ctx.save();
    ctx.fillStyle = 'rgba(255,255,255,.85)';
    ctx.beginPath(); ctx.arc(x, y + 16, 18, 0, Math.PI * 2); ctx.fill();
    ctx.beginPath();
    ctx.moveTo(x, y + 2); ctx.lineTo(x + 8, y + 26); ctx.lineTo(x, y + 20); ctx.closePath();
    ctx.fillStyle = '#111'; ctx.fill();
    ctx.beginPath();
    ctx.moveTo(x, y + 2); ctx.lineTo(x - 8, y + 26); ctx.lineTo(x, y + 20); ctx.closePath();
    ctx.fillStyle = '#777'; ctx.fill();
    ctx.fillStyle = '#111';
    ctx.font = FONT_BOLD;
    ctx.textAlign = 'center';
    ctx.textBaseline = 'top';
    ctx.fillText('N', x, y + 36);
    ctx.restore();
  }

  function drawScaleBar(ctx, W, H, b) {
    const latc = (b.lat_min + b.lat_max) / 2;
    const kmAcross = (b.lon_max - b.lon_min) * KM_PER_DEG * Math.cos(latc * Math.PI / 180);
    const pxPerKm = W / kmAcross;
    const target = W / 5;
    const nice = (units, pxPer) => {
      const cands = [0.1, 0.2, 0.5, 1, 2, 5, 10, 20, 25, 50, 100, 200, 500, 1000];
      let best = cands[0];
      for (const c of cands) if (c * pxPer <= target) best = c;
      return best;
    };
    const km = nice('km', pxPerKm);
    const pxPerMi = pxPerKm * KM_PER_MILE;
    const mi = nice('mi', pxPerMi);
    const x0 = 12;
    const y0 = H - 74;
    const wKm = km * pxPerKm;
    const wMi = mi * pxPerMi;
    ctx.save();
    ctx.font = FONT;
    const boxW = Math.max(wKm, wMi) + 70;
    ctx.fillStyle = 'rgba(255,255,255,.85)';
    ctx.fillRect(x0 - 6, y0 - 8, boxW, 46);
    const bar = (y, w, label) => {
      ctx.fillStyle = '#111';
      ctx.fillRect(x0, y, w, 5);
      ctx.fillStyle = '#fff';
      ctx.fillRect(x0 + w / 2, y + 1, w / 2 - 1, 3);
      ctx.strokeStyle = '#111';
      ctx.lineWidth = 1;
      ctx.strokeRect(x0 + 0.5, y + 0.5, w - 1, 4);
      ctx.fillStyle = '#111';
      ctx.textAlign = 'left';
      ctx.textBaseline = 'middle';
      ctx.fillText(label, x0 + w + 6, y + 3);
    };
    bar(y0, wKm, `${km} km`);
    bar(y0 + 20, wMi, `${mi} mi`);
    ctx.restore();
  }

  function drawLegend() {
    const ctx = legendCanvas.getContext('2d');
    for (let i = 0; i < 200; i++) {
      ctx.fillStyle = probCss(i / 199);
      ctx.fillRect(i, 0, 1, 14);
    }
    const note = legend.querySelector('#legend-note');
    const values = mapValues(st.map);
    legend.querySelector('#legend-title').textContent = values.relative ? 'chance of ignition vs the usual day' : 'model score';
    legend.querySelector('#legend-min').textContent = values.relative ? '¼×' : '0 %';
    legend.querySelector('#legend-max').textContent = values.relative ? '8× or more' : '100 %';
    if (st.map && values.relative) {
      note.textContent = `· ${st.map.date} · the usual day: ${fmtDailyPct(values.usual)} chance a cell · mean over ${st.map.seeds} seed${st.map.seeds === 1 ? '' : 's'} · blank cells: no complete weather window`;
      const x = Math.round(relPosition(1) * 199);
      ctx.fillStyle = '#000';
      ctx.fillRect(x - 1, 0, 2, 14);
    } else if (st.map) {
      note.textContent = `· ${st.map.date} · the model's score on its training samples' scale (about 40 % fires), not a daily chance · mean over ${st.map.seeds} seed${st.map.seeds === 1 ? '' : 's'}, alert threshold ${fmtPct(st.map.threshold)} · blank cells: no complete weather window`;
      if (Number.isFinite(st.map.threshold)) {
        const x = Math.round(clamp(st.map.threshold, 0, 1) * 199);
        ctx.fillStyle = '#000';
        ctx.fillRect(x - 1, 0, 2, 14);
      }
    } else {
      note.textContent = st.mapLoading ? '· loading the day\'s map…' : '· pick a place to map the day';
    }
  }

  // ---------- interaction ----------
  function eventLatLon(ev) {
    if (!st.view) return null;
    const r = canvas.getBoundingClientRect();
    const fx = (ev.clientX - r.left) / r.width;
    const fy = (ev.clientY - r.top) / r.height;
    const b = st.view.b;
    return { lat: b.lat_max - fy * (b.lat_max - b.lat_min), lon: b.lon_min + fx * (b.lon_max - b.lon_min) };
  }

  function probabilityAt(lat, lon) {
    if (!st.map || !st.cov) return null;
    const cell = st.cov.cell_deg || 1 / 24;
    const lats = st.map.lats || [];
    const lons = st.map.lons || [];
    let r = -1, k = -1;
    for (let i = 0; i < lats.length; i++) if (Math.abs(lats[i] - lat) <= cell / 2) { r = i; break; }
    for (let i = 0; i < lons.length; i++) if (Math.abs(lons[i] - lon) <= cell / 2) { k = i; break; }
    if (r < 0 || k < 0) return null;
    const values = mapValues(st.map);
    const row = values.rows ? values.rows[r] : null;
    const v = row ? row[k] : null;
    if (v === null || v === undefined) return null;
    return values.relative ? `${fmtDailyPct(v)} chance of an ignition (${fmtTimes(v / values.usual)} the usual day)` : `model score ${fmtPct(v)}`;
  }

  canvas.addEventListener('mousemove', (ev) => {
    const ll = eventLatLon(ev);
    if (!ll) return;
    const p = probabilityAt(ll.lat, ll.lon);
    const parts = [fmtPlace(ll.lat, ll.lon)];
    if (st.map) parts.push(p === null || p === undefined ? 'no forecast for this cell' : `${p} on ${st.map.date}`);
    readout.textContent = parts.join(' · ');
  });
  canvas.addEventListener('mouseleave', () => {
    readout.textContent = Number.isFinite(st.lat) ? `Picked ${fmtPlace(st.lat, st.lon)}.` : 'Click the map to pick a place.';
  });
  canvas.addEventListener('click', (ev) => {
    const ll = eventLatLon(ev);
    if (!ll || !st.date) return;
    pick(ll.lat, ll.lon);
  });

  async function pick(lat, lon) {
    st.lat = lat;
    st.lon = lon;
    const seq = ++st.seq;
    st.forecast = null;
    updateHash();
    startBtn.disabled = true;
    startBtn.textContent = 'Start the fire';
    forecastBody.replaceChildren(loading(`Forecasting ${fmtPlace(lat, lon)} on ${st.date}…`));
    readout.textContent = `Picked ${fmtPlace(lat, lon)}.`;
    draw();
    loadMap(st.date);
    const date = st.date;
    try {
      const f = await api(`/api/predictWildfire?${qs({ lat: lat.toFixed(4), lon: lon.toFixed(4), date })}`, { method: 'POST' });
      if (!scope.alive || seq !== st.seq) return;
      st.forecast = f;
      renderForecast(f);
    } catch (e) {
      if (!scope.alive || seq !== st.seq) return;
      st.forecast = null;
      showError(forecastBody, e, 'No forecast');
      const unavailable = st.cov && st.cov.forecaster && st.cov.forecaster.available === false;
      // Without a forecaster, the fire can still be started at a place inside the data.
      if (unavailable && e.code === 'no_model') {
        startBtn.disabled = false;
        startBtn.textContent = 'Start the fire (no forecast)';
      }
    }
    draw();
  }

  async function loadMap(date) {
    const seq = ++st.mapSeq;
    if (!st.map || st.map.date !== date) {
      st.map = null;
      st.mapLoading = true;
      drawLegend();
      draw();
    }
    mapStatus.replaceChildren();
    try {
      const m = await getProbabilityMap(date);
      if (!scope.alive || seq !== st.mapSeq) return;
      st.map = m;
    } catch (e) {
      if (!scope.alive || seq !== st.mapSeq) return;
      st.map = null;
      showError(mapStatus, e, `No probability map for ${date}`);
    }
    st.mapLoading = false;
    drawLegend();
    draw();
  }

  function renderForecast(f) {
    const score = f.probability;
    const alert = !!f.ignition_expected;
    const daily = f.daily && Number.isFinite(f.daily.probability) ? f.daily : null;
    const interval = Array.isArray(f.interval) ? f.interval : null;
    const facts = h('dl', { class: 'facts' });
    const fact = (k, ...v) => facts.append(h('dt', null, k), h('dd', null, ...v));
    if (daily) {
      fact('The usual day', h('span', { id: 'usual' }, `${fmtDailyPct(daily.usual)} chance a cell`),
        h('span', { class: 'muted' }, ` (${daily.base.ignition_cell_days} ignition cell-days over ${daily.base.cells} cells × ${daily.base.days} days of the training area)`));
      if (Array.isArray(daily.interval)) fact('Range over seeds', h('span', { id: 'interval' }, `${fmtDailyPct(daily.interval[0])} – ${fmtDailyPct(daily.interval[1])}`));
    } else if (interval) {
      fact('Range over seeds', h('span', { id: 'interval' }, `${fmtPct(interval[0])} – ${fmtPct(interval[1])}`), f.interval_method ? h('span', { class: 'muted' }, ` (${f.interval_method})`) : null);
    }
    fact('Model score', h('span', { id: 'score' }, fmtPct(score)),
      h('span', { class: 'muted' }, ` on the training samples' scale (about 40 % fires), not a daily chance; alert threshold ${Number.isFinite(f.threshold) ? fmtPct(f.threshold) : '—'}, chosen on validation data`));
    fact('Place', fmtPlace(f.lat, f.lon));
    if (Number.isFinite(f.cell_lat)) fact('GRIDMET cell', `centre ${fmtPlace(f.cell_lat, f.cell_lon)}`);
    fact('Day', f.date || st.date);
    fact('Model', `${f.model || '—'}${f.kind ? ` (${f.kind})` : ''}`);
    if (f.protocol) fact('Protocol', f.protocol);
    if (f.dataset) fact('Dataset', `${f.dataset}${f.dataset_version ? ` · version ${f.dataset_version}` : ''}`);
    const skill = [];
    if (Number.isFinite(f.validation_auroc)) skill.push(`validation ${f.validation_auroc.toFixed(3)}`);
    if (Number.isFinite(f.test_auroc)) skill.push(`test ${f.test_auroc.toFixed(3)}`);
    if (skill.length) fact('AUROC', skill.join(' · '));
    if (f.prediction !== undefined) fact('FireCastRL answer', h('code', null, `prediction = ${typeof f.prediction === 'number' ? fmtNum(f.prediction) : fmtValue(f.prediction)}`), h('span', { class: 'muted' }, ' (the model score)'));

    let seeds = null;
    if (Array.isArray(f.per_seed) && f.per_seed.length) {
      seeds = h('details', null, h('summary', null, `Each training seed (${f.per_seed.length})`),
        h('div', { class: 'table-wrap' }, h('table', null,
          h('thead', null, h('tr', null, h('th', null, 'seed'), h('th', { class: 'num' }, 'score'), h('th', { class: 'num' }, 'threshold'), h('th', { class: 'num' }, 'val. AUROC'), h('th', { class: 'num' }, 'test AUROC'))),
          h('tbody', null, f.per_seed.map((s) => h('tr', null,
            h('td', null, fmtValue(s.seed)), h('td', { class: 'num' }, fmtPct(s.probability)), h('td', { class: 'num' }, fmtPct(s.threshold)),
            h('td', { class: 'num' }, Number.isFinite(s.validation_auroc) ? s.validation_auroc.toFixed(3) : '—'),
            h('td', { class: 'num' }, Number.isFinite(s.test_auroc) ? s.test_auroc.toFixed(3) : '—')))))));
    }

    const headline = daily
      ? h('div', { class: 'prob-block' },
        h('div', { id: 'probability', 'data-testid': 'probability', 'data-value': String(daily.probability), style: { color: relTextCss(daily.relative_to_usual) } }, fmtDailyPct(daily.probability)),
        h('div', { class: 'prob-caption' }, 'chance of an ignition in this cell', h('br'), `on ${f.date || st.date}: `, h('b', { id: 'relative' }, `${fmtTimes(daily.relative_to_usual)} the usual day`)))
      : h('div', { class: 'prob-block' },
        h('div', { id: 'probability', 'data-testid': 'probability', 'data-value': String(score), style: { color: probTextCss(score) } }, fmtPct(score)),
        h('div', { class: 'prob-caption' }, 'model score, not a daily chance', h('br'), `no daily probability: ${f.daily_unavailable || 'the forecast does not carry one'}`));
    fill(forecastBody,
      headline,
      h('div', { class: `verdict ${alert ? 'yes' : 'no'}`, id: 'verdict', 'data-testid': 'verdict' }, alert ? 'Alert: score above the threshold' : 'No alert: score below the threshold'),
      facts,
      seeds);
    startBtn.disabled = false;
    startBtn.textContent = alert ? 'Start the fire (alert)' : 'Start the fire';
  }

  // ---------- load ----------
  getCoverage().then((cov) => {
    if (!scope.alive) return;
    st.cov = cov;
    covStatus.replaceChildren();
    dateInput.min = cov.first_date || '';
    dateInput.max = cov.last_date || '';
    if (!st.date || (cov.first_date && st.date < cov.first_date) || (cov.last_date && st.date > cov.last_date)) {
      if (!st.date) st.date = defaultDate(cov);
    }
    dateInput.value = st.date;
    dateInput.disabled = false;
    root.querySelector('#date-range').textContent = `GRIDMET days ${cov.first_date} to ${cov.last_date}`;
    if (cov.forecaster && cov.forecaster.available === false) {
      covStatus.append(h('div', { class: 'warning' }, h('strong', null, 'No trained forecaster: '), cov.forecaster.reason || 'forecasts are not available.'));
    }
    if (cov.basemap && cov.basemap.url) {
      const img = new Image();
      img.onload = () => { if (scope.alive) draw(); };
      img.onerror = () => {
        if (!scope.alive) return;
        st.imgFailed = true;
        mapStatus.prepend(errorBox(new ApiError('basemap', `The base map ${cov.basemap.url} could not be loaded.`), 'Base map'));
        draw();
      };
      img.src = cov.basemap.url;
      st.img = img;
    } else {
      st.imgFailed = true;
    }
    drawLegend();
    draw();
    scope.onResize(draw);
    if (Number.isFinite(st.lat) && Number.isFinite(st.lon) && st.date) pick(st.lat, st.lon);
    else updateHash();
  }).catch((e) => {
    if (!scope.alive) return;
    showError(covStatus, e, 'The data coverage could not be loaded');
    mapWrap.classList.add('hidden');
    legend.classList.add('hidden');
    readout.classList.add('hidden');
  });
}

// ============================================================================
// Page 2: live fire
// ============================================================================

const STATE_UNBURNT = 0, STATE_BURNING = 1, STATE_BURNT = 2, STATE_WET = 3;

/** One binary frame (docs/web-app.md): little-endian header of 28 bytes, then n × u32 changes. */
function parseFrame(buf) {
  if (!(buf instanceof ArrayBuffer) || buf.byteLength < 28) throw new Error(`a frame of ${buf && buf.byteLength} bytes is shorter than its 28-byte header`);
  const dv = new DataView(buf);
  const n = dv.getUint32(24, true);
  if (28 + 4 * n > buf.byteLength) throw new Error(`a frame says ${n} changes but holds ${(buf.byteLength - 28) / 4}`);
  const changes = new Uint32Array(n);
  for (let k = 0; k < n; k++) changes[k] = dv.getUint32(28 + 4 * k, true);
  return {
    step: dv.getUint32(0, true),
    hours: dv.getFloat32(4, true),
    burning: dv.getUint32(8, true),
    burnt: dv.getUint32(12, true),
    hx: dv.getInt16(16, true),
    hy: dv.getInt16(18, true),
    flags: dv.getUint8(20),
    changes,
  };
}

function pageFire(root, params, scope) {
  const lat = parseFloat(params.get('lat'));
  const lon = parseFloat(params.get('lon'));
  const date = params.get('date') || '';
  const st = {
    seed: Math.max(0, parseInt(params.get('seed') || '0', 10) || 0),
    agents: { left: params.get('left') || '', right: params.get('right') || 'rule' },
    env: null,
    cov: null,
    img: null,
  };
  const backHash = `#/?${qs({ lat: Number.isFinite(lat) ? lat.toFixed(4) : '', lon: Number.isFinite(lon) ? lon.toFixed(4) : '', date })}`;

  const header = h('div', { class: 'page-title' },
    h('h1', null, 'Live fire'),
    h('span', { class: 'crumbs' }, h('a', { href: backHash }, '← back to the forecast')));
  root.append(header);

  if (!Number.isFinite(lat) || !Number.isFinite(lon) || !/^\d{4}-\d{2}-\d{2}$/.test(date)) {
    root.append(h('div', { class: 'card' }, errorBox(new ApiError('bad_request', 'This link needs a place and a day: #/fire?lat=…&lon=…&date=YYYY-MM-DD.'), 'Cannot start a fire'),
      h('a', { href: '#/' }, 'Pick a place on the map')));
    return;
  }
  header.append(h('span', { class: 'muted' }, `${fmtPlace(lat, lon)} · ${date}`));

  const envStatus = h('div', { id: 'env-status' }, loading('Building the fire\'s landscape and weather…'));
  const fireArea = h('div', { id: 'fire-area' });
  root.append(envStatus, fireArea);
  const reportCard = buildReportCard(scope, lat, lon, date);

  Promise.allSettled([
    api(`/api/createEnvironment?${qs({ lat: lat.toFixed(4), lon: lon.toFixed(4), date })}`, { method: 'POST' }),
    getCoverage(),
  ]).then(([envR, covR]) => {
    if (!scope.alive) return;
    envStatus.replaceChildren();
    if (covR.status === 'fulfilled') st.cov = covR.value;
    else envStatus.append(errorBox(covR.reason, 'Agent availability unknown (coverage failed)'));
    if (envR.status === 'rejected') {
      const e = envR.reason;
      const what = e.code === 'no_fuel' ? 'Nothing can burn here' : 'The fire could not be set up';
      envStatus.append(errorBox(e, what), h('p', null, h('a', { href: backHash }, 'Pick another place')));
      root.append(reportCard);
      return;
    }
    st.env = envR.value;
    if (!st.agents.left) st.agents.left = defaultLeftAgent(st.cov);
    buildFire();
    root.append(reportCard);
  });

  function buildFire() {
    const env = st.env;
    const W = env.width;
    const H = env.height;
    const S = Math.max(1, Math.min(4, Math.floor(720 / W) || 1)); // initial pixels per cell (the canvas is redrawn at its shown size)

    // Landscape image.
    const img = new Image();
    st.img = img;
    const imgError = h('div');
    img.onload = () => ctrl.render();
    img.onerror = () => {
      if (!scope.alive) return;
      imgError.replaceChildren(errorBox(new ApiError('landscape', `The landscape image ${env.landscape_png} could not be loaded; the fire is drawn on a plain background.`), 'Landscape'));
      ctrl.render();
    };
    img.src = env.landscape_png;

    // ---------- shared controls ----------
    const playBtn = h('button', { id: 'play', 'data-testid': 'play', type: 'button', title: 'Play both fires' }, '▶ Play');
    const pauseBtn = h('button', { id: 'pause', 'data-testid': 'pause', type: 'button', title: 'Pause both fires' }, '❚❚ Pause');
    const stepBtn = h('button', { id: 'step', 'data-testid': 'step', type: 'button', title: 'Advance both fires by one time step (pauses them)' }, `Step +${fmtNum(env.step_minutes)} min`);
    const speedSel = h('select', { id: 'speed', 'data-testid': 'speed', 'aria-label': 'Speed' },
      [5, 15, 30, 60].map((f) => h('option', { value: String(f) }, `${f} frames/s`)),
      h('option', { value: '0' }, 'max (as fast as computed)'));
    speedSel.value = '30';
    const seedInput = h('input', { id: 'seed', type: 'number', min: 0, step: 1, value: String(st.seed), style: { width: '6em' }, 'aria-label': 'Fire seed' });
    const restartBtn = h('button', { id: 'restart', type: 'button', title: 'Start both fires again from ignition' }, '↺ Restart');
    const scrub = h('input', { id: 'scrub', 'data-testid': 'scrub', type: 'range', min: 0, max: 0, value: 0, step: 1, 'aria-label': 'Time' });
    const scrubLabel = h('span', { class: 'scrub-label', id: 'scrub-label' }, 'waiting for the first frame…');
    const liveBtn = h('button', { id: 'live', type: 'button', class: 'is-live', title: 'Jump to the newest frame and follow the fire' }, '● Live');

    const controls = h('section', { class: 'card', id: 'fire-controls' },
      h('div', { class: 'controls' },
        h('span', { class: 'group' }, playBtn, pauseBtn, stepBtn),
        h('label', { class: 'field' }, h('span', null, 'Speed'), speedSel),
        h('label', { class: 'field' }, h('span', null, 'Fire seed'), seedInput),
        restartBtn,
        h('span', { class: 'muted small' }, `Same seed on both sides = the same fire, weather and spread; only the helicopter differs. One frame = ${fmtNum(env.step_minutes)} minutes.`)),
      h('div', { class: 'scrub-row' }, h('label', { for: 'scrub', class: 'muted small' }, 'Time'), scrub, scrubLabel, liveBtn));

    const grid = h('div', { class: 'fire-grid' });
    const facts = buildEnvFacts(env);
    fireArea.append(controls, imgError, grid, facts);

    const ctrl = {
      index: 0,
      follow: true,
      playing: true,
      fps: 30,
      panels: {},
      rafPending: false,
      maxLen() { return Math.max(0, ...Object.values(this.panels).map((p) => p.frames.length)); },
      render() {
        if (this.rafPending || !scope.alive) return;
        this.rafPending = true;
        requestAnimationFrame(() => {
          this.rafPending = false;
          if (!scope.alive) return;
          const n = this.maxLen();
          if (this.follow) this.index = Math.max(0, n - 1);
          this.index = clamp(this.index, 0, Math.max(0, n - 1));
          scrub.max = String(Math.max(0, n - 1));
          scrub.value = String(this.index);
          scrub.disabled = n === 0;
          liveBtn.classList.toggle('is-live', this.follow);
          liveBtn.textContent = this.follow ? '● Live' : '→ Go live';
          let hours = NaN;
          for (const p of Object.values(this.panels)) {
            const f = p.frames[Math.min(this.index, p.frames.length - 1)];
            if (f && (!Number.isFinite(hours) || this.index < p.frames.length)) hours = f.hours;
          }
          const newest = Math.max(...Object.values(this.panels).map((p) => (p.frames.length ? p.frames[p.frames.length - 1].hours : 0)));
          scrubLabel.textContent = n === 0 ? 'waiting for the first frame…'
            : this.follow ? `${fmtHours(hours)} after ignition (live)` : `${fmtHours(hours)} after ignition · newest ${fmtHours(newest)}`;
          for (const p of Object.values(this.panels)) p.draw(this.index);
        });
      },
      send(msg) { for (const p of Object.values(this.panels)) p.send(msg); },
      updateUrl() {
        replaceHash(`#/fire?${qs({ lat: params.get('lat'), lon: params.get('lon'), date, left: st.agents.left, right: st.agents.right, seed: st.seed })}`);
      },
      setPlaying(on) {
        this.playing = on;
        playBtn.classList.toggle('pressed', on);
        pauseBtn.classList.toggle('pressed', !on);
      },
    };
    ctrl.setPlaying(true);

    playBtn.addEventListener('click', () => { ctrl.send({ type: 'play' }); ctrl.setPlaying(true); ctrl.follow = true; ctrl.render(); });
    pauseBtn.addEventListener('click', () => { ctrl.send({ type: 'pause' }); ctrl.setPlaying(false); });
    stepBtn.addEventListener('click', () => {
      if (ctrl.playing) { ctrl.send({ type: 'pause' }); ctrl.setPlaying(false); }
      ctrl.send({ type: 'step' });
      ctrl.follow = true;
      ctrl.render();
    });
    speedSel.addEventListener('change', () => {
      ctrl.fps = parseInt(speedSel.value, 10) || 0;
      ctrl.send({ type: 'speed', fps: ctrl.fps });
    });
    scrub.addEventListener('input', () => {
      const v = parseInt(scrub.value, 10) || 0;
      ctrl.index = v;
      ctrl.follow = v >= ctrl.maxLen() - 1;
      ctrl.render();
    });
    liveBtn.addEventListener('click', () => { ctrl.follow = true; ctrl.render(); });
    const restartAll = () => {
      ctrl.follow = true;
      for (const p of Object.values(ctrl.panels)) p.start();
      ctrl.updateUrl();
    };
    seedInput.addEventListener('change', () => {
      const v = parseInt(seedInput.value, 10);
      if (!Number.isFinite(v) || v < 0) { seedInput.value = String(st.seed); return; }
      st.seed = v;
      restartAll();
    });
    restartBtn.addEventListener('click', restartAll);

    const left = makePanel('left', 'right');
    const right = makePanel('right', 'left');
    ctrl.panels.left = left;
    ctrl.panels.right = right;
    grid.append(left.el, right.el);
    ctrl.updateUrl();
    left.start();
    right.start();
    scope.onResize(() => { for (const p of Object.values(ctrl.panels)) p.chartDirty = true; ctrl.render(); });

    // ---------- one panel ----------
    function makePanel(side, otherSide) {
      const color = SIDE_COLORS[side];
      const agents = agentList(st.cov);
      const sel = h('select', { id: `agent-${side}`, 'data-testid': `agent-${side}`, 'aria-label': `Agent, ${side} panel` },
        agents.map((a) => h('option', { value: a.id, disabled: !a.available, title: a.available ? null : (a.reason || 'not available') },
          a.available ? a.label : `${a.label} — unavailable`)));
      if (!agents.some((a) => a.id === st.agents[side])) sel.append(h('option', { value: st.agents[side] }, st.agents[side]));
      sel.value = st.agents[side];
      const canvas = h('canvas', { class: 'fire-canvas', width: W * S, height: H * S, role: 'img', 'aria-label': `Fire map, ${side} panel` });
      const statsEls = {
        hours: h('b', { class: 'hours' }, '—'),
        acres: h('b', { class: 'acres' }, '—'),
        burning: h('b', { class: 'burning' }, '—'),
        drops: h('b', { class: 'drops' }, '—'),
      };
      const stats = h('div', { class: 'stats' },
        h('span', { class: 'stat main' }, statsEls.acres, 'burnt + burning'),
        h('span', { class: 'stat' }, statsEls.hours, 'since ignition'),
        h('span', { class: 'stat' }, statsEls.burning, 'burning now'),
        h('span', { class: 'stat' }, statsEls.drops, 'water drops'));
      const runState = h('div', { class: 'run-state muted' }, '');
      const msgBox = h('div', { class: 'panel-messages' });
      const chart = h('canvas', { class: 'area-chart', 'aria-label': 'Area over time' });
      const legendEl = h('div', { class: 'legend' },
        h('span', null, h('i', { class: 'sw', style: { background: 'rgb(255,96,0)' } }), 'burning'),
        h('span', null, h('i', { class: 'sw', style: { background: 'rgb(40,34,30)' } }), 'burnt'),
        h('span', null, h('i', { class: 'sw', style: { background: 'rgb(60,130,255)' } }), 'wetted by a drop'),
        h('span', null, h('i', { class: 'sw dot', style: { background: '#ffe14d', borderColor: '#000' } }), 'helicopter'),
        h('span', null, h('i', { class: 'sw line', style: { background: '#ffffff', boxShadow: '0 0 0 1px #333' } }), 'its path'),
        h('span', null, h('i', { class: 'sw dot', style: { background: 'transparent', border: '2px solid #0a3fa8' } }), 'drop'));
      const body = h('div', { class: 'panel-body' }, canvas, legendEl, stats, runState, chart);
      // What the server says about the chosen agent (e.g. which map the PPO agent learned on).
      const agentNote = h('div', { class: 'muted small agent-note', id: `agent-note-${side}` });
      const showNote = () => {
        const a = agents.find((x) => x.id === sel.value);
        agentNote.textContent = a && a.available && a.id === 'ppo' ? (a.reason || '') : '';
      };
      showNote();
      const el = h('section', { class: 'card fire-panel', id: `fire-${side}`, 'data-testid': `fire-${side}`, style: { '--panel-color': color } },
        h('div', { class: 'panel-head' }, h('h2', null, side === 'left' ? 'Left' : 'Right'), sel),
        agentNote, msgBox, body);

      const overlay = document.createElement('canvas');
      overlay.width = W;
      overlay.height = H;
      const octx = overlay.getContext('2d');
      const imageData = octx.createImageData(W, H);
      const px = new Uint32Array(imageData.data.buffer);
      const littleEndian = new Uint8Array(new Uint32Array([1]).buffer)[0] === 1;
      const rgba = (r, g, b, a) => (littleEndian ? ((a << 24) | (b << 16) | (g << 8) | r) >>> 0 : ((r << 24) | (g << 16) | (b << 8) | a) >>> 0);
      const COLORS = [0, rgba(255, 96, 0, 255), rgba(40, 34, 30, 215), rgba(60, 130, 255, 150)];

      const p = {
        el,
        side,
        ws: null,
        gen: 0,
        frames: [],
        live: new Uint8Array(W * H),
        view: new Uint8Array(W * H),
        viewIdx: -1,
        drops: [], // cumulative drops per frame
        startMsg: null,
        endMsg: null,
        failed: false,
        lastIndex: -1,
        chartDirty: true,

        start() {
          this.stop();
          this.gen++;
          const gen = this.gen;
          this.frames = [];
          this.live.fill(0);
          this.view.fill(0);
          this.viewIdx = -1;
          this.drops = [];
          this.startMsg = null;
          this.endMsg = null;
          this.failed = false;
          this.chartDirty = true;
          msgBox.replaceChildren();
          body.classList.remove('hidden');
          runState.classList.remove('ended');
          const agent = st.agents[side];
          const info = agentList(st.cov).find((a) => a.id === agent);
          el.dataset.agent = agent;
          if (st.cov && info && !info.available) {
            this.failed = true;
            msgBox.replaceChildren(errorBox(new ApiError('no_model', `${info.label} is not available${info.reason ? ': ' + info.reason : '.'}`), 'Agent unavailable'),
              h('p', { class: 'muted' }, 'Pick another agent above.'));
            body.classList.add('hidden');
            ctrl.render();
            return;
          }
          runState.textContent = 'Connecting…';
          const proto = location.protocol === 'https:' ? 'wss:' : 'ws:';
          const url = `${proto}//${location.host}/api/environments/${enc(env.id)}/simulate?${qs({ agent, seed: st.seed })}`;
          let ws;
          try {
            ws = new WebSocket(url);
          } catch (e) {
            this.fail(new ApiError('websocket', `The live fire could not be opened (${e.message}).`));
            return;
          }
          ws.binaryType = 'arraybuffer';
          this.ws = ws;
          ws.onopen = () => {
            if (gen !== this.gen) return;
            runState.textContent = 'Waiting for the simulation…';
            // Keep this run in step with the shared controls.
            if (ctrl.fps !== 30) this.send({ type: 'speed', fps: ctrl.fps });
            if (!ctrl.playing) this.send({ type: 'pause' });
          };
          ws.onmessage = (ev) => {
            if (gen !== this.gen) return;
            if (typeof ev.data === 'string') this.onText(ev.data);
            else this.onFrame(ev.data);
          };
          ws.onerror = () => {
            if (gen !== this.gen) return;
            // The close event that follows says more; remember that it was an error.
            this.sawError = true;
          };
          ws.onclose = (ev) => {
            if (gen !== this.gen) return;
            this.ws = null;
            if (this.endMsg || this.failed) return;
            const why = ev.reason ? `: ${ev.reason}` : '';
            this.fail(new ApiError('websocket', ev.code === 1008
              ? `The server closed the live fire (policy${why}).`
              : `The connection to the live fire closed before it ended (code ${ev.code}${why}).`));
          };
        },

        stop() {
          if (this.ws) {
            const ws = this.ws;
            this.ws = null;
            ws.onclose = null; ws.onmessage = null; ws.onerror = null;
            try { ws.close(1000, 'restart'); } catch { /* closed */ }
          }
        },

        send(msg) {
          if (this.ws && this.ws.readyState === WebSocket.OPEN) this.ws.send(JSON.stringify(msg));
        },

        fail(err) {
          this.failed = true;
          msgBox.replaceChildren(errorBox(err, 'Live fire'));
          // Nothing arrived: show the error alone, not an empty fire.
          body.classList.toggle('hidden', this.frames.length === 0);
          runState.textContent = this.frames.length ? 'Stopped early: the frames received so far can still be scrubbed.' : '';
          ctrl.render();
        },

        onText(text) {
          let m;
          try { m = JSON.parse(text); } catch {
            this.fail(new ApiError('bad_message', `The server sent a message that is not JSON: ${text.slice(0, 120)}`));
            return;
          }
          if (m.type === 'start') {
            this.startMsg = m;
            if ((m.width && m.width !== W) || (m.height && m.height !== H)) {
              this.fail(new ApiError('bad_message', `The run's grid (${m.width}×${m.height}) differs from the environment's (${W}×${H}).`));
              this.stop();
              return;
            }
            runState.textContent = `Running: ${agentLabel(m.agent)}, seed ${m.seed}, wind ${fmtNum(Number((m.wind_speed_mph || 0).toFixed(1)))} mph from ${compass(m.wind_from_deg || 0)}.`;
          } else if (m.type === 'end') {
            this.endMsg = m;
            runState.classList.add('ended');
            const area = Number.isFinite(m.burnt_acres) ? m.burnt_acres : (m.burnt_cells || 0) * env.cell_acres;
            runState.textContent = `${m.fire_out ? `Fire out after ${fmtHours(m.hours)}` : `Still burning when the run stopped at ${fmtHours(m.hours)}`}: ${fmtAcres(area)} acres burnt, ${fmtNum(m.drops || 0)} drops.`;
            ctrl.render();
          } else if (m.type === 'error') {
            this.fail(new ApiError(m.code || 'error', m.message || 'the live fire failed'));
          }
        },

        onFrame(buf) {
          let f;
          try { f = parseFrame(buf); } catch (e) {
            this.fail(new ApiError('bad_frame', `A frame could not be read: ${e.message}`));
            this.stop();
            return;
          }
          const n = W * H;
          const prev = new Uint8Array(f.changes.length);
          for (let k = 0; k < f.changes.length; k++) {
            const c = f.changes[k];
            const cell = c >>> 8;
            if (cell >= n) continue;
            prev[k] = this.live[cell];
            this.live[cell] = c & 255;
          }
          f.prev = prev;
          const lastDrops = this.drops.length ? this.drops[this.drops.length - 1] : 0;
          this.drops.push(lastDrops + ((f.flags & 1) ? 1 : 0));
          this.frames.push(f);
          this.chartDirty = true;
          ctrl.render();
          // The other panel's chart shows this curve too.
          const other = ctrl.panels[otherSide];
          if (other) other.chartDirty = true;
        },

        seek(k) {
          const target = Math.min(k, this.frames.length - 1);
          const n = W * H;
          while (this.viewIdx < target) {
            this.viewIdx++;
            const ch = this.frames[this.viewIdx].changes;
            for (let i = 0; i < ch.length; i++) {
              const cell = ch[i] >>> 8;
              if (cell < n) this.view[cell] = ch[i] & 255;
            }
          }
          while (this.viewIdx > target) {
            const f = this.frames[this.viewIdx];
            for (let i = 0; i < f.changes.length; i++) {
              const cell = f.changes[i] >>> 8;
              if (cell < n) this.view[cell] = f.prev[i];
            }
            this.viewIdx--;
          }
        },

        draw(index) {
          this.seek(index);
          // Drawn at the size it is shown (crisp text and lines at any width).
          const dpr = window.devicePixelRatio || 1;
          const cssW = canvas.clientWidth || W * S;
          const cssH = (cssW * H) / W;
          const pw = Math.max(1, Math.round(cssW * dpr));
          const ph = Math.max(1, Math.round(cssH * dpr));
          if (canvas.width !== pw || canvas.height !== ph) { canvas.width = pw; canvas.height = ph; }
          const ctx = canvas.getContext('2d');
          ctx.setTransform(dpr, 0, 0, dpr, 0, 0);
          const s = cssW / W; // CSS pixels per cell
          ctx.imageSmoothingEnabled = false;
          if (st.img && st.img.complete && st.img.naturalWidth > 0) ctx.drawImage(st.img, 0, 0, cssW, cssH);
          else { ctx.fillStyle = '#d8d2c4'; ctx.fillRect(0, 0, cssW, cssH); }
          // Fire overlay: cell (x, y) with row 0 south is canvas row H-1-y.
          for (let y = 0; y < H; y++) {
            const src = y * W;
            const dst = (H - 1 - y) * W;
            for (let x = 0; x < W; x++) px[dst + x] = COLORS[this.view[src + x]] || 0;
          }
          octx.putImageData(imageData, 0, 0);
          ctx.drawImage(overlay, 0, 0, cssW, cssH);

          const vi = this.viewIdx;
          const cx = (x) => (x + 0.5) * s;
          const cy = (y) => (H - 1 - y + 0.5) * s;
          // Path.
          if (vi >= 0) {
            const path = [];
            const dropsAt = [];
            for (let i = 0; i <= vi; i++) {
              const f = this.frames[i];
              if (f.hx >= 0 && f.hy >= 0) {
                path.push([cx(f.hx), cy(f.hy)]);
                if (f.flags & 1) dropsAt.push([cx(f.hx), cy(f.hy)]);
              } else if (path.length && path[path.length - 1] !== null) {
                path.push(null);
              }
            }
            const stroke = (style, width) => {
              ctx.strokeStyle = style;
              ctx.lineWidth = width;
              ctx.beginPath();
              let pen = false;
              for (const pt of path) {
                if (!pt) { pen = false; continue; }
                if (pen) ctx.lineTo(pt[0], pt[1]); else ctx.moveTo(pt[0], pt[1]);
                pen = true;
              }
              ctx.stroke();
            };
            ctx.lineJoin = 'round';
            stroke('rgba(0,0,0,.45)', 3);
            stroke('rgba(255,255,255,.9)', 1.3);
            for (const [x, y] of dropsAt) {
              ctx.beginPath();
              ctx.arc(x, y, Math.max(3.5, s * 1.6), 0, Math.PI * 2);
              ctx.lineWidth = 2;
              ctx.strokeStyle = '#0a3fa8';
              ctx.stroke();
              ctx.lineWidth = 1;
              ctx.strokeStyle = 'rgba(255,255,255,.8)';
              ctx.stroke();
            }
            const f = this.frames[vi];
            if (f.hx >= 0 && f.hy >= 0) drawHelicopter(ctx, cx(f.hx), cy(f.hy));
          }
          drawFireMapDecor(ctx, cssW, cssH, s, env, this.startMsg);

          // Stats for the viewed frame.
          const f = vi >= 0 ? this.frames[vi] : null;
          if (f) {
            const acres = (f.burnt + f.burning) * env.cell_acres;
            statsEls.hours.textContent = fmtHours(f.hours);
            statsEls.hours.dataset.value = String(f.hours);
            statsEls.acres.textContent = `${fmtAcres(acres)} acres`;
            statsEls.acres.dataset.value = String(acres);
            statsEls.burning.textContent = `${fmtAcres(f.burning * env.cell_acres)} acres`;
            statsEls.burning.dataset.value = String(f.burning * env.cell_acres);
            statsEls.drops.textContent = nf0.format(this.drops[vi]);
            statsEls.drops.dataset.value = String(this.drops[vi]);
          } else {
            for (const e of Object.values(statsEls)) { e.textContent = '—'; delete e.dataset.value; }
          }
          if (this.chartDirty || this.lastIndex !== vi) this.drawChart();
          this.lastIndex = vi;
        },

        series() {
          const xs = new Array(this.frames.length);
          const ys = new Array(this.frames.length);
          for (let i = 0; i < this.frames.length; i++) {
            const f = this.frames[i];
            xs[i] = f.hours;
            ys[i] = (f.burnt + f.burning) * env.cell_acres;
          }
          return { xs, ys };
        },

        drawChart() {
          this.chartDirty = false;
          const own = this.series();
          const other = ctrl.panels[otherSide];
          const os = other ? other.series() : { xs: [], ys: [] };
          const vi = this.viewIdx;
          drawChart(chart, {
            height: 200,
            xLabel: 'hours since ignition',
            yLabel: 'area (acres)',
            xMin: 0,
            xMax: 1,
            yMin: 0,
            vline: vi >= 0 ? this.frames[vi].hours : undefined,
            empty: 'waiting for the fire…',
            series: [
              other ? { label: `${agentLabel(st.agents[otherSide])} (${otherSide})`, xs: os.xs, ys: os.ys, color: SIDE_COLORS[otherSide], dash: [6, 4], width: 2 } : null,
              { label: `${agentLabel(st.agents[side])} (${side})`, xs: own.xs, ys: own.ys, color, width: 2.5 },
            ],
          });
        },
      };

      sel.addEventListener('change', () => {
        st.agents[side] = sel.value;
        showNote();
        ctrl.updateUrl();
        p.start();
        const other = ctrl.panels[otherSide];
        if (other) other.chartDirty = true;
      });
      scope.add(() => p.stop());
      return p;
    }
  }

  function buildEnvFacts(env) {
    const dl = h('dl', { class: 'facts env-facts' });
    const fact = (k, ...v) => dl.append(h('dt', null, k), h('dd', null, ...v));
    fact('Place', `${fmtPlace(env.lat ?? lat, env.lon ?? lon)} on ${env.date || date}`);
    fact('Weather', env.weather || 'no GRIDMET weather for this day: the fire settings\' default wind');
    fact('Wind', `${fmtNum(Number((env.wind_speed_mph || 0).toFixed(1)))} mph from ${fmtNum(Math.round(env.wind_from_deg || 0))}° (${compass(env.wind_from_deg || 0)})`);
    fact('Landscape', env.landscape || '—');
    const widthMi = (env.width * (env.cell_size_ft || 0)) / FEET_PER_MILE;
    const heightMi = (env.height * (env.cell_size_ft || 0)) / FEET_PER_MILE;
    if (env.cell_size_ft) fact('Area shown', `${nf1.format(widthMi)} × ${nf1.format(heightMi)} miles; each cell ${fmtNum(env.cell_size_ft)} ft square = ${fmtAcres(env.cell_acres)} acres`);
    fact('Time step', `${fmtNum(env.step_minutes)} minutes per frame`);
    fact('Longest run', `${fmtHours(env.max_hours)} (${fmtNum(env.max_steps)} frames)`);
    if (Array.isArray(env.ignition) && env.cell_size_ft) {
      const east = ((env.ignition[0] + 0.5) * env.cell_size_ft) / FEET_PER_MILE;
      const north = ((env.ignition[1] + 0.5) * env.cell_size_ft) / FEET_PER_MILE;
      fact('Ignition', `the picked place: ${nf1.format(east)} miles east and ${nf1.format(north)} miles north of the map's south-west corner`);
    }
    return h('section', { class: 'card', id: 'env-info' },
      h('h2', null, 'This fire'),
      dl,
      h('p', { class: 'note', id: 'honest-note' }, 'The overview map and the fire\'s landscape are both FireCast renderings; the fire\'s landscape is procedural (seeded), not the real terrain at this place.'));
  }
}

function agentLabel(id) { return AGENT_LABELS[id] || id || '—'; }

function drawHelicopter(ctx, x, y) {
  const r = 7;
  ctx.save();
  ctx.translate(x, y);
  ctx.fillStyle = '#ffe14d';
  ctx.strokeStyle = '#000';
  ctx.lineWidth = 1.5;
  ctx.beginPath();
  ctx.moveTo(0, -r); ctx.lineTo(r, 0); ctx.lineTo(0, r); ctx.lineTo(-r, 0); ctx.closePath();
  ctx.fill();
  ctx.stroke();
  ctx.beginPath();
  ctx.moveTo(-r * 1.5, -r * 1.5); ctx.lineTo(r * 1.5, r * 1.5);
  ctx.moveTo(r * 1.5, -r * 1.5); ctx.lineTo(-r * 1.5, r * 1.5);
  ctx.lineWidth = 1.2;
  ctx.stroke();
  ctx.restore();
}

/** North arrow, wind arrow and a scale bar on a fire map. */
function drawFireMapDecor(ctx, Wpx, Hpx, S, env, startMsg) {
  ctx.save();
  ctx.font = FONT;
  // Wind (top left): the arrow points where the wind blows to.
  const speed = startMsg && Number.isFinite(startMsg.wind_speed_mph) ? startMsg.wind_speed_mph : env.wind_speed_mph;
  const from = startMsg && Number.isFinite(startMsg.wind_from_deg) ? startMsg.wind_from_deg : env.wind_from_deg;
  if (Number.isFinite(speed) && Number.isFinite(from)) {
    const label = `wind ${fmtNum(Number(speed.toFixed(1)))} mph from ${compass(from)}`;
    const w = ctx.measureText(label).width + 44;
    ctx.fillStyle = 'rgba(255,255,255,.85)';
    ctx.fillRect(6, 6, w, 26);
    const cx = 22, cy = 19;
    const to = ((from + 180) * Math.PI) / 180;
    const dx = Math.sin(to), dy = -Math.cos(to);
    ctx.strokeStyle = '#111';
    ctx.fillStyle = '#111';
    ctx.lineWidth = 2;
    ctx.beginPath(); ctx.moveTo(cx - dx * 9, cy - dy * 9); ctx.lineTo(cx + dx * 6, cy + dy * 6); ctx.stroke();
    ctx.beginPath();
    ctx.moveTo(cx + dx * 10, cy + dy * 10);
    ctx.lineTo(cx + dx * 3 - dy * 5, cy + dy * 3 + dx * 5);
    ctx.lineTo(cx + dx * 3 + dy * 5, cy + dy * 3 - dx * 5);
    ctx.closePath(); ctx.fill();
    ctx.textAlign = 'left';
    ctx.textBaseline = 'middle';
    ctx.fillText(label, 38, 19);
  }
  // North (top right).
  ctx.fillStyle = 'rgba(255,255,255,.85)';
  ctx.fillRect(Wpx - 30, 6, 24, 34);
  ctx.fillStyle = '#111';
  ctx.beginPath(); ctx.moveTo(Wpx - 18, 10); ctx.lineTo(Wpx - 12, 24); ctx.lineTo(Wpx - 24, 24); ctx.closePath(); ctx.fill();
  ctx.font = FONT_BOLD;
  ctx.textAlign = 'center';
  ctx.textBaseline = 'top';
  ctx.fillText('N', Wpx - 18, 25);
  // Scale bar (bottom left), in miles.
  if (env.cell_size_ft > 0) {
    const pxPerMile = (FEET_PER_MILE / env.cell_size_ft) * S;
    let miles = 1;
    for (const m of [0.25, 0.5, 1, 2, 5, 10, 20]) if (m * pxPerMile <= Wpx / 4) miles = m;
    const w = miles * pxPerMile;
    ctx.font = FONT;
    ctx.fillStyle = 'rgba(255,255,255,.85)';
    ctx.fillRect(6, Hpx - 26, w + 60, 20);
    ctx.fillStyle = '#111';
    ctx.fillRect(12, Hpx - 18, w, 4);
    ctx.textAlign = 'left';
    ctx.textBaseline = 'middle';
    ctx.fillText(`${miles} mi`, 18 + w, Hpx - 16);
  }
  ctx.restore();
}

// ---------- the threat report ----------

function buildReportCard(scope, lat, lon, date) {
  const btn = h('button', { id: 'report-btn', 'data-testid': 'report-btn', class: 'primary', type: 'button' }, 'Threat report for this place and day');
  const status = h('div', { id: 'report-status', 'data-testid': 'report-status', 'aria-live': 'polite' });
  const links = h('div', { id: 'report-links', 'data-testid': 'report-links', class: 'report-links' });
  const frameBox = h('div', { id: 'report-view' });
  const card = h('section', { class: 'card', id: 'report-card' },
    h('div', { class: 'card-head' }, h('h2', null, 'Threat report'), btn),
    h('p', { class: 'muted small' }, `Runs the threat pipeline for ${fmtPlace(lat, lon)} on ${date}: the forecast, an ensemble of fires, the helicopter plan and the report (HTML, PDF, JSON, GeoJSON). It can take a few minutes.`),
    status, links, frameBox);

  let jobId = null;
  let clientStart = 0;
  let polling = false;

  btn.addEventListener('click', async () => {
    btn.disabled = true;
    links.replaceChildren();
    frameBox.replaceChildren();
    status.replaceChildren(loading('Asking for the report…'));
    clientStart = Date.now() / 1000;
    try {
      const job = await api(`/api/jobs/threat?${qs({ lat: lat.toFixed(4), lon: lon.toFixed(4), date })}`, { method: 'POST' });
      if (!scope.alive) return;
      jobId = job.id;
      renderJob(job);
      if (job.status !== 'succeeded' && job.status !== 'failed') schedulePoll();
    } catch (e) {
      if (!scope.alive) return;
      showError(status, e, e.code === 'busy' ? 'The server is busy' : 'The report could not be started');
      btn.disabled = false;
    }
  });

  function schedulePoll() {
    if (polling) return;
    polling = true;
    scope.timeout(poll, 1000);
  }

  async function poll() {
    polling = false;
    if (!scope.alive || !jobId) return;
    try {
      const job = await api(`/api/jobs/${enc(jobId)}`);
      if (!scope.alive) return;
      renderJob(job);
      if (job.status !== 'succeeded' && job.status !== 'failed') schedulePoll();
    } catch (e) {
      if (!scope.alive) return;
      status.append(errorBox(e, 'The report\'s progress could not be read'));
      btn.disabled = false;
    }
  }

  function renderJob(job) {
    const done = Number(job.stages_done) || 0;
    const total = Number(job.stages_total) || 0;
    const pct = total > 0 ? clamp((100 * done) / total, 0, 100) : (job.status === 'succeeded' ? 100 : 0);
    const t0 = parseTime(job.started_at) || parseTime(job.queued_at) || clientStart;
    const t1 = Number.isFinite(parseTime(job.ended_at)) ? parseTime(job.ended_at) : Date.now() / 1000;
    const elapsed = Number.isFinite(t0) ? Math.max(0, t1 - t0) : NaN;
    const parts = [
      h('div', { class: 'toolbar' },
        statusBadge(job.status),
        h('span', { class: 'report-stages' }, total > 0 ? `${done} of ${total} stages` : 'stages not known yet'),
        job.current ? h('span', null, 'now: ', h('code', { class: 'report-current' }, String(job.current))) : null,
        Number.isFinite(elapsed) ? h('span', { class: 'muted' }, `elapsed ${fmtDuration(elapsed)}`) : null),
      h('div', { class: 'progress', role: 'progressbar', 'aria-valuemin': 0, 'aria-valuemax': 100, 'aria-valuenow': Math.round(pct) }, h('div', { style: { width: `${pct}%` } })),
    ];
    if (job.status === 'failed') {
      parts.push(errorBox(new ApiError('job_failed', job.error || 'the threat pipeline failed'), 'The report failed'));
      const tail = Array.isArray(job.log_tail) ? job.log_tail.join('\n') : job.log_tail;
      if (tail) parts.push(h('details', { open: true }, h('summary', null, 'Last lines of its log'), h('pre', { class: 'block' }, tail)));
      btn.disabled = false;
    }
    status.replaceChildren(...parts);
    if (job.status === 'succeeded') {
      btn.disabled = false;
      const files = job.files || {};
      const names = [['html', 'HTML report'], ['pdf', 'PDF'], ['json', 'JSON'], ['geojson', 'GeoJSON']];
      links.replaceChildren(...names.filter(([k]) => files[k]).map(([k, label]) =>
        h('a', { class: 'button', href: files[k], target: '_blank', rel: 'noopener', 'data-file': k }, `${label} ↗`)));
      if (!names.some(([k]) => files[k])) links.append(errorBox(new ApiError('no_files', 'The job succeeded but lists no report files.'), 'Report'));
      if (files.html) frameBox.replaceChildren(h('iframe', { id: 'report-frame', src: files.html, title: 'Threat report' }));
    }
  }

  return card;
}

// ============================================================================
// Page 3: runs
// ============================================================================

const RUN_COLUMNS = [
  { key: 'run_id', label: 'Run' },
  { key: 'pipeline', label: 'Pipeline' },
  { key: 'stage', label: 'Stage' },
  { key: 'kind', label: 'Kind' },
  { key: 'status', label: 'Status' },
  { key: 'started_at', label: 'Started (UTC)' },
  { key: 'duration_secs', label: 'Duration', num: true },
];

function runRowCells(r) {
  return [
    h('td', null, runLink(r.run_id)),
    h('td', { class: 'wrap' }, r.pipeline || '—'),
    h('td', null, r.stage || '—'),
    h('td', null, r.kind || '—'),
    h('td', null, statusBadge(r.status, r.error || null)),
    h('td', { class: 'mono small nowrap' }, fmtTimestamp(r.started_at)),
    h('td', { class: 'num' }, r.status === 'running' && !Number.isFinite(r.duration_secs) ? 'running…' : fmtDuration(r.duration_secs)),
  ];
}

/** A plain table of runs (children, compare). */
function runsTable(rows, opts = {}) {
  return h('div', { class: 'table-wrap' }, h('table', { id: opts.id || null },
    h('thead', null, h('tr', null, opts.colors ? h('th', null, '') : null, RUN_COLUMNS.map((c) => h('th', { class: c.num ? 'num' : null }, c.label)))),
    h('tbody', null, rows.length === 0
      ? h('tr', { class: 'empty-row' }, h('td', { colspan: RUN_COLUMNS.length + (opts.colors ? 1 : 0) }, opts.empty || 'No runs.'))
      : rows.map((r, i) => h('tr', null, opts.colors ? h('td', null, h('span', { class: 'swatch', style: { background: opts.colors[i] } })) : null, runRowCells(r))))));
}

function pageRuns(root, params, scope) {
  const st = {
    q: params.get('q') || '',
    status: params.get('status') || '',
    pipeline: params.get('pipeline') || '',
    kind: params.get('kind') || '',
    sort: params.get('sort') || 'started_at',
    order: params.get('order') === 'asc' ? 'asc' : 'desc',
    offset: Math.max(0, parseInt(params.get('offset') || '0', 10) || 0),
    limit: 100,
    selected: new Set((params.get('selected') || '').split(',').filter(Boolean)),
    seq: 0,
    inFlight: false,
    rows: [],
    total: 0,
  };

  const search = h('input', { id: 'runs-search', 'data-testid': 'runs-search', type: 'search', placeholder: 'Search id, pipeline, stage, kind, params', value: st.q, style: { minWidth: '240px', flex: '1 1 240px' }, 'aria-label': 'Search runs' });
  const statusSel = h('select', { id: 'runs-status', 'aria-label': 'Status' },
    h('option', { value: '' }, 'any status'),
    ['running', 'succeeded', 'failed', 'restored'].map((s) => h('option', { value: s }, s)));
  statusSel.value = st.status;
  const pipelineInput = h('input', { id: 'runs-pipeline', type: 'text', placeholder: 'pipeline', value: st.pipeline, style: { width: '9em' }, 'aria-label': 'Pipeline' });
  const kindInput = h('input', { id: 'runs-kind', type: 'text', placeholder: 'kind', value: st.kind, style: { width: '9em' }, 'aria-label': 'Kind' });
  const liveBox = h('input', { id: 'runs-live', type: 'checkbox' });
  const compareBtn = h('button', { id: 'compare-btn', 'data-testid': 'compare-btn', type: 'button', class: 'primary', disabled: true }, 'Compare selected');
  const csv = h('a', { id: 'runs-csv', 'data-testid': 'runs-csv', class: 'button', href: '/api/runs.csv', download: 'runs.csv' }, 'Download CSV');
  const errBox = h('div', { id: 'runs-error' });
  const summary = h('div', { class: 'muted small', id: 'runs-summary' }, '');
  const thead = h('thead');
  const tbody = h('tbody', null, h('tr', { class: 'empty-row' }, h('td', { colspan: RUN_COLUMNS.length + 1 }, loading('Loading runs…'))));
  const table = h('table', { id: 'runs-table', 'data-testid': 'runs-table' }, thead, tbody);
  const prevBtn = h('button', { id: 'runs-prev', type: 'button' }, '← Previous');
  const nextBtn = h('button', { id: 'runs-next', type: 'button' }, 'Next →');
  const pageInfo = h('span', { class: 'muted small' }, '');

  root.append(
    h('div', { class: 'page-title' }, h('h1', null, 'Runs')),
    h('section', { class: 'card' },
      h('div', { class: 'toolbar' }, search, statusSel, pipelineInput, kindInput,
        h('label', { class: 'field', title: 'Reload the table every 2 seconds' }, liveBox, 'live refresh')),
      h('div', { class: 'toolbar' }, compareBtn, h('span', { class: 'muted small', id: 'selected-count' }, ''), h('span', { class: 'spacer' }), csv),
      errBox,
      summary,
      h('div', { class: 'table-wrap' }, table),
      h('div', { class: 'pager' }, prevBtn, nextBtn, pageInfo)));

  function queryParams(withPage) {
    const q = { q: st.q, status: st.status, pipeline: st.pipeline, kind: st.kind, sort: st.sort, order: st.order };
    if (withPage) { q.limit = st.limit; q.offset = st.offset; }
    return q;
  }

  function updateUrl() {
    const q = queryParams(false);
    if (q.sort === 'started_at') delete q.sort;
    if (q.order === 'desc') delete q.order;
    if (st.offset) q.offset = st.offset;
    const s = qs(q);
    replaceHash(`#/runs${s ? '?' + s : ''}`);
    csv.href = `/api/runs.csv${qs(queryParams(false)) ? '?' + qs(queryParams(false)) : ''}`;
  }

  function renderHead() {
    const all = h('input', { type: 'checkbox', 'aria-label': 'Select all on this page', id: 'runs-select-all' });
    all.checked = st.rows.length > 0 && st.rows.every((r) => st.selected.has(r.run_id));
    all.addEventListener('change', () => {
      for (const r of st.rows) { if (all.checked) st.selected.add(r.run_id); else st.selected.delete(r.run_id); }
      renderBody();
    });
    thead.replaceChildren(h('tr', null, h('th', null, all), RUN_COLUMNS.map((c) => {
      const active = st.sort === c.key;
      const th = h('th', { class: `sortable${c.num ? ' num' : ''}`, 'data-sort': c.key, 'aria-sort': active ? (st.order === 'asc' ? 'ascending' : 'descending') : 'none', tabindex: 0, title: `Sort by ${c.label.toLowerCase()}` },
        c.label, active ? h('span', { class: 'arrow' }, st.order === 'asc' ? '▲' : '▼') : null);
      const go = () => {
        if (st.sort === c.key) st.order = st.order === 'asc' ? 'desc' : 'asc';
        else { st.sort = c.key; st.order = c.key === 'started_at' || c.key === 'duration_secs' ? 'desc' : 'asc'; }
        st.offset = 0;
        reload();
      };
      th.addEventListener('click', go);
      th.addEventListener('keydown', (ev) => { if (ev.key === 'Enter' || ev.key === ' ') { ev.preventDefault(); go(); } });
      return th;
    })));
  }

  function renderBody() {
    renderHead();
    if (st.rows.length === 0) {
      tbody.replaceChildren(h('tr', { class: 'empty-row' }, h('td', { colspan: RUN_COLUMNS.length + 1 },
        st.q || st.status || st.pipeline || st.kind ? 'No run matches these filters.' : 'No runs in the registry yet. Run `cargo xtask demo` or a pipeline.')));
    } else {
      tbody.replaceChildren(...st.rows.map((r) => {
        const box = h('input', { type: 'checkbox', 'aria-label': `Select ${r.run_id}`, 'data-id': r.run_id });
        box.checked = st.selected.has(r.run_id);
        box.addEventListener('change', () => {
          if (box.checked) st.selected.add(r.run_id); else st.selected.delete(r.run_id);
          tr.classList.toggle('selected', box.checked);
          updateSelection();
        });
        const tr = h('tr', { class: box.checked ? 'selected' : null, 'data-run-id': r.run_id }, h('td', null, box), runRowCells(r));
        return tr;
      }));
    }
    updateSelection();
    const from = st.total === 0 ? 0 : st.offset + 1;
    const to = st.offset + st.rows.length;
    summary.textContent = `${nf0.format(from)}–${nf0.format(to)} of ${nf0.format(st.total)} run${st.total === 1 ? '' : 's'}`;
    pageInfo.textContent = `page ${Math.floor(st.offset / st.limit) + 1} of ${Math.max(1, Math.ceil(st.total / st.limit))}`;
    prevBtn.disabled = st.offset <= 0;
    nextBtn.disabled = st.offset + st.rows.length >= st.total;
  }

  function updateSelection() {
    const n = st.selected.size;
    compareBtn.disabled = n < 2;
    root.querySelector('#selected-count').textContent = n ? `${n} selected` : 'select two or more runs to compare them';
  }

  async function load() {
    const seq = ++st.seq;
    st.inFlight = true;
    try {
      const res = await api(`/api/runs?${qs(queryParams(true))}`);
      if (!scope.alive || seq !== st.seq) return;
      st.rows = Array.isArray(res.runs) ? res.runs : [];
      st.total = Number.isFinite(res.total) ? res.total : st.rows.length;
      errBox.replaceChildren();
      renderBody();
    } catch (e) {
      if (!scope.alive || seq !== st.seq) return;
      st.rows = [];
      st.total = 0;
      showError(errBox, e, 'The runs could not be listed');
      renderHead();
      tbody.replaceChildren(h('tr', { class: 'empty-row' }, h('td', { colspan: RUN_COLUMNS.length + 1 }, 'No runs to show.')));
      summary.textContent = '';
      pageInfo.textContent = '';
      prevBtn.disabled = true;
      nextBtn.disabled = true;
    } finally {
      if (seq === st.seq) st.inFlight = false;
    }
  }

  function reload() { updateUrl(); load(); }

  let debounce = null;
  search.addEventListener('input', () => {
    clearTimeout(debounce);
    debounce = setTimeout(() => { st.q = search.value.trim(); st.offset = 0; reload(); }, 300);
  });
  scope.add(() => clearTimeout(debounce));
  const onFilter = () => { st.status = statusSel.value; st.pipeline = pipelineInput.value.trim(); st.kind = kindInput.value.trim(); st.offset = 0; reload(); };
  statusSel.addEventListener('change', onFilter);
  pipelineInput.addEventListener('change', onFilter);
  kindInput.addEventListener('change', onFilter);
  prevBtn.addEventListener('click', () => { st.offset = Math.max(0, st.offset - st.limit); reload(); });
  nextBtn.addEventListener('click', () => { st.offset += st.limit; reload(); });
  compareBtn.addEventListener('click', () => {
    if (st.selected.size < 2) return;
    location.hash = `#/compare?ids=${[...st.selected].map(enc).join(',')}`;
  });
  liveBox.addEventListener('change', () => {
    if (liveBox.checked) load();
  });
  scope.interval(() => { if (liveBox.checked && !st.inFlight) load(); }, 2000);

  renderHead();
  reload();
}

// ============================================================================
// Metric charts (run page and compare page)
// ============================================================================

const seriesCache = new Map();
function getSeries(runId, key) {
  const k = `${runId}\u0000${key}`;
  if (!seriesCache.has(k)) {
    const p = api(`/api/runs/${enc(runId)}/metrics/${enc(key)}`).catch((e) => { seriesCache.delete(k); throw e; });
    seriesCache.set(k, p);
  }
  return seriesCache.get(k);
}

/** Runs tasks with at most `limit` in flight. */
function pool(tasks, limit) {
  let i = 0;
  const next = () => {
    if (i >= tasks.length) return Promise.resolve();
    const t = tasks[i++];
    return Promise.resolve().then(t).catch(() => {}).then(next);
  };
  return Promise.all(Array.from({ length: Math.min(limit, tasks.length) }, next));
}

/**
 * A section of metric charts with one smoothing slider and one log-scale box for all.
 * items: [{key, runs: [{id, label, color}]}]
 */
function metricCharts(scope, items) {
  const smoothing = h('input', { id: 'smoothing', type: 'range', min: 0, max: 0.99, step: 0.01, value: 0, 'aria-label': 'Smoothing', style: { width: '160px' } });
  const smoothVal = h('span', { class: 'mono small', style: { minWidth: '3em' } }, '0.00');
  const logBox = h('input', { id: 'logscale', type: 'checkbox' });
  const grid = h('div', { class: 'charts-grid', id: 'metric-charts' });
  const section = h('div', { class: 'metric-charts' },
    h('div', { class: 'toolbar' },
      h('label', { class: 'field', title: 'Exponential moving average (0 = raw values)' }, h('span', null, 'Smoothing'), smoothing, smoothVal),
      h('label', { class: 'field' }, logBox, 'log scale (y)')),
    grid);
  const charts = [];
  for (const item of items) {
    const canvas = h('canvas', { 'aria-label': `Chart of ${item.key}` });
    const status = h('div');
    const card = h('div', { class: 'chart-card', 'data-key': item.key }, h('h4', null, item.key), status, canvas);
    grid.append(card);
    const chart = { item, canvas, status, data: new Map(), card };
    charts.push(chart);
  }
  const redraw = (chart) => {
    if (!chart.canvas.isConnected) return;
    const a = parseFloat(smoothing.value) || 0;
    const series = [];
    for (const r of chart.item.runs) {
      const d = chart.data.get(r.id);
      if (!d) continue;
      const xs = d.steps;
      const ys = d.values.map((v) => (v === null ? null : Number(v)));
      if (a > 0) {
        series.push({ xs, ys, color: r.color, width: 1, alpha: 0.25, legend: false });
        series.push({ label: r.label, xs, ys: ema(ys, a), color: r.color, width: 2 });
      } else {
        series.push({ label: r.label, xs, ys, color: r.color, width: 2 });
      }
    }
    drawChart(chart.canvas, {
      height: 230,
      series,
      xLabel: 'step',
      yLabel: chart.item.key,
      logY: logBox.checked,
      empty: chart.data.size ? 'no finite values' : 'loading…',
    });
  };
  const redrawAll = () => { for (const c of charts) redraw(c); };
  smoothing.addEventListener('input', () => { smoothVal.textContent = Number(smoothing.value).toFixed(2); redrawAll(); });
  logBox.addEventListener('change', redrawAll);
  scope.onResize(redrawAll);

  // Load the series (a few at a time) once the section is in the page.
  requestAnimationFrame(() => {
    redrawAll();
    const tasks = [];
    for (const c of charts) {
      for (const r of c.item.runs) {
        tasks.push(async () => {
          try {
            const s = await getSeries(r.id, c.item.key);
            if (!scope.alive) return;
            c.data.set(r.id, { steps: (s.steps || []).map(Number), values: s.values || [] });
          } catch (e) {
            if (!scope.alive) return;
            c.status.append(errorBox(e, `${c.item.key} of ${shortId(r.id)}`));
          }
          redraw(c);
        });
      }
    }
    pool(tasks, 4);
  });
  return section;
}

function metricsSummaryTable(metrics, id) {
  return h('div', { class: 'table-wrap' }, h('table', { id },
    h('thead', null, h('tr', null, ['metric', 'values', 'last', 'at step', 'min', 'at step', 'max', 'at step', 'mean'].map((c, i) => h('th', { class: i ? 'num' : null }, c)))),
    h('tbody', null, metrics.length === 0
      ? h('tr', { class: 'empty-row' }, h('td', { colspan: 9 }, 'This run logged no metrics.'))
      : metrics.map((m) => h('tr', null,
        h('td', { class: 'mono' }, m.key),
        h('td', { class: 'num' }, fmtNum(m.count)),
        h('td', { class: 'num' }, h('b', null, fmtNum(m.last))),
        h('td', { class: 'num muted' }, fmtNum(m.last_step)),
        h('td', { class: 'num' }, fmtNum(m.min)),
        h('td', { class: 'num muted' }, fmtNum(m.min_step)),
        h('td', { class: 'num' }, fmtNum(m.max)),
        h('td', { class: 'num muted' }, fmtNum(m.max_step)),
        h('td', { class: 'num' }, fmtNum(m.mean)))))));
}

// ============================================================================
// Page 4: one run
// ============================================================================

function artifactPath(a, runId) {
  const uri = String(a.uri || '');
  const marker = `runs/${a.run_id || runId}/${a.name}/`;
  let i = uri.indexOf(marker);
  if (i >= 0) return uri.slice(i + marker.length);
  const m2 = `/${a.name}/`;
  i = uri.indexOf(m2);
  if (i >= 0) return uri.slice(i + m2.length);
  return uri.split('/').pop() || a.name;
}

function artifactUrl(a, runId) {
  const path = artifactPath(a, runId);
  return `/api/runs/${enc(a.run_id || runId)}/artifacts/${enc(a.name)}/${path.split('/').map(enc).join('/')}`;
}

function extOf(s) {
  const m = String(s || '').toLowerCase().match(/\.([a-z0-9]+)$/);
  return m ? m[1] : '';
}

const IMAGE_EXT = new Set(['png', 'gif', 'jpg', 'jpeg', 'webp', 'svg']);
const TEXT_EXT = new Set(['md', 'txt', 'json', 'csv', 'tsv', 'yaml', 'yml', 'log', 'toml', 'geojson', 'jsonl']);

function parseCsvLine(line, sep) {
  const out = [];
  let cur = '';
  let q = false;
  for (let i = 0; i < line.length; i++) {
    const c = line[i];
    if (q) {
      if (c === '"' && line[i + 1] === '"') { cur += '"'; i++; } else if (c === '"') q = false; else cur += c;
    } else if (c === '"') q = true;
    else if (c === sep) { out.push(cur); cur = ''; } else cur += c;
  }
  out.push(cur);
  return out;
}

function artifactPreview(a, runId) {
  const path = artifactPath(a, runId);
  const ext = extOf(path) || extOf(a.uri) || extOf(a.name);
  const url = artifactUrl(a, runId);
  const box = h('div', { class: 'artifact-preview' });
  if (IMAGE_EXT.has(ext)) {
    const img = h('img', { src: url, alt: `${a.name}/${path}`, loading: 'lazy' });
    img.addEventListener('error', () => box.replaceChildren(errorBox(new ApiError('preview', `${path} could not be shown as an image.`), 'Preview')));
    box.append(img);
    return box;
  }
  if (!TEXT_EXT.has(ext)) return null;
  box.append(loading('Loading the first lines…'));
  fetchHead(url, 64 * 1024).then(({ text, truncated }) => {
    let lines = text.split(/\r?\n/);
    if (truncated) lines.pop();
    let note = '';
    if (ext === 'json' || ext === 'geojson') {
      if (!truncated) {
        try { lines = JSON.stringify(JSON.parse(text), null, 2).split('\n'); } catch { /* as text */ }
      }
    }
    const more = lines.length > 50 || truncated;
    lines = lines.slice(0, 50);
    note = more ? `first ${lines.length} lines` : '';
    if (ext === 'csv' || ext === 'tsv') {
      const sep = ext === 'tsv' ? '\t' : ',';
      const rows = lines.filter((l) => l.length).map((l) => parseCsvLine(l, sep));
      const [head, ...body] = rows;
      fill(box,
        h('div', { class: 'table-wrap csv-preview' }, h('table', null,
          head ? h('thead', null, h('tr', null, head.map((c) => h('th', null, c)))) : null,
          h('tbody', null, body.map((r) => h('tr', null, r.map((c) => h('td', null, c))))))),
        note ? h('div', { class: 'muted small' }, note) : null);
    } else {
      fill(box, h('pre', { class: 'block' }, lines.join('\n')), note ? h('div', { class: 'muted small' }, note) : null);
    }
  }).catch((e) => box.replaceChildren(errorBox(e, 'Preview')));
  return box;
}

/**
 * The datasets a data.dataset run registered: those named after its `name` parameter (the
 * dataset and its companions, `<name>_samples`), with the version this run made.
 */
async function runDatasets(run) {
  const name = run.params && typeof run.params.name === 'string' ? run.params.name : '';
  const list = (await api('/api/datasets')).datasets || [];
  const candidates = list.filter((x) => x.name === name || (name && x.name.startsWith(`${name}_`)));
  const out = [];
  for (const c of candidates) {
    let version = null;
    try {
      const d = await api(`/api/datasets/${enc(c.name)}`);
      const v = (d.versions || []).find((x) => x.run_id === run.run_id);
      if (!v && candidates.length > 1) continue;
      version = v ? v.version : null;
    } catch { /* listed without its version */ }
    out.push({ name: c.name, version });
  }
  return out;
}

function pageRun(root, id, scope) {
  id = decodeURIComponent(id);
  const page = h('div', { id: 'run-page', 'data-testid': 'run-page' }, loading(`Loading run ${id}…`));
  root.append(h('div', { class: 'page-title' }, h('h1', null, 'Run'), h('span', { class: 'crumbs' }, h('a', { href: '#/runs' }, '← all runs'))), page);

  api(`/api/runs/${enc(id)}`).then((d) => {
    if (!scope.alive) return;
    const run = d.run || {};
    const metrics = Array.isArray(d.metrics) ? d.metrics : [];
    const artifacts = Array.isArray(d.artifacts) ? d.artifacts : [];
    const lineage = Array.isArray(d.lineage) ? d.lineage : [];
    const children = Array.isArray(d.children) ? d.children : [];

    // Header.
    const facts = h('dl', { class: 'facts' });
    const fact = (k, ...v) => facts.append(h('dt', null, k), h('dd', null, ...v));
    fact('Kind', `${run.kind || '—'}${run.kind_version !== null && run.kind_version !== undefined ? ` (version ${run.kind_version})` : ''}`);
    fact('Pipeline', run.pipeline || '—', run.stage ? [' / stage ', h('b', null, run.stage)] : null);
    if (run.pipeline_run_id && run.pipeline_run_id !== run.run_id) fact('Pipeline run', runLink(run.pipeline_run_id, true));
    if (run.parent_run_id) fact('Parent', runLink(run.parent_run_id, true));
    fact('Started', fmtTimestamp(run.started_at));
    fact('Ended', fmtTimestamp(run.ended_at));
    fact('Duration', fmtDuration(run.duration_secs));
    if (run.git_commit) fact('Git commit', h('code', null, run.git_commit));
    if (run.cache_key) fact('Cache key', h('code', null, run.cache_key));
    const runId = run.run_id || id;
    if (run.kind === 'forecast.experiment' && run.status === 'succeeded') {
      fact('Results', h('a', { href: `#/tables/forecast?${qs({ run: runId })}`, id: 'run-table-link' }, 'Table III of this run'), h('span', { class: 'muted' }, ' (metrics with intervals, paired tests, plots)'));
    } else if (run.kind === 'rl.evaluate' && run.status === 'succeeded') {
      fact('Results', h('a', { href: `#/tables/rl?${qs({ run: runId })}`, id: 'run-table-link' }, 'Table IV of this run'), h('span', { class: 'muted' }, ' (agents with intervals, comparisons, recordings)'));
    }
    if (run.kind === 'data.dataset') {
      const dd = h('dd', { id: 'run-datasets' }, loading('Looking for its datasets…'));
      facts.append(h('dt', null, 'Datasets'), dd);
      runDatasets(run).then((found) => {
        if (!scope.alive) return;
        fill(dd, found.length === 0 ? h('span', { class: 'muted' }, 'none registered by this run')
          : found.map((f, k) => [k ? ' · ' : '', h('a', { href: `#/datasets/${enc(f.name)}` }, f.name),
            f.version ? h('span', { class: 'mono small muted' }, ` ${f.version}`) : null]));
      }).catch((e) => { if (scope.alive) fill(dd, errorBox(e, 'Datasets')); });
    }
    const header = h('section', { class: 'card', id: 'run-header' },
      h('div', { class: 'card-head' },
        h('h2', { style: { overflowWrap: 'anywhere' } }, h('span', { class: 'mono', id: 'run-id' }, run.run_id || id)),
        statusBadge(run.status)),
      facts,
      run.error ? h('div', { class: 'failure', id: 'run-error' }, h('strong', null, 'This run failed: '), h('pre', null, run.error)) : null);

    // Parameters.
    const flat = flatten(run.params && typeof run.params === 'object' ? run.params : {});
    const paramsCard = h('section', { class: 'card', id: 'run-params' },
      h('h3', null, `Parameters (${flat.length})`),
      flat.length === 0 ? h('p', { class: 'muted' }, 'No parameters recorded.')
        : h('div', { class: 'table-wrap' }, h('table', { class: 'kv' },
          h('thead', null, h('tr', null, h('th', null, 'name'), h('th', null, 'value'))),
          h('tbody', null, flat.map(([k, v]) => h('tr', null, h('td', null, k), h('td', null, fmtValue(v))))))));

    // Metrics.
    const curves = metrics.filter((m) => m.count > 1);
    const metricsCard = h('section', { class: 'card', id: 'run-metrics' },
      h('h3', null, `Metrics (${metrics.length})`),
      metricsSummaryTable(metrics, 'run-metrics-table'),
      curves.length ? h('div', { class: 'section-gap' },
        h('h4', null, `Curves (${curves.length})`),
        metricCharts(scope, curves.map((m) => ({ key: m.key, runs: [{ id: run.run_id || id, label: '', color: PALETTE[0] }] })))) : null);

    // Artifacts.
    const artCard = h('section', { class: 'card', id: 'run-artifacts' }, h('h3', null, `Artifacts (${artifacts.length})`));
    if (artifacts.length === 0) artCard.append(h('p', { class: 'muted' }, 'No artifacts recorded.'));
    else {
      const list = h('div');
      let previews = 0;
      for (const a of artifacts) {
        const path = artifactPath(a, id);
        const url = artifactUrl(a, id);
        const ext = extOf(path) || extOf(a.uri);
        const previewable = IMAGE_EXT.has(ext) || TEXT_EXT.has(ext);
        const row = h('div', { class: 'artifact', 'data-name': a.name },
          h('div', { class: 'toolbar', style: { margin: '4px 0' } },
            h('a', { href: url, target: '_blank', rel: 'noopener', class: 'mono' }, `${a.name}/${path}`),
            ext === 'rrd' ? rerunLink(url, `${a.name}/${path}`) : null,
            h('span', { class: 'muted small' }, fmtBytes(a.size)),
            h('span', { class: 'muted small mono', title: a.hash }, a.hash ? `hash ${String(a.hash).slice(0, 12)}` : ''),
            h('span', { class: 'muted small mono', style: { overflowWrap: 'anywhere' } }, a.uri)));
        if (previewable) {
          const det = h('details', null, h('summary', null, 'preview'));
          let filled = false;
          const fill = () => { if (!filled) { filled = true; const p = artifactPreview(a, id); if (p) det.append(p); } };
          det.addEventListener('toggle', () => { if (det.open) fill(); });
          if (previews < 6) { det.open = true; fill(); previews++; }
          row.append(det);
        }
        list.append(row);
      }
      artCard.append(list);
    }

    // Lineage.
    const linCard = h('section', { class: 'card', id: 'run-lineage' }, h('h3', null, `Lineage (${lineage.length})`),
      lineage.length === 0 ? h('p', { class: 'muted' }, 'No inputs or outputs recorded.')
        : h('div', { class: 'table-wrap' }, h('table', null,
          h('thead', null, h('tr', null, ['direction', 'name', 'uri', 'size', 'hash'].map((c) => h('th', { class: c === 'size' ? 'num' : null }, c)))),
          h('tbody', null, lineage.map((l) => h('tr', null,
            h('td', null, h('span', { class: `badge dir-${l.direction}` }, l.direction)),
            h('td', { class: 'mono' }, l.name),
            h('td', { class: 'mono small wrap' }, l.uri),
            h('td', { class: 'num' }, fmtBytes(l.size)),
            h('td', { class: 'mono small', title: l.hash }, l.hash ? String(l.hash).slice(0, 12) : '—')))))));

    // Children.
    const childCard = children.length ? h('section', { class: 'card', id: 'run-children' },
      h('h3', null, `Stage runs (${children.length})`), runsTable(children, { id: 'children-table' })) : null;

    // Log.
    let logCard = null;
    if (d.log) {
      const pre = h('pre', { class: 'block', id: 'run-log-text' });
      const det = h('details', { id: 'run-log' }, h('summary', null, 'Show the log'), pre);
      let loaded = false;
      det.addEventListener('toggle', () => {
        if (!det.open || loaded) return;
        loaded = true;
        pre.replaceChildren(loading('Loading the log…'));
        api(`/api/runs/${enc(run.run_id || id)}/log`, { text: true }).then((t) => {
          pre.textContent = t || '(empty log)';
          pre.scrollTop = pre.scrollHeight;
        }).catch((e) => { loaded = false; det.replaceChildren(det.firstChild, errorBox(e, 'The log could not be read'), pre); pre.textContent = ''; });
      });
      logCard = h('section', { class: 'card' }, h('h3', null, 'Log'), det);
    }

    fill(page, header, paramsCard, metricsCard, artCard, linCard, childCard, logCard);
  }).catch((e) => {
    if (!scope.alive) return;
    showError(page, e, `Run ${id}`);
  });
}

// ============================================================================
// Page 5: compare
// ============================================================================

function pageCompare(root, params, scope) {
  const ids = (params.get('ids') || '').split(',').map((s) => s.trim()).filter(Boolean);
  const page = h('div', { id: 'compare-page', 'data-testid': 'compare-page' });
  root.append(h('div', { class: 'page-title' }, h('h1', null, 'Compare runs'), h('span', { class: 'crumbs' }, h('a', { href: '#/runs' }, '← all runs'))), page);
  if (ids.length === 0) {
    page.append(errorBox(new ApiError('bad_request', 'No runs to compare: pick them in the runs table (#/compare?ids=a,b).'), 'Compare'));
    return;
  }
  page.append(loading(`Loading ${ids.length} runs…`));
  api(`/api/compare?${qs({ ids: ids.join(',') })}`).then((d) => {
    if (!scope.alive) return;
    const runs = Array.isArray(d.runs) ? d.runs : [];
    const colors = runs.map((_, i) => PALETTE[i % PALETTE.length]);
    const labels = runs.map((r) => shortId(r.run_id));
    const paramsObj = d.params || {};
    const differing = new Set(Array.isArray(d.differing) ? d.differing : []);
    const names = Object.keys(paramsObj).sort();

    const runHead = (i) => h('th', null, h('span', { class: 'swatch', style: { background: colors[i] } }), runLink(runs[i].run_id));

    // Parameters.
    const showAll = h('input', { type: 'checkbox', id: 'show-all-params' });
    const ptBody = h('tbody');
    const renderParams = () => {
      const shown = names.filter((n) => showAll.checked || differing.has(n));
      ptBody.replaceChildren(...(shown.length === 0
        ? [h('tr', { class: 'empty-row' }, h('td', { colspan: runs.length + 1 }, names.length ? 'No parameter differs between these runs.' : 'No parameters recorded.'))]
        : shown.map((n) => h('tr', { class: differing.has(n) ? 'diff' : null, 'data-param': n },
          h('td', { class: 'mono small' }, n),
          runs.map((_, i) => h('td', { class: 'mono small wrap' }, fmtValue((paramsObj[n] || [])[i])))))));
    };
    showAll.addEventListener('change', renderParams);
    renderParams();
    const paramsCard = h('section', { class: 'card', id: 'compare-params' },
      h('div', { class: 'card-head' }, h('h3', null, `Parameters that differ (${differing.size} of ${names.length})`),
        h('label', { class: 'field' }, showAll, 'show all parameters')),
      h('div', { class: 'table-wrap' }, h('table', { class: 'kv', id: 'compare-params-table' },
        h('thead', null, h('tr', null, h('th', null, 'parameter'), runs.map((_, i) => runHead(i)))),
        ptBody)));

    // Metrics.
    const mobj = d.metrics || {};
    const keys = Object.keys(mobj).sort();
    const metricsCard = h('section', { class: 'card', id: 'compare-metrics' },
      h('h3', null, `Metrics (${keys.length})`),
      keys.length === 0 ? h('p', { class: 'muted' }, 'None of these runs logged metrics.')
        : h('div', { class: 'table-wrap' }, h('table', { id: 'compare-metrics-table' },
          h('thead', null, h('tr', null, h('th', null, 'metric'), runs.map((_, i) => runHead(i)))),
          h('tbody', null, keys.map((k) => h('tr', null,
            h('td', { class: 'mono small' }, k),
            runs.map((_, i) => {
              const s = (mobj[k] || [])[i];
              if (!s) return h('td', { class: 'muted' }, '—');
              return h('td', { class: 'num', title: `count ${s.count}, mean ${fmtNum(s.mean)}` },
                h('b', null, fmtNum(s.last)),
                s.count > 1 ? h('div', { class: 'muted small' }, `min ${fmtNum(s.min)} · max ${fmtNum(s.max)} · n ${fmtNum(s.count)}`) : null);
            })))))));

    // Curves.
    const curveKeys = keys.filter((k) => (mobj[k] || []).some((s) => s && s.count > 1));
    const curvesCard = h('section', { class: 'card', id: 'compare-curves' },
      h('h3', null, `Curves (${curveKeys.length})`),
      curveKeys.length === 0 ? h('p', { class: 'muted' }, 'No metric has more than one value in these runs.')
        : metricCharts(scope, curveKeys.map((k) => ({
          key: k,
          runs: runs.map((r, i) => ({ id: r.run_id, label: labels[i], color: colors[i], has: ((mobj[k] || [])[i] || {}).count > 1 }))
            .filter((r, i) => (mobj[k] || [])[i]),
        }))));

    const missing = ids.filter((x) => !runs.some((r) => r.run_id === x || r.run_id.startsWith(x)));
    fill(page,
      missing.length ? h('div', { class: 'warning' }, `Not found: ${missing.join(', ')}`) : null,
      h('section', { class: 'card', id: 'compare-runs' }, h('h3', null, `Runs (${runs.length})`), runsTable(runs, { id: 'compare-runs-table', colors })),
      paramsCard, metricsCard,
      groupSection(scope, runs.map((r) => r.run_id), [...differing].sort(), params.get('group')),
      curvesCard);
  }).catch((e) => {
    if (!scope.alive) return;
    showError(page, e, 'The runs could not be compared');
  });
}

// ============================================================================
// Result pages: shared pieces (tables with intervals, plots, Rerun links, Markdown)
// ============================================================================

const f3 = (v) => (Math.abs(v) < 5e-4 ? 0 : v).toFixed(3);
const fPct1 = (v) => (v * 100).toFixed(1);

function finite(v) { return typeof v === 'number' && Number.isFinite(v) ? v : null; }

/** A p-value: three decimals, or an exponent below 0.001. */
function fmtP(p) {
  if (!Number.isFinite(p)) return '—';
  return p < 1e-3 ? p.toExponential(1) : p.toFixed(3);
}

/** A signed number for differences (+0.044, −374). */
function fmtSigned(v, fmt) {
  if (!Number.isFinite(v)) return '—';
  const s = fmt(Math.abs(v));
  return v > 0 ? `+${s}` : v < 0 ? `−${s}` : s;
}

/** A table cell with an estimate and, under it, its interval [low, high]. */
function ciCell(est, lo, hi, fmt, opts = {}) {
  const has = Number.isFinite(lo) && Number.isFinite(hi);
  return h('td', { class: `num ci${opts.cls ? ' ' + opts.cls : ''}`, title: opts.title || null },
    h('span', { class: 'est' }, Number.isFinite(est) ? fmt(est) : '—'),
    has ? h('span', { class: 'ival' }, fmtInterval(lo, hi, fmt)) : null);
}

/** "[low, high]", or "[low … high]" when the numbers have thousands separators. */
function fmtInterval(lo, hi, fmt) {
  const a = fmt(lo);
  const b = fmt(hi);
  return `[${a}${(a + b).includes(',') ? ' … ' : ', '}${b}]`;
}

/** A bootstrap estimate object ({estimate, low, high}) as a cell. */
function estCell(o, fmt, opts = {}) {
  if (!o || typeof o !== 'object') return h('td', { class: 'num muted' }, '—');
  return ciCell(finite(o.estimate), finite(o.low), finite(o.high), fmt, opts);
}

/**
 * A table sorted by clicking a column head.
 * columns: [{key, label, title, num, value(row) → sort key (none: not sortable), cell(row) → <td>,
 *            best: 'max'|'min' (the best value of the column is marked)}]
 * opts: {id, cls, columns, rows, sort: {key, order}, rowAttrs(row), empty}
 */
function sortableTable(opts) {
  const st = { key: opts.sort ? opts.sort.key : null, order: opts.sort && opts.sort.order === 'asc' ? 'asc' : 'desc' };
  const thead = h('thead');
  const tbody = h('tbody');
  const table = h('table', { id: opts.id || null, class: opts.cls || null }, thead, tbody);
  const missing = (x) => x === null || x === undefined || x === '' || (typeof x === 'number' && !Number.isFinite(x));
  const best = {};
  for (const c of opts.columns) {
    if (!c.best || !c.value) continue;
    const vals = opts.rows.map(c.value).filter((v) => typeof v === 'number' && Number.isFinite(v));
    if (vals.length > 1 && Math.min(...vals) !== Math.max(...vals)) best[c.key] = c.best === 'min' ? Math.min(...vals) : Math.max(...vals);
  }
  const render = () => {
    const col = opts.columns.find((c) => c.key === st.key && c.value);
    const rows = opts.rows.slice();
    if (col) {
      const dir = st.order === 'asc' ? 1 : -1;
      rows.sort((a, b) => {
        const x = col.value(a);
        const y = col.value(b);
        const xm = missing(x);
        const ym = missing(y);
        if (xm || ym) return Number(xm) - Number(ym);
        if (typeof x === 'number' && typeof y === 'number') return (x - y) * dir;
        return String(x).localeCompare(String(y), 'en', { numeric: true }) * dir;
      });
    }
    thead.replaceChildren(h('tr', null, opts.columns.map((c) => {
      const sortable = !!c.value;
      const active = sortable && st.key === c.key;
      const th = h('th', {
        class: [sortable ? 'sortable' : '', c.num ? 'num' : ''].filter(Boolean).join(' ') || null,
        'data-sort': c.key,
        'aria-sort': sortable ? (active ? (st.order === 'asc' ? 'ascending' : 'descending') : 'none') : null,
        tabindex: sortable ? 0 : null,
        title: c.title || (sortable ? `Sort by ${c.label}` : null),
      }, c.label, active ? h('span', { class: 'arrow' }, st.order === 'asc' ? '▲' : '▼') : null);
      if (sortable) {
        const go = () => {
          if (st.key === c.key) st.order = st.order === 'asc' ? 'desc' : 'asc';
          else { st.key = c.key; st.order = c.num ? (c.best === 'min' ? 'asc' : 'desc') : 'asc'; }
          render();
        };
        th.addEventListener('click', go);
        th.addEventListener('keydown', (ev) => { if (ev.key === 'Enter' || ev.key === ' ') { ev.preventDefault(); go(); } });
      }
      return th;
    })));
    tbody.replaceChildren(...(rows.length === 0
      ? [h('tr', { class: 'empty-row' }, h('td', { colspan: opts.columns.length }, opts.empty || 'Nothing to show.'))]
      : rows.map((r) => h('tr', opts.rowAttrs ? opts.rowAttrs(r) : null, opts.columns.map((c) => {
        const td = c.cell(r);
        if (best[c.key] !== undefined && c.value(r) === best[c.key]) {
          td.classList.add('best');
          td.title = `${td.title ? td.title + ' — ' : ''}best in this column`;
        }
        return td;
      })))));
  };
  render();
  return h('div', { class: 'table-wrap' }, table);
}

/** A plain table of objects (unknown shapes): one column per key. */
function objectsTable(items, id) {
  const first = ['name', 'split', 'tier', 'feature'];
  const keys = [];
  for (const it of items) for (const k of Object.keys(it || {})) if (!keys.includes(k)) keys.push(k);
  keys.sort((a, b) => (first.indexOf(a) < 0 ? 99 : first.indexOf(a)) - (first.indexOf(b) < 0 ? 99 : first.indexOf(b)));
  return h('div', { class: 'table-wrap' }, h('table', { id: id || null },
    h('thead', null, h('tr', null, keys.map((k) => h('th', { class: items.some((it) => typeof (it || {})[k] === 'number') ? 'num' : null }, k)))),
    h('tbody', null, items.map((it) => h('tr', null, keys.map((k) => {
      const v = (it || {})[k];
      return h('td', { class: typeof v === 'number' ? 'num' : 'wrap' }, typeof v === 'number' ? fmtNum(v) : fmtValue(v));
    }))))));
}

/** The URL of a file a run wrote (one of its lineage outputs). */
function outputUrl(runId, name, path) {
  return `/api/runs/${enc(runId)}/outputs/${enc(name)}/${String(path).split('/').map(enc).join('/')}`;
}

/** Rerun's web viewer (served by this server) on a recording the server serves. */
function rerunHref(fileUrl) {
  return `/rerun/?url=${enc(new URL(fileUrl, location.href).href)}`;
}

function rerunLink(fileUrl, label) {
  return h('a', {
    class: 'button rerun-link', href: rerunHref(fileUrl), target: '_blank', rel: 'noopener',
    title: `Open ${label || 'this recording'} in Rerun's web viewer (new tab; the viewer takes a few seconds to load)`,
    'data-testid': 'open-rerun',
  }, '▶ Open in Rerun');
}

/** A large view of an image over the page (Esc, the × or a click beside it closes it). */
function openLightbox(scope, src, caption) {
  let open = true;
  const close = () => {
    if (!open) return;
    open = false;
    box.remove();
    document.removeEventListener('keydown', onKey);
  };
  const onKey = (ev) => { if (ev.key === 'Escape') close(); };
  const closeBtn = h('button', { type: 'button', class: 'lightbox-close', 'aria-label': 'Close', onclick: close }, '×');
  const box = h('div', { class: 'lightbox', role: 'dialog', 'aria-modal': 'true', 'aria-label': caption },
    h('figure', null,
      h('img', { src, alt: caption }),
      h('figcaption', null, h('span', null, caption), h('a', { href: src, target: '_blank', rel: 'noopener' }, 'open the file'), closeBtn)));
  box.addEventListener('click', (ev) => { if (ev.target === box) close(); });
  document.body.append(box);
  document.addEventListener('keydown', onKey);
  scope.add(close);
  closeBtn.focus();
}

/** A plot: large ones fill their column, thumbnails are small; a click enlarges either. */
function plotFigure(scope, url, caption, large) {
  const img = h('img', { src: url, alt: caption, loading: large ? 'eager' : 'lazy', class: 'plot-img' });
  const fig = h('figure', { class: `plot ${large ? 'large' : 'thumb'}`, 'data-plot': url.split('/').pop() },
    h('button', { type: 'button', class: 'plot-open', title: `Enlarge: ${caption}`, onclick: () => openLightbox(scope, url, caption) }, img),
    h('figcaption', null, caption));
  img.addEventListener('error', () => fig.replaceChildren(errorBox(new ApiError('preview', `${caption} (${url.split('/').pop()}) could not be loaded.`), 'Plot')));
  return fig;
}

/** A picker of the runs a result page can show. */
function runPicker(runs, current, onPick) {
  const sel = h('select', { id: 'table-run', 'data-testid': 'table-run', 'aria-label': 'Run' },
    runs.map((r) => h('option', { value: r.run_id, title: r.run_id },
      `${fmtTimestamp(r.started_at)} · ${r.pipeline || '—'} / ${r.stage || '—'} · ${shortId(r.run_id)}`)));
  if (current && !runs.some((r) => r.run_id === current)) sel.prepend(h('option', { value: current }, current));
  sel.value = current;
  sel.addEventListener('change', () => onPick(sel.value));
  return h('label', { class: 'field' }, h('span', null, `Run (${runs.length})`), sel);
}

function safeId(s) { return String(s).replace(/[^A-Za-z0-9_-]/g, '_'); }

// ---------- Markdown (dataset cards) ----------

/**
 * Markdown → DOM for dataset cards: headings, paragraphs, lists, tables, code blocks, quotes,
 * rules; inline code, bold, italics, links and images. Only text nodes and fixed elements are
 * made: HTML in the text shows as text. opts.link(href) → a URL or null (text only);
 * opts.image(src, alt) → an element or null (the alt text in brackets).
 */
function renderMarkdown(text, opts = {}) {
  const lines = String(text || '').replace(/\r\n?/g, '\n').split('\n');
  const out = h('div', { class: 'markdown' });
  let i = 0;
  const indentOf = (l) => l.match(/^\s*/)[0].replace(/\t/g, '    ').length;
  const isBlank = (l) => /^\s*$/.test(l);
  const isFence = (l) => /^\s*(```|~~~)/.test(l);
  const isHeading = (l) => /^#{1,6}\s/.test(l);
  const isRule = (l) => /^\s{0,3}([-*_])(\s*\1){2,}\s*$/.test(l);
  const listRe = /^(\s*)([-*+]|\d{1,9}[.)])\s+(.*)$/;
  const isList = (l) => listRe.test(l) && !isRule(l);
  const isQuote = (l) => /^\s{0,3}>/.test(l);
  const delimRe = /^\s*\|?\s*:?-+:?\s*(\|\s*:?-+:?\s*)*\|?\s*$/;
  const isTable = (k) => k + 1 < lines.length && lines[k].includes('|') && lines[k + 1].includes('-') && delimRe.test(lines[k + 1]);
  const startsBlock = (k) => isFence(lines[k]) || isHeading(lines[k]) || isList(lines[k]) || isQuote(lines[k]) || isRule(lines[k]) || isTable(k);

  const safeHref = (href) => {
    const s = String(href).trim();
    if (opts.link) return opts.link(s);
    return /^(https?:|mailto:|#)/i.test(s) ? s : null;
  };

  function inline(s) {
    const frag = document.createDocumentFragment();
    const re = /(`+)([\s\S]*?[^`])\1(?!`)|!\[([^\]]*)\]\(\s*([^)\s]+)(?:\s+"[^"]*")?\s*\)|\[([^\]]+)\]\(\s*([^)\s]+)(?:\s+"[^"]*")?\s*\)|\*\*(?=\S)([\s\S]*?\S)\*\*|__(?=\S)([\s\S]*?\S)__(?![A-Za-z0-9])|\*(?=[^\s*])([\s\S]*?[^\s*])\*|(?<![A-Za-z0-9_])_(?=[^\s_])([\s\S]*?[^\s_])_(?![A-Za-z0-9_])|(https?:\/\/[^\s<>()]*[^\s<>().,;:!?'"])|( {2,}|\\)\n/g;
    let last = 0;
    let m;
    while ((m = re.exec(s))) {
      if (m.index > last) frag.append(s.slice(last, m.index));
      last = re.lastIndex;
      if (m[1]) frag.append(h('code', null, m[2].replace(/^ (.*) $/, '$1')));
      else if (m[4] !== undefined) {
        const el = opts.image ? opts.image(m[4], m[3]) : null;
        frag.append(el || `[${m[3] || 'image'}]`);
      } else if (m[6] !== undefined) {
        const href = safeHref(m[6]);
        frag.append(href ? h('a', { href, target: /^https?:/i.test(href) ? '_blank' : null, rel: 'noopener' }, inline(m[5])) : inline(m[5]));
      } else if (m[7] !== undefined || m[8] !== undefined) frag.append(h('strong', null, inline(m[7] !== undefined ? m[7] : m[8])));
      else if (m[9] !== undefined || m[10] !== undefined) frag.append(h('em', null, inline(m[9] !== undefined ? m[9] : m[10])));
      else if (m[11]) frag.append(h('a', { href: m[11], target: '_blank', rel: 'noopener' }, m[11]));
      else if (m[12]) frag.append(h('br'));
    }
    if (last < s.length) frag.append(s.slice(last));
    return frag;
  }

  function splitRow(l) {
    let s = l.trim();
    if (s.startsWith('|')) s = s.slice(1);
    if (s.endsWith('|') && !s.endsWith('\\|')) s = s.slice(0, -1);
    const cells = [];
    let cur = '';
    let code = false;
    for (let k = 0; k < s.length; k++) {
      const c = s[k];
      if (c === '\\' && s[k + 1] === '|') { cur += '|'; k++; continue; }
      if (c === '`') code = !code;
      if (c === '|' && !code) { cells.push(cur.trim()); cur = ''; continue; }
      cur += c;
    }
    cells.push(cur.trim());
    return cells;
  }

  function table() {
    const head = splitRow(lines[i]);
    const aligns = splitRow(lines[i + 1]).map((c) => (c.startsWith(':') && c.endsWith(':') ? 'center' : c.endsWith(':') ? 'right' : null));
    i += 2;
    const body = [];
    while (i < lines.length && !isBlank(lines[i]) && lines[i].includes('|')) body.push(splitRow(lines[i++]));
    const st = (k) => (aligns[k] ? { textAlign: aligns[k] } : null);
    return h('div', { class: 'table-wrap' }, h('table', null,
      h('thead', null, h('tr', null, head.map((c, k) => h('th', { style: st(k) }, inline(c))))),
      h('tbody', null, body.map((r) => h('tr', null, head.map((_, k) => h('td', { style: st(k) }, inline(r[k] || ''))))))));
  }

  function list() {
    const first = lines[i].match(listRe);
    const indent = indentOf(first[1]);
    const ordered = /\d/.test(first[2]);
    const el = h(ordered ? 'ol' : 'ul');
    if (ordered && parseInt(first[2], 10) !== 1) el.setAttribute('start', String(parseInt(first[2], 10)));
    while (i < lines.length) {
      const m = lines[i].match(listRe);
      if (!m || isRule(lines[i]) || indentOf(m[1]) !== indent || /\d/.test(m[2]) !== ordered) break;
      const li = h('li');
      let text = [m[3]];
      const flush = () => { if (text.length) { li.append(inline(text.join('\n'))); text = []; } };
      i++;
      while (i < lines.length) {
        const l = lines[i];
        if (isBlank(l)) {
          let k = i + 1;
          while (k < lines.length && isBlank(lines[k])) k++;
          if (k < lines.length && indentOf(lines[k]) > indent) { i = k; if (!listRe.test(lines[k])) { flush(); } continue; }
          if (k < lines.length && listRe.test(lines[k]) && indentOf(lines[k]) === indent) { i = k; }
          break;
        }
        const lm = l.match(listRe);
        if (lm && indentOf(lm[1]) > indent && !isRule(l)) { flush(); li.append(list()); continue; }
        if (lm) break;
        if (indentOf(l) > indent) {
          if (isFence(l)) { flush(); li.append(fence()); continue; }
          text.push(l.trim()); i++; continue;
        }
        if (startsBlock(i)) break;
        text.push(l.trim()); // a lazy continuation line
        i++;
      }
      flush();
      el.append(li);
    }
    return el;
  }

  function fence() {
    const open = lines[i].trim();
    const marker = open.slice(0, 3);
    const lang = open.slice(3).trim();
    const indent = indentOf(lines[i]);
    const body = [];
    i++;
    while (i < lines.length && !lines[i].trim().startsWith(marker)) body.push(lines[i++].slice(Math.min(indent, indentOf(lines[i - 1]))));
    i++;
    return h('pre', { class: 'block', 'data-lang': lang || null }, h('code', null, body.join('\n')));
  }

  function blocks(target, stopAt) {
    while (i < lines.length && (stopAt === undefined || i < stopAt)) {
      const line = lines[i];
      if (isBlank(line)) { i++; continue; }
      if (isFence(line)) { target.append(fence()); continue; }
      const hm = line.match(/^(#{1,6})\s+(.*?)(\s+#+)?\s*$/);
      if (hm) {
        const level = Math.min(6, hm[1].length + (opts.shift || 0));
        target.append(h(`h${level}`, { class: 'md-h' }, inline(hm[2])));
        i++;
        continue;
      }
      if (isRule(line)) { target.append(h('hr')); i++; continue; }
      if (isTable(i)) { target.append(table()); continue; }
      if (isList(line)) { target.append(list()); continue; }
      if (isQuote(line)) {
        const inner = [];
        while (i < lines.length && isQuote(lines[i])) inner.push(lines[i++].replace(/^\s{0,3}>\s?/, ''));
        target.append(h('blockquote', null, renderMarkdown(inner.join('\n'), opts)));
        continue;
      }
      const para = [];
      while (i < lines.length && !isBlank(lines[i]) && (para.length === 0 || !startsBlock(i))) para.push(lines[i++].replace(/^\s+/, ''));
      target.append(h('p', null, inline(para.join('\n'))));
    }
  }

  blocks(out);
  return out;
}

// ============================================================================
// Page 6: Table III (a forecast.experiment run)
// ============================================================================

const T3_METRICS = [
  { key: 'accuracy', label: 'Accuracy [%]', fmt: fPct1 },
  { key: 'precision', label: 'Precision' },
  { key: 'recall', label: 'Recall' },
  { key: 'f1', label: 'F1' },
  { key: 'auroc', label: 'AUROC' },
  { key: 'auprc', label: 'AUPRC' },
  { key: 'brier', label: 'Brier', lower: true, title: 'Brier score (lower is better)' },
  { key: 'ece', label: 'ECE', lower: true, title: 'Expected calibration error (lower is better)' },
];

const PLOT_KINDS = ['precision_recall', 'auroc_forest', 'auprc_forest', 'calibration', 'confusion', 'training', 'roc'];
const PLOT_LABELS = {
  roc: 'ROC curves',
  precision_recall: 'Precision–recall curves',
  calibration: 'Calibration (reliability)',
  auroc_forest: 'AUROC with intervals',
  auprc_forest: 'AUPRC with intervals',
  confusion: 'Confusion matrix',
  training: 'Training curves',
};
const MAIN_PLOTS = ['roc', 'precision_recall', 'calibration'];

/** A plot file of an experiment: its kind, protocol and model (from `kind_protocol[_model].png`). */
function classifyPlot(path, protocols) {
  const stem = path.split('/').pop().replace(/\.png$/i, '');
  for (const kind of PLOT_KINDS) {
    if (!stem.startsWith(kind + '_')) continue;
    const rest = stem.slice(kind.length + 1);
    let proto = null;
    for (const p of protocols) if ((rest === p || rest.startsWith(p + '_')) && (proto === null || p.length > proto.length)) proto = p;
    if (proto === null) continue;
    return { kind, protocol: proto, model: rest === proto ? '' : rest.slice(proto.length + 1), path };
  }
  return { kind: 'other', protocol: null, model: '', path, stem };
}

function plotCaption(p) {
  if (p.kind === 'other') return p.stem || p.path;
  const label = PLOT_LABELS[p.kind] || p.kind;
  return p.model ? `${label}: ${p.model}` : label;
}

/** Thresholds of a result row over its seeds: {mean, differ, rule, all}. */
function thresholdOf(r) {
  const all = (Array.isArray(r.runs) ? r.runs : []).map((x) => finite(x.threshold)).filter((x) => x !== null);
  const rules = [...new Set((r.runs || []).map((x) => x.threshold_rule).filter(Boolean))];
  if (!all.length) return { mean: null, differ: false, rule: rules.join('; '), all };
  const mean = all.reduce((a, b) => a + b, 0) / all.length;
  return { mean, differ: Math.max(...all) - Math.min(...all) > 1e-9, rule: rules.join('; '), all };
}

function pageTableForecast(root, params, scope) {
  const asked = params.get('run') || '';
  const page = h('div', { id: 'table3-page', 'data-testid': 'table3-page' }, loading('Loading Table III…'));
  root.append(h('div', { class: 'page-title' },
    h('h1', null, 'Table III — ignition forecasts'),
    h('span', { class: 'crumbs' }, h('a', { href: `#/runs?${qs({ kind: 'forecast.experiment' })}` }, 'forecast.experiment runs'))), page);

  api(`/api/tables/forecast${asked ? `?${qs({ run: asked })}` : ''}`).then((d) => {
    if (!scope.alive) return;
    const run = d.run || {};
    const res = d.results || {};
    const runId = run.run_id || asked;
    const rows = Array.isArray(res.results) ? res.results : [];
    const protocols = (Array.isArray(res.protocols) ? res.protocols : []).slice();
    for (const r of rows) if (r.protocol && !protocols.some((p) => p.name === r.protocol)) protocols.push({ name: r.protocol });
    // The headline protocol first, then in the experiment's order.
    protocols.sort((a, b) => Number(b.name === res.headline) - Number(a.name === res.headline));
    const plots = (Array.isArray(d.plots) ? d.plots : []).map((p) => classifyPlot(p, protocols.map((x) => x.name)));
    const output = d.output || { name: 'report' };
    const plotUrl = (p) => outputUrl(runId, output.name || 'report', p.path);
    const models = [...new Set(rows.map((r) => r.model))];

    const facts = h('dl', { class: 'facts' });
    const fact = (k, ...v) => facts.append(h('dt', null, k), h('dd', null, ...v));
    fact('Experiment', h('b', null, res.name || run.params && run.params.name || '—'));
    fact('Run', runLink(runId, true), ' · ', run.pipeline || '—', run.stage ? [' / ', run.stage] : null, ' · ', fmtTimestamp(run.started_at));
    if (res.dataset) {
      fact('Dataset', h('a', { href: `#/datasets/${enc(res.dataset)}`, id: 'table3-dataset' }, res.dataset),
        res.dataset_version ? h('span', { class: 'mono small muted' }, ` ${res.dataset_version}`) : null,
        res.framing ? h('span', { class: 'muted' }, ` · ${res.framing} framing`) : null);
    }
    fact('Models', `${models.length}: `, h('span', { class: 'small' }, models.join(', ')));
    fact('Intervals', `${Math.round((res.level || 0.95) * 100)} % percentile bootstrap${res.bootstrap ? `, ${nf0.format(res.bootstrap)} resamples` : ''}${res.cluster ? ` of test ${res.cluster}s` : ''}; models with several seeds averaged over them`);
    if (output.path) fact('Files', h('code', null, output.path), ' (', h('a', { href: plotUrl({ path: 'results.json' }), target: '_blank', rel: 'noopener' }, 'results.json'), ')');
    const head = h('section', { class: 'card', id: 'table3-head' },
      h('div', { class: 'toolbar' },
        runPicker(Array.isArray(d.runs) ? d.runs : [], runId, (id) => { location.hash = `#/tables/forecast?${qs({ run: id })}`; }),
        h('a', { class: 'button', href: `#/runs/${enc(runId)}` }, 'Run page')),
      facts);

    const sections = protocols.map((p) => table3Protocol(scope, p, res, rows.filter((r) => r.protocol === p.name),
      plots.filter((x) => x.protocol === p.name), plotUrl));
    const others = plots.filter((x) => x.protocol === null);
    fill(page, head, sections,
      others.length ? h('section', { class: 'card', id: 'table3-other-plots' }, h('h3', null, `Other plots (${others.length})`),
        h('div', { class: 'plot-thumbs' }, others.map((p) => plotFigure(scope, plotUrl(p), plotCaption(p), false)))) : null);
  }).catch((e) => {
    if (!scope.alive) return;
    showError(page, e, 'Table III');
  });
}

function table3Protocol(scope, p, res, rows, plots, plotUrl) {
  const headline = p.name === res.headline;
  const level = Math.round((res.level || 0.95) * 100);
  const desc = [];
  if (Array.isArray(p.days) && p.days.length === 2) {
    const [a, b] = p.days;
    desc.push(h('p', null, `Inputs: days ${a}…${b} relative to the predicted date`,
      p.leaks_future === false ? ' — they end before the predicted date (a forecast).' : '.'));
  }
  if (p.leaks_future) {
    desc.push(h('div', { class: 'warning leak-note' }, h('strong', null, 'Leak: '),
      'the inputs include days on and after the predicted date (the ignition itself), as the published FireCastRL table did; these scores are not a forecast\u2019s.'));
  }
  if (p.split || Number.isFinite(p.train)) {
    desc.push(h('p', null,
      p.split ? ['Split: ', p.split, '. '] : null,
      Number.isFinite(p.train) ? `Train ${nf0.format(p.train)} / val ${nf0.format(p.val)} / test ${nf0.format(p.test)}` : null,
      Number.isFinite(p.test_positives) ? ` (${nf0.format(p.test_positives)} positive, prevalence ${f3(p.prevalence)})` : null,
      p.dropped ? `; ${nf0.format(p.dropped)} samples dropped` : null, '.'));
  }
  if (Number.isFinite(p.majority_accuracy)) {
    desc.push(h('p', { class: 'muted' }, `No skill: majority-class accuracy ${fPct1(p.majority_accuracy)} %, AUPRC ${f3(p.prevalence)} (the prevalence), AUROC 0.5.`,
      p.oracle ? ` Oracle (the synthetic generator's true probabilities, never a model input): AUROC ${f3(p.oracle.auroc)}, AUPRC ${f3(p.oracle.auprc)}.` : null));
  }

  const cols = [
    { key: 'model', label: 'Model', value: (r) => r.model, cell: (r) => h('td', { class: 'mono nowrap' }, r.model, r.kind && r.kind !== r.model ? h('div', { class: 'muted small' }, r.kind) : null) },
    { key: 'family', label: 'Family', value: (r) => r.family || '', cell: (r) => h('td', { class: 'small' }, r.family || '—') },
    ...T3_METRICS.map((m) => ({
      key: m.key, label: m.label, num: true, best: m.lower ? 'min' : 'max', title: m.title || null,
      value: (r) => finite((r.test || {})[m.key]),
      cell: (r) => {
        const iv = (r.intervals || {})[m.key];
        const sd = finite((r.seed_std || {})[m.key]);
        const fmt = m.fmt || f3;
        const nSeeds = (r.seeds || []).length;
        const lo = Array.isArray(iv) ? finite(iv[0]) : null;
        const hi = Array.isArray(iv) ? finite(iv[1]) : null;
        return ciCell(finite((r.test || {})[m.key]), lo, hi, fmt, {
          title: `${m.label}: ${r.model} on the test split${lo !== null ? `, ${level} % interval ${fmtInterval(lo, hi, fmt)}` : ''}${nSeeds > 1 && sd !== null ? `; seed standard deviation ${fmt(sd)} over ${nSeeds} seeds` : ''}`,
        });
      },
    })),
    {
      key: 'threshold', label: 'Threshold', num: true, value: (r) => thresholdOf(r).mean,
      cell: (r) => {
        const t = thresholdOf(r);
        return h('td', { class: 'num', title: `${t.rule || 'threshold'}${t.differ ? `; per seed: ${t.all.map(f3).join(', ')} (mean shown)` : ''}` },
          t.mean === null ? '—' : `${f3(t.mean)}${t.differ ? '…' : ''}`,
          t.rule ? h('span', { class: 'ival' }, t.rule.startsWith('max F1') ? 'max F1 (val)' : t.rule.replace(/^fixed /, 'fixed ')) : null);
      },
    },
    { key: 'seeds', label: 'Seeds', num: true, value: (r) => (r.seeds || []).length, cell: (r) => h('td', { class: 'num', title: `seeds ${(r.seeds || []).join(', ')}` }, fmtNum((r.seeds || []).length)) },
  ];
  const table = sortableTable({
    id: `table3-${safeId(p.name)}`, cls: 'table3 results-table', columns: cols, rows,
    sort: { key: 'auroc', order: 'desc' }, rowAttrs: (r) => ({ 'data-model': r.model }),
    empty: 'No model was evaluated under this protocol.',
  });

  // Paired tests of this protocol.
  const paired = (Array.isArray(res.paired) ? res.paired : []).filter((x) => x.protocol === p.name);
  const pairedBlock = paired.length ? h('div', { class: 'section-gap', id: `paired-${safeId(p.name)}` },
    h('h4', null, 'Paired tests on the same test samples'),
    h('div', { class: 'table-wrap' }, h('table', { class: 'paired-table' },
      h('thead', null, h('tr', null, ['Model', 'vs baseline', 'McNemar b / c', 'McNemar p', 'ΔAUROC (DeLong)', 'DeLong p', 'ΔAUPRC', 'P(model better, AUPRC)'].map((c, k) => h('th', { class: k > 1 ? 'num' : null }, c)))),
      h('tbody', null, paired.map((x) => h('tr', null,
        h('td', { class: 'mono' }, x.model),
        h('td', { class: 'mono' }, x.baseline),
        h('td', { class: 'num' }, `${fmtNum(x.mcnemar_b)} / ${fmtNum(x.mcnemar_c)}`),
        h('td', { class: `num${x.mcnemar_p < 0.05 ? ' signif' : ''}`, title: x.mcnemar_exact ? 'exact binomial test' : 'χ² with continuity correction' }, fmtP(x.mcnemar_p)),
        h('td', { class: 'num' }, fmtSigned(x.delong_auroc_diff, f3)),
        h('td', { class: `num${x.delong_p < 0.05 ? ' signif' : ''}` }, fmtP(x.delong_p)),
        ciCell(finite(x.auprc_diff), Array.isArray(x.auprc_diff_interval) ? finite(x.auprc_diff_interval[0]) : null,
          Array.isArray(x.auprc_diff_interval) ? finite(x.auprc_diff_interval[1]) : null, (v) => fmtSigned(v, f3)),
        h('td', { class: 'num' }, Number.isFinite(x.prob_model_better_auprc) ? f3(x.prob_model_better_auprc) : '—')))))),
    h('p', { class: 'muted small' }, 'Best model against the best baseline; p < 0.05 in bold.')) : null;

  // Plots: the curves large, the rest as thumbnails.
  const main = MAIN_PLOTS.map((k) => plots.find((x) => x.kind === k && !x.model)).filter(Boolean);
  const rest = plots.filter((x) => !main.includes(x));
  const order = ['auroc_forest', 'auprc_forest', 'confusion', 'training'];
  rest.sort((a, b) => {
    const ia = order.indexOf(a.kind) < 0 ? 9 : order.indexOf(a.kind);
    const ib = order.indexOf(b.kind) < 0 ? 9 : order.indexOf(b.kind);
    return ia - ib || a.model.localeCompare(b.model);
  });
  const plotsBlock = plots.length ? h('div', { class: 'section-gap' },
    h('h4', null, `Plots (${plots.length})`),
    main.length ? h('div', { class: 'plot-grid' }, main.map((x) => plotFigure(scope, plotUrl(x), plotCaption(x), true))) : null,
    rest.length ? h('div', { class: 'plot-thumbs' }, rest.map((x) => plotFigure(scope, plotUrl(x), plotCaption(x), false))) : null) : null;

  return h('section', { class: 'card protocol', id: `protocol-${safeId(p.name)}`, 'data-protocol': p.name },
    h('div', { class: 'card-head' },
      h('h2', null, 'Protocol ', h('code', null, p.name), headline ? h('span', { class: 'badge status-succeeded headline-badge' }, 'headline') : null,
        p.leaks_future ? h('span', { class: 'badge status-failed' }, 'inputs leak the future') : null),
      h('span', { class: 'muted small' }, `${rows.length} model${rows.length === 1 ? '' : 's'} · click a column to sort · ${level} % intervals under each value`)),
    desc, table, pairedBlock, plotsBlock);
}

// ============================================================================
// Page 7: Table IV (an rl.evaluate run)
// ============================================================================

const T4_METRICS = [
  { key: 'cells_burned', label: 'Cells burnt', best: 'min', iqm: true },
  { key: 'cells_saved', label: 'Cells saved vs none', best: 'max', title: 'Cells saved against no suppression on the same fire' },
  { key: 'timesteps', label: 'Steps', title: 'Steps until the fire was out or the episode ended' },
  { key: 'helitacks', label: 'Helitacks', title: 'Water drops' },
  { key: 'water_used_gal', label: 'Water (gal)' },
];

/** A number for Table IV: integers above 100, one decimal below. */
function fmt4(v) {
  if (!Number.isFinite(v)) return '—';
  return Math.abs(v) >= 100 ? nf0.format(Math.round(v)) : v.toFixed(1);
}

function pageTableRl(root, params, scope) {
  const asked = params.get('run') || '';
  const page = h('div', { id: 'table4-page', 'data-testid': 'table4-page' }, loading('Loading Table IV…'));
  root.append(h('div', { class: 'page-title' },
    h('h1', null, 'Table IV — helicopter suppression'),
    h('span', { class: 'crumbs' }, h('a', { href: `#/runs?${qs({ kind: 'rl.evaluate' })}` }, 'rl.evaluate runs'))), page);

  api(`/api/tables/rl${asked ? `?${qs({ run: asked })}` : ''}`).then((d) => {
    if (!scope.alive) return;
    const run = d.run || {};
    const ev = d.evaluation || {};
    const runId = run.run_id || asked;
    const agents = Array.isArray(ev.agents) ? ev.agents : [];
    const fires = Array.isArray(ev.fires) ? ev.fires.length : null;
    const output = d.output || { name: 'report' };
    const level = Math.round(((agents[0] && agents[0].cells_burned && agents[0].cells_burned.mean && agents[0].cells_burned.mean.level) || 0.95) * 100);

    const facts = h('dl', { class: 'facts' });
    const fact = (k, ...v) => facts.append(h('dt', null, k), h('dd', null, ...v));
    fact('Run', runLink(runId, true), ' · ', run.pipeline || '—', run.stage ? [' / ', run.stage] : null, ' · ', fmtTimestamp(run.started_at));
    fact('Fires', fires !== null ? `${nf0.format(fires)} held-out fires, the same for every agent` : '—',
      ev.deterministic ? ' (greedy PPO actions)' : '');
    fact('Intervals', `${level} % stratified bootstrap${ev.resamples ? `, ${nf0.format(ev.resamples)} resamples` : ''}; IQM: the interquartile mean over episodes`);
    if (output.path) fact('Files', h('code', null, output.path), ' (', h('a', { href: outputUrl(runId, output.name || 'report', 'evaluation.json'), target: '_blank', rel: 'noopener' }, 'evaluation.json'), ')');
    const head = h('section', { class: 'card', id: 'table4-head' },
      h('div', { class: 'toolbar' },
        runPicker(Array.isArray(d.runs) ? d.runs : [], runId, (id) => { location.hash = `#/tables/rl?${qs({ run: id })}`; }),
        h('a', { class: 'button', href: `#/runs/${enc(runId)}` }, 'Run page')),
      facts);

    // Agents.
    const known = new Set(['agent', 'runs', 'episodes', 'contained_rate', ...T4_METRICS.map((m) => m.key)]);
    const extra = [];
    for (const a of agents) {
      for (const [k, v] of Object.entries(a)) {
        if (known.has(k) || extra.includes(k) || !v || typeof v !== 'object') continue;
        if (v.mean || Number.isFinite(v.estimate)) extra.push(k);
      }
    }
    const metrics = [...T4_METRICS.filter((m) => agents.some((a) => a[m.key])), ...extra.map((k) => ({ key: k, label: k.replace(/_/g, ' ') }))];
    const meanOf = (a, k) => {
      const v = a[k];
      if (!v) return null;
      return v.mean ? v.mean : (Number.isFinite(v.estimate) ? v : null);
    };
    const cols = [
      { key: 'agent', label: 'Agent', value: (a) => a.agent, cell: (a) => h('td', { class: 'nowrap' }, h('b', { class: 'mono' }, a.agent), AGENT_LABELS[a.agent] ? h('div', { class: 'muted small' }, AGENT_LABELS[a.agent]) : null) },
      { key: 'runs', label: 'Runs × fires', num: true, value: (a) => a.episodes, cell: (a) => h('td', { class: 'num', title: `${a.episodes} episodes` }, `${fmtNum(a.runs)} × ${fmtNum(a.runs ? Math.round(a.episodes / a.runs) : fires)}`) },
    ];
    for (const m of metrics) {
      cols.push({
        key: `${m.key}.mean`, label: `${m.label}, mean`, num: true, title: m.title || null, best: m.best || null,
        value: (a) => { const o = meanOf(a, m.key); return o ? finite(o.estimate) : null; },
        cell: (a) => {
          const iqm = a[m.key] && a[m.key].iqm;
          return estCell(meanOf(a, m.key), fmt4, { title: iqm && !m.iqm ? `IQM ${fmt4(iqm.estimate)} ${fmtInterval(iqm.low, iqm.high, fmt4)}` : null });
        },
      });
      if (m.iqm) {
        cols.push({
          key: `${m.key}.iqm`, label: `${m.label}, IQM`, num: true, best: m.best || null,
          value: (a) => (a[m.key] && a[m.key].iqm ? finite(a[m.key].iqm.estimate) : null),
          cell: (a) => estCell(a[m.key] && a[m.key].iqm, fmt4),
        });
      }
    }
    if (agents.some((a) => a.contained_rate)) {
      cols.push({
        key: 'contained', label: 'Contained', num: true, title: 'Share of fires put out before the episode ended', best: 'max',
        value: (a) => (a.contained_rate ? finite(a.contained_rate.estimate) : null),
        cell: (a) => estCell(a.contained_rate, (v) => `${Math.round(v * 100)} %`),
      });
    }
    const agentsCard = h('section', { class: 'card', id: 'table4-agents' },
      h('div', { class: 'card-head' }, h('h2', null, `Agents (${agents.length})`),
        h('span', { class: 'muted small' }, `click a column to sort · ${level} % intervals under each value`)),
      sortableTable({ id: 'table4-table', cls: 'results-table', columns: cols, rows: agents, sort: null, rowAttrs: (a) => ({ 'data-agent': a.agent }), empty: 'This evaluation has no agents.' }));

    // Comparisons.
    const comps = Array.isArray(ev.comparisons) ? ev.comparisons : [];
    const verdict = (c) => {
      const diff = c.cells_burned_diff;
      if (!diff || !Number.isFinite(diff.low) || !Number.isFinite(diff.high)) return null;
      if (diff.high < 0) return h('span', { class: 'badge status-succeeded' }, 'burns less');
      if (diff.low > 0) return h('span', { class: 'badge status-failed' }, 'burns more');
      return h('span', { class: 'badge' }, 'no clear difference');
    };
    const compCard = comps.length ? h('section', { class: 'card', id: 'table4-comparisons' },
      h('h2', null, 'Comparisons on the same fires'),
      h('div', { class: 'table-wrap' }, h('table', { id: 'table4-comparisons-table' },
        h('thead', null, h('tr', null, ['Agent', 'vs baseline', 'Δ cells burnt (agent − baseline)', 'Relative reduction', 'P(agent burns less)', ''].map((c, k) => h('th', { class: k > 1 && k < 5 ? 'num' : null }, c)))),
        h('tbody', null, comps.map((c) => h('tr', { 'data-baseline': c.baseline },
          h('td', { class: 'mono' }, c.agent),
          h('td', { class: 'mono' }, c.baseline),
          estCell(c.cells_burned_diff, (v) => fmtSigned(v, fmt4)),
          estCell(c.relative_reduction, (v) => `${fmtSigned(v * 100, (x) => x.toFixed(1))} %`),
          estCell(c.probability_better, f3),
          h('td', null, verdict(c))))))),
      h('p', { class: 'muted small' }, 'A negative Δ and a positive reduction mean the agent burns less than the baseline; "burns less / more" when the whole interval of Δ is on one side of 0.')) : null;

    // Plots.
    const plots = Array.isArray(d.plots) ? d.plots : [];
    const plotsCard = plots.length ? h('section', { class: 'card', id: 'table4-plots' }, h('h2', null, `Plots (${plots.length})`),
      h('div', { class: 'plot-grid two' }, plots.map((p) => plotFigure(scope, outputUrl(runId, output.name || 'report', p), p.replace(/\.png$/i, '').replace(/_/g, ' '), true)))) : null;

    // Recordings.
    const recs = Array.isArray(d.recordings) ? d.recordings : [];
    const evRecs = Array.isArray(ev.recordings) ? ev.recordings : [];
    const fileUrl = (r) => `/api/runs/${enc(runId)}/artifacts/${enc(r.artifact)}/${enc(r.file)}`;
    const matched = new Set();
    const rows = evRecs.map((e) => {
      const file = String(e.path || '').split('/').pop();
      const art = recs.find((r) => r.file === file);
      if (art) matched.add(art);
      return { e, art, file };
    });
    const others = recs.filter((r) => !matched.has(r));
    const recCard = h('section', { class: 'card', id: 'table4-recordings' },
      h('h2', null, `Recordings (${recs.length})`),
      h('p', { class: 'muted small' }, "Episodes recorded for Rerun: fire state, helicopter path and drops, burning and burnt cells per step. The viewer opens in a new tab (it loads a 40 MB module the first time)."),
      rows.length ? h('div', { class: 'table-wrap' }, h('table', { id: 'table4-recordings-table' },
        h('thead', null, h('tr', null, ['Episode', 'Training seed', 'Fire', 'Cells burnt', 'Steps', 'Helitacks', 'File', ''].map((c, k) => h('th', { class: k >= 1 && k <= 5 ? 'num' : null }, c)))),
        h('tbody', null, rows.map(({ e, art, file }) => h('tr', { 'data-role': e.role },
          h('td', null, h('b', null, e.role || '—')),
          h('td', { class: 'num' }, fmtNum(e.train_seed)),
          h('td', { class: 'num' }, fmtNum(e.fire)),
          h('td', { class: 'num' }, fmtNum(e.cells_burned)),
          h('td', { class: 'num' }, fmtNum(e.timesteps)),
          h('td', { class: 'num' }, fmtNum(e.helitacks)),
          h('td', { class: 'mono small' }, art ? h('a', { href: fileUrl(art), download: file }, file) : file, art ? h('span', { class: 'muted' }, ` ${fmtBytes(art.size)}`) : null),
          h('td', null, art ? rerunLink(fileUrl(art), `the ${e.role} episode`) : h('span', { class: 'muted small' }, 'not stored as an artifact'))))))) : null,
      others.length ? h('div', { class: 'section-gap' }, h('h4', null, 'Other recordings of this run'),
        h('ul', { class: 'plain-list' }, others.map((r) => h('li', null,
          h('span', { class: 'mono' }, `${r.artifact}/${r.file}`), ' ', h('span', { class: 'muted small' }, fmtBytes(r.size)), ' ', rerunLink(fileUrl(r), r.artifact))))) : null,
      recs.length === 0 ? h('p', { class: 'muted' }, 'This run stored no recordings.') : null);

    fill(page, head, agentsCard, compCard, recCard, plotsCard);
  }).catch((e) => {
    if (!scope.alive) return;
    showError(page, e, 'Table IV');
  });
}

// ============================================================================
// Page 8: datasets
// ============================================================================

function pageDatasets(root, params, scope) {
  const page = h('div', { id: 'datasets-page', 'data-testid': 'datasets-page' }, loading('Loading datasets…'));
  root.append(h('div', { class: 'page-title' }, h('h1', null, 'Datasets')), page);
  api('/api/datasets').then((d) => {
    if (!scope.alive) return;
    const list = Array.isArray(d.datasets) ? d.datasets : [];
    fill(page, h('section', { class: 'card' },
      h('p', { class: 'muted' }, 'The datasets of the registry: each version is a hash of its configuration and values, made by a run.'),
      sortableTable({
        id: 'datasets-table', rows: list, sort: { key: 'name', order: 'asc' },
        empty: 'No dataset in the registry yet. Run `cargo xtask demo` or a pipeline with a data.dataset stage.',
        rowAttrs: (x) => ({ 'data-name': x.name }),
        columns: [
          { key: 'name', label: 'Name', value: (x) => x.name, cell: (x) => h('td', null, h('a', { href: `#/datasets/${enc(x.name)}` }, x.name)) },
          { key: 'latest', label: 'Latest version', value: (x) => x.latest, cell: (x) => h('td', { class: 'mono small' }, x.latest || '—') },
          { key: 'rows', label: 'Rows', num: true, value: (x) => x.rows, cell: (x) => h('td', { class: 'num' }, fmtNum(x.rows)) },
          { key: 'versions', label: 'Versions', num: true, value: (x) => x.versions, cell: (x) => h('td', { class: 'num' }, fmtNum(x.versions)) },
          { key: 'card', label: 'Card', value: (x) => (x.card ? 1 : 0), cell: (x) => h('td', null, x.card ? h('span', { class: 'badge status-succeeded' }, 'card') : h('span', { class: 'muted' }, '—')) },
          { key: 'created_at', label: 'Created (UTC)', value: (x) => x.created_at, cell: (x) => h('td', { class: 'mono small nowrap' }, fmtTimestamp(x.created_at)) },
          { key: 'location', label: 'Location', value: (x) => x.location, cell: (x) => h('td', { class: 'mono small wrap' }, x.location || '—') },
        ],
      })));
  }).catch((e) => {
    if (!scope.alive) return;
    showError(page, e, 'The datasets could not be listed');
  });
}

function pageDataset(root, name, scope) {
  name = decodeURIComponent(name);
  const page = h('div', { id: 'dataset-page', 'data-testid': 'dataset-page' }, loading(`Loading dataset ${name}…`));
  root.append(h('div', { class: 'page-title' }, h('h1', null, 'Dataset ', h('span', { class: 'mono' }, name)),
    h('span', { class: 'crumbs' }, h('a', { href: '#/datasets' }, '← all datasets'))), page);
  api(`/api/datasets/${enc(name)}`).then((d) => {
    if (!scope.alive) return;
    const files = Array.isArray(d.files) ? d.files : [];
    const fileUrl = (f) => `/api/datasets/${enc(d.name || name)}/files/${enc(f)}`;
    const versions = Array.isArray(d.versions) ? d.versions : [];
    const current = versions.find((v) => v.on_disk) || versions[0] || {};
    const man = d.manifest && typeof d.manifest === 'object' ? d.manifest : null;
    const hasMap = files.includes('map.png');

    // Head: facts and the map.
    const facts = h('dl', { class: 'facts' });
    const fact = (k, ...v) => facts.append(h('dt', null, k), h('dd', null, ...v));
    fact('On disk', h('span', { class: 'mono' }, d.on_disk || '—'), versions.length > 1 ? h('span', { class: 'muted' }, ` (${versions.length} versions registered)`) : null);
    if (current.run_id) fact('Made by', runLink(current.run_id, true), current.created_at ? h('span', { class: 'muted small' }, ` · ${fmtTimestamp(current.created_at)}`) : null);
    if (Number.isFinite(current.rows)) fact('Rows', nf0.format(current.rows));
    if (man) {
      if (Number.isFinite(man.samples)) fact('Samples', `${nf0.format(man.samples)}${Number.isFinite(man.positives) ? ` (${nf0.format(man.positives)} positive, ${fmtPct(man.positives / Math.max(1, man.samples))})` : ''}`);
      if (man.splits && typeof man.splits === 'object') fact('Splits', Object.entries(man.splits).map(([k, v]) => `${k} ${fmtNum(v)}`).join(' · '), man.test_from ? h('span', { class: 'muted' }, ` (test from ${man.test_from})`) : null);
      if (man.framing && typeof man.framing === 'object') fact('Framing', h('b', null, man.framing.kind || '—'), Array.isArray(man.day_offsets) ? ` · days ${man.day_offsets[0]}…${man.day_offsets[1]} around each sample's date` : null);
      if (Array.isArray(man.features)) fact('Features', `${man.features.length}: `, h('span', { class: 'mono small' }, man.features.join(', ')));
    }
    fact('Location', h('code', null, d.location || '—'));
    if (d.folder) fact('Folder', h('code', null, d.folder));
    if (files.length) fact('Files', files.map((f, k) => [k ? ', ' : '', h('a', { href: fileUrl(f), target: '_blank', rel: 'noopener', class: 'mono small' }, f)]));
    const mapFig = hasMap ? h('figure', { class: 'dataset-map', id: 'dataset-map' },
      h('button', { type: 'button', class: 'plot-open', title: 'Enlarge the map', onclick: () => openLightbox(scope, fileUrl('map.png'), `${name}: where the samples are`) },
        h('img', { src: fileUrl('map.png'), alt: `Map of the samples of ${name}`, id: 'dataset-map-img' })),
      h('figcaption', null, 'Where the samples are',
        Array.isArray(d.map_legend) ? h('div', { class: 'legend', id: 'dataset-map-legend' },
          d.map_legend.map((e) => h('span', null, h('i', { class: 'sw dot', style: { background: String(e.color || '#888') } }), String(e.label || '')))) : null)) : null;
    const head = h('section', { class: 'card', id: 'dataset-head' }, h('div', { class: mapFig ? 'dataset-head-grid' : null }, facts, mapFig));

    // The card.
    const cardSec = h('section', { class: 'card', id: 'dataset-card' }, h('h2', null, 'Card'));
    if (typeof d.card === 'string' && d.card.trim()) {
      cardSec.append(renderMarkdown(d.card, {
        shift: 1,
        image: (src, alt) => {
          const f = String(src).replace(/^\.\//, '');
          if (!files.includes(f)) return null;
          if (f === 'map.png' && mapFig) return h('span', { class: 'muted small' }, `[${alt || 'map'}: shown above]`);
          return h('img', { src: fileUrl(f), alt: alt || f, class: 'md-img' });
        },
        link: (href) => {
          if (/^(https?:|mailto:)/i.test(href)) return href;
          const f = href.replace(/^\.\//, '');
          return files.includes(f) ? fileUrl(f) : null;
        },
      }));
    } else cardSec.append(h('p', { class: 'muted' }, 'This dataset has no card (card.md) in its folder.'));

    // Statistics.
    const stats = d.stats && typeof d.stats === 'object' ? d.stats : null;
    const statsSec = h('section', { class: 'card', id: 'dataset-stats' }, h('h2', null, 'Statistics'));
    if (!stats) statsSec.append(h('p', { class: 'muted' }, 'No stats.json in the dataset folder.'));
    else {
      const feats = Array.isArray(stats.features) ? stats.features : [];
      if (feats.length) {
        const splits = [...new Set(feats.map((f) => f.split).filter(Boolean))];
        const splitSel = h('select', { id: 'stats-split', 'aria-label': 'Split' }, h('option', { value: '' }, 'every split'), splits.map((s) => h('option', { value: s }, s)));
        const holder = h('div');
        const numCol = (key, label) => ({ key, label, num: true, value: (f) => finite(f[key]), cell: (f) => h('td', { class: 'num' }, fmtNum(f[key])) });
        const render = () => {
          const rows = feats.filter((f) => !splitSel.value || f.split === splitSel.value);
          holder.replaceChildren(sortableTable({
            id: 'stats-table', rows, columns: [
              { key: 'split', label: 'Split', value: (f) => f.split, cell: (f) => h('td', null, f.split || '—') },
              { key: 'feature', label: 'Feature', value: (f) => f.feature, cell: (f) => h('td', { class: 'mono' }, f.feature) },
              numCol('rows', 'Rows'), numCol('missing', 'Missing'), numCol('mean', 'Mean'), numCol('std', 'Std'), numCol('min', 'Min'), numCol('max', 'Max'),
            ],
          }));
        };
        splitSel.addEventListener('change', render);
        render();
        statsSec.append(h('h3', null, `Features per split (${feats.length} rows)`), h('div', { class: 'toolbar' }, h('label', { class: 'field' }, h('span', null, 'Split'), splitSel)), holder);
      }
      for (const [k, v] of Object.entries(stats)) {
        if (k === 'features') continue;
        if (Array.isArray(v) && v.length && v.every((x) => x && typeof x === 'object' && !Array.isArray(x))) {
          statsSec.append(h('h3', { class: 'section-gap' }, k === 'tiers' ? 'Samples per split and tier' : k), objectsTable(v, `stats-${safeId(k)}`));
        } else {
          statsSec.append(h('h3', { class: 'section-gap' }, k), h('pre', { class: 'block' }, JSON.stringify(v, null, 2)));
        }
      }
    }

    // Versions.
    const versSec = h('section', { class: 'card', id: 'dataset-versions' }, h('h2', null, `Versions (${versions.length})`),
      h('div', { class: 'table-wrap' }, h('table', { id: 'versions-table' },
        h('thead', null, h('tr', null, ['Version', '', 'Rows', 'Created (UTC)', 'Made by run', 'Metadata'].map((c, k) => h('th', { class: k === 2 ? 'num' : null }, c)))),
        h('tbody', null, versions.map((v) => h('tr', { class: v.on_disk ? 'selected' : null, 'data-version': v.version },
          h('td', { class: 'mono small' }, v.version),
          h('td', null, v.on_disk ? h('span', { class: 'badge status-succeeded', title: 'The files in the folder are this version' }, 'on disk') : h('span', { class: 'badge', title: 'Registered; the folder now holds another version' }, 'not on disk')),
          h('td', { class: 'num' }, fmtNum(v.rows)),
          h('td', { class: 'mono small nowrap' }, fmtTimestamp(v.created_at)),
          h('td', null, v.run_id ? runLink(v.run_id) : '—'),
          h('td', { class: 'small wrap' }, v.metadata && typeof v.metadata === 'object'
            ? Object.entries(v.metadata).map(([k, x]) => h('div', null, h('span', { class: 'muted' }, `${k}: `), h('span', { class: 'mono' }, fmtValue(x))))
            : fmtValue(v.metadata))))))));

    // Schema.
    const schema = d.schema;
    const schemaSec = h('section', { class: 'card', id: 'dataset-schema' }, h('h2', null, 'Schema'));
    if (Array.isArray(schema) && schema.every((x) => typeof x === 'string')) {
      schemaSec.append(h('p', { class: 'muted small' }, `${schema.length} columns`), h('div', { class: 'chips' }, schema.map((c) => h('span', { class: 'chip mono' }, c))));
    } else if (Array.isArray(schema) && schema.every((x) => x && typeof x === 'object')) schemaSec.append(objectsTable(schema, 'schema-table'));
    else if (schema && typeof schema === 'object') {
      schemaSec.append(h('div', { class: 'table-wrap' }, h('table', { class: 'kv' }, h('tbody', null, Object.entries(schema).map(([k, v]) => h('tr', null, h('td', null, k), h('td', null, fmtValue(v))))))));
    } else schemaSec.append(h('p', { class: 'muted' }, schema ? String(schema) : 'No schema recorded.'));

    // Manifest.
    const manSec = h('section', { class: 'card', id: 'dataset-manifest' }, h('h2', null, 'Manifest (dataset.json)'));
    if (!man) manSec.append(h('p', { class: 'muted' }, 'No dataset.json in the dataset folder.'));
    else {
      const scalars = Object.entries(man).filter(([k, v]) => !['files', 'provenance', 'config', 'features'].includes(k) && (v === null || typeof v !== 'object' || (Array.isArray(v) && v.length <= 8 && v.every((x) => typeof x !== 'object'))));
      const small = Object.entries(man).filter(([k, v]) => !['files', 'provenance', 'features'].includes(k) && v && typeof v === 'object' && !scalars.some(([s]) => s === k));
      manSec.append(h('div', { class: 'table-wrap' }, h('table', { class: 'kv', id: 'manifest-table' }, h('tbody', null,
        scalars.map(([k, v]) => h('tr', null, h('td', null, k), h('td', null, fmtValue(v)))),
        small.map(([k, v]) => h('tr', null, h('td', null, k), h('td', null, flatten(v).map(([kk, vv]) => h('div', null, h('span', { class: 'muted' }, `${kk}: `), fmtValue(vv))))))))));
      if (man.files && typeof man.files === 'object') {
        manSec.append(h('h3', { class: 'section-gap' }, `Files and their hashes (${Object.keys(man.files).length})`),
          h('div', { class: 'table-wrap' }, h('table', { class: 'kv' }, h('tbody', null, Object.entries(man.files).map(([f, hash]) => h('tr', null,
            h('td', null, files.includes(f) ? h('a', { href: fileUrl(f), target: '_blank', rel: 'noopener' }, f) : f),
            h('td', { class: 'small', title: String(hash) }, `blake3 ${String(hash).slice(0, 16)}…`)))))));
      }
      if (man.provenance && typeof man.provenance === 'object') {
        const prov = Object.entries(man.provenance);
        manSec.append(h('details', { class: 'section-gap' }, h('summary', null, `Provenance (${prov.length} entries)`),
          h('div', { class: 'table-wrap' }, h('table', { class: 'kv' }, h('tbody', null, prov.map(([k, v]) => h('tr', null, h('td', null, k), h('td', { class: 'small' }, fmtValue(v)))))))));
      }
      manSec.append(h('details', null, h('summary', null, 'The whole dataset.json'), h('pre', { class: 'block' }, JSON.stringify(man, null, 2))));
    }

    const jump = h('nav', { class: 'jump', 'aria-label': 'Sections' }, [
      ['Card', cardSec], ['Statistics', statsSec], ['Versions', versSec], ['Schema', schemaSec], ['Manifest', manSec],
    ].map(([label, sec]) => h('button', { type: 'button', class: 'link-button', onclick: () => sec.scrollIntoView({ behavior: 'smooth', block: 'start' }) }, label)));
    fill(page, head, jump, cardSec, statsSec, versSec, schemaSec, manSec);
  }).catch((e) => {
    if (!scope.alive) return;
    showError(page, e, `Dataset ${name}`);
  });
}

// ============================================================================
// Grouped comparison (compare page): mean and interval per group
// ============================================================================

/**
 * Dot-and-whisker chart: one row per group, its mean as a dot and its interval as a line.
 * items: [{label, mean, low, high, n, color}]
 */
function drawWhiskers(canvas, items, opts = {}) {
  const dpr = window.devicePixelRatio || 1;
  const cssW = Math.max(200, Math.round(canvas.clientWidth || (canvas.parentElement && canvas.parentElement.clientWidth) || 360));
  const rowH = 24;
  const cssH = 30 + rowH * Math.max(1, items.length);
  canvas.style.height = `${cssH}px`;
  canvas.width = Math.round(cssW * dpr);
  canvas.height = Math.round(cssH * dpr);
  const ctx = canvas.getContext('2d');
  ctx.setTransform(dpr, 0, 0, dpr, 0, 0);
  ctx.fillStyle = '#fff';
  ctx.fillRect(0, 0, cssW, cssH);
  ctx.font = FONT;
  let lo = Infinity;
  let hi = -Infinity;
  for (const it of items) {
    for (const v of [it.mean, it.low, it.high]) if (Number.isFinite(v)) { lo = Math.min(lo, v); hi = Math.max(hi, v); }
  }
  const t = niceTicks(lo, hi, Math.max(3, Math.min(6, Math.floor(cssW / 90))));
  const labels = items.map((it) => {
    let s = String(it.label);
    while (ctx.measureText(s).width > cssW * 0.32 && s.length > 4) s = s.slice(0, -2);
    return s === String(it.label) ? s : s + '…';
  });
  const padL = Math.min(cssW * 0.34, Math.max(40, ...labels.map((l) => ctx.measureText(l).width)) + 12);
  const padR = 12;
  const pw = Math.max(20, cssW - padL - padR);
  const X = (v) => padL + ((v - t.lo) / (t.hi - t.lo || 1)) * pw;
  const bottom = 8 + rowH * items.length;
  ctx.strokeStyle = '#e6e8eb';
  ctx.fillStyle = '#4a525b';
  ctx.textAlign = 'center';
  ctx.textBaseline = 'top';
  for (const v of t.ticks) {
    const x = Math.round(X(v)) + 0.5;
    ctx.beginPath(); ctx.moveTo(x, 4); ctx.lineTo(x, bottom); ctx.stroke();
    ctx.fillText(tickLabel(v, t.step), clamp(x, padL + 10, padL + pw - 10), bottom + 5);
  }
  items.forEach((it, k) => {
    const y = 8 + rowH * k + rowH / 2;
    ctx.fillStyle = '#2b3138';
    ctx.textAlign = 'right';
    ctx.textBaseline = 'middle';
    ctx.fillText(labels[k], padL - 8, y);
    const color = it.color || PALETTE[k % PALETTE.length];
    if (Number.isFinite(it.low) && Number.isFinite(it.high)) {
      ctx.strokeStyle = color;
      ctx.lineWidth = 2;
      ctx.beginPath();
      ctx.moveTo(X(it.low), y); ctx.lineTo(X(it.high), y);
      ctx.moveTo(X(it.low), y - 5); ctx.lineTo(X(it.low), y + 5);
      ctx.moveTo(X(it.high), y - 5); ctx.lineTo(X(it.high), y + 5);
      ctx.stroke();
    }
    if (Number.isFinite(it.mean)) {
      ctx.fillStyle = color;
      ctx.beginPath(); ctx.arc(X(it.mean), y, 4.5, 0, Math.PI * 2); ctx.fill();
    }
  });
  if (opts.empty && !Number.isFinite(lo)) {
    ctx.fillStyle = '#6b7480';
    ctx.textAlign = 'center';
    ctx.fillText(opts.empty, padL + pw / 2, cssH / 2);
  }
}

/** A group's value as text (older servers sent strings with their JSON quotes). */
function groupLabel(v) {
  const s = String(v);
  if (s.length >= 2 && s.startsWith('"') && s.endsWith('"')) {
    try { return JSON.parse(s); } catch { return s; }
  }
  return s;
}

/** The group-by section of the compare page. */
function groupSection(scope, ids, differing, initial) {
  const sel = h('select', { id: 'group-by', 'data-testid': 'group-by', 'aria-label': 'Group by parameter' },
    h('option', { value: '' }, '— no grouping —'),
    differing.map((n) => h('option', { value: n }, n)));
  const filter = h('input', { id: 'group-filter', type: 'search', placeholder: 'filter metrics', 'aria-label': 'Filter metrics', style: { width: '14em' } });
  const body = h('div', { id: 'compare-groups' });
  const card = h('section', { class: 'card', id: 'compare-group' },
    h('div', { class: 'card-head' }, h('h3', null, 'Group by a parameter'),
      h('span', { class: 'muted small' }, 'per group: the mean of each run\u2019s last value and its 95 % t interval over the group\u2019s runs (seeds, mostly)')),
    h('div', { class: 'toolbar' }, h('label', { class: 'field' }, h('span', null, 'Group by'), sel), filter),
    body);
  if (differing.length === 0) {
    sel.disabled = true;
    body.append(h('p', { class: 'muted' }, 'No parameter differs between these runs: there is nothing to group by.'));
    return card;
  }
  let seq = 0;
  let grouped = null;
  let canvases = [];
  const redraw = () => { for (const c of canvases) if (c.canvas.isConnected) drawWhiskers(c.canvas, c.items); };
  scope.onResize(redraw);

  const render = () => {
    canvases = [];
    if (!grouped) { body.replaceChildren(); return; }
    const groups = Array.isArray(grouped.groups) ? grouped.groups : [];
    const colors = groups.map((_, k) => PALETTE[k % PALETTE.length]);
    const q = filter.value.trim().toLowerCase();
    const keys = [...new Set(groups.flatMap((g) => Object.keys(g.metrics || {})))].sort().filter((k) => !q || k.toLowerCase().includes(q));
    const fmtG = (m) => (m ? [h('span', { class: 'est' }, fmtNum(m.mean)), h('span', { class: 'ival' }, Number.isFinite(m.low) ? `${fmtInterval(m.low, m.high, fmtNum)} n ${m.n}` : `n ${m.n}`)] : '—');
    const groupHead = (g, k) => h('th', { class: 'num' }, h('span', { class: 'swatch', style: { background: colors[k] } }), h('span', { class: 'mono' }, groupLabel(g.value)), h('div', { class: 'muted small' }, `${g.runs.length} run${g.runs.length === 1 ? '' : 's'}`));
    const grid = h('div', { class: 'charts-grid whiskers' });
    for (const key of keys.slice(0, 24)) {
      const items = groups.map((g, k) => {
        const m = (g.metrics || {})[key];
        return { label: groupLabel(g.value), mean: m ? m.mean : NaN, low: m && Number.isFinite(m.low) ? m.low : NaN, high: m && Number.isFinite(m.high) ? m.high : NaN, color: colors[k] };
      });
      const canvas = h('canvas', { 'aria-label': `Means and intervals of ${key} per group` });
      grid.append(h('div', { class: 'chart-card', 'data-key': key }, h('h4', null, key), canvas));
      canvases.push({ canvas, items });
    }
    fill(body,
      h('div', { class: 'group-runs' }, groups.map((g, k) => h('div', { class: 'group-chip', 'data-value': g.value },
        h('span', { class: 'swatch', style: { background: colors[k] } }),
        h('b', { class: 'mono' }, `${grouped.param} = ${groupLabel(g.value)}`), ': ',
        g.runs.map((id, j) => [j ? ', ' : '', runLink(id)])))),
      keys.length === 0 ? h('p', { class: 'muted' }, q ? 'No metric matches the filter.' : 'These runs logged no metrics.') : h('div', { class: 'table-wrap' }, h('table', { id: 'group-table', class: 'results-table' },
        h('thead', null, h('tr', null, h('th', null, 'metric'), groups.map(groupHead))),
        h('tbody', null, keys.map((key) => h('tr', { 'data-key': key }, h('td', { class: 'mono small' }, key),
          groups.map((g) => h('td', { class: 'num ci' }, fmtG((g.metrics || {})[key])))))))),
      keys.length > 24 ? h('p', { class: 'muted small' }, `Charts for the first 24 of ${keys.length} metrics: filter to see others.`) : null,
      grid);
    requestAnimationFrame(redraw);
  };

  const load = (param) => {
    const my = ++seq;
    const hash = `#/compare?${qs({ ids: ids.join(','), group: param })}`;
    replaceHash(hash.replace(/%2C/gi, ','));
    if (!param) { grouped = null; render(); return; }
    body.replaceChildren(loading(`Grouping by ${param}…`));
    api(`/api/compare?${qs({ ids: ids.join(','), group: param })}`).then((d) => {
      if (!scope.alive || my !== seq) return;
      grouped = d.grouped || { param, groups: [] };
      render();
    }).catch((e) => {
      if (!scope.alive || my !== seq) return;
      showError(body, e, `Grouping by ${param}`);
    });
  };
  sel.addEventListener('change', () => load(sel.value));
  let debounce = null;
  filter.addEventListener('input', () => { clearTimeout(debounce); debounce = setTimeout(render, 200); });
  scope.add(() => clearTimeout(debounce));
  if (initial && differing.includes(initial)) { sel.value = initial; load(initial); }
  return card;
}

// ============================================================================
// Start
// ============================================================================

function footer() {
  const v = document.getElementById('version');
  if (!v) return;
  api('/api/health').then((hh) => {
    v.textContent = hh.version ? `FireCast ${hh.version}` : '';
  }).catch((e) => {
    v.replaceChildren(errorBox(e, 'Server health'));
  });
}

function start() {
  window.addEventListener('hashchange', route);
  if (!location.hash) history.replaceState(null, '', '#/');
  route();
  footer();
}

if (document.readyState === 'loading') document.addEventListener('DOMContentLoaded', start);
else start();

})();
