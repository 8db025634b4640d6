// Shared by the pages of `turbgen serve`: escaping, the token, requests, inline errors, line plots (SVG).
'use strict';
const $ = (s, root) => (root || document).querySelector(s);
const $$ = (s, root) => Array.from((root || document).querySelectorAll(s));

function text(s) {
  const d = document.createElement('div');
  d.textContent = s == null ? '' : String(s);
  return d.innerHTML;
}

// the bearer token, if the server needs one: typed into the page, kept in the page only (never stored)
function authHeaders(extra) {
  const t = $('#token');
  return Object.assign({}, extra || {}, t && t.value ? {'Authorization': 'Bearer ' + t.value} : {});
}

async function getJSON(url) {
  const r = await fetch(url, {headers: authHeaders()});
  const body = await r.json().catch(() => ({detail: r.status + ' ' + r.statusText}));
  if (!r.ok) throw new Error(body.detail || String(r.status));
  return body;
}

// an image made by the server (a header carries the token): shown in <img>, or the server's message in `err`;
// true once shown, false for an error, null when a later request for the same <img> replaced this one
async function loadImage(img, url, err) {
  img.dataset.want = url;
  const r = await fetch(url, {headers: authHeaders()});
  if (img.dataset.want !== url) return null;
  if (!r.ok) {
    const body = await r.json().catch(() => ({detail: String(r.status)}));
    err.textContent = body.detail;
    return false;
  }
  const blob = await r.blob();
  if (img.dataset.want !== url) return null;
  err.textContent = '';
  const old = img.src;
  const shown = new Promise((ok) => { img.onload = () => ok(true); img.onerror = () => ok(false); });
  img.src = URL.createObjectURL(blob);
  img.dataset.url = url;
  if (old.startsWith('blob:')) URL.revokeObjectURL(old);
  return shown;
}

function bytes(n) {
  if (n == null) return '';
  const units = ['B', 'KiB', 'MiB', 'GiB', 'TiB'];
  let i = 0;
  while (n >= 1024 && i < units.length - 1) { n /= 1024; i++; }
  return (i ? n.toFixed(1) : n) + ' ' + units[i];
}

// curves [{name, x: [...], y: [...], color}] as an SVG line plot with axes labels and a legend
function linePlot(curves, xlabel, ylabel, opts) {
  const W = 640, H = 250, L = 56, R = 10, T = 22, B = 36, o = opts || {};
  const xs = curves.flatMap(c => c.x), ys = curves.flatMap(c => c.y).filter(Number.isFinite);
  let [x0, x1] = [Math.min(...xs), Math.max(...xs)], [y0, y1] = [Math.min(...ys), Math.max(...ys)];
  if (o.ymin != null) y0 = o.ymin;
  if (o.ymax != null) y1 = o.ymax;
  if (x1 === x0) x1 = x0 + 1;
  if (y1 === y0) y1 = y0 + 1;
  const px = (x) => L + (x - x0) / (x1 - x0) * (W - L - R), py = (y) => T + (y1 - y) / (y1 - y0) * (H - T - B);
  const step = (c) => Math.max(1, Math.floor(c.x.length / 2000));  // at most ~2000 vertices per curve
  const lines = curves.map(c => {
    const pts = [];
    for (let i = 0; i < c.x.length; i += step(c)) if (Number.isFinite(c.y[i])) pts.push(px(c.x[i]).toFixed(1) + ',' + py(c.y[i]).toFixed(1));
    return `<polyline class="curve" data-name="${text(c.name)}" fill="none" stroke="${c.color}" stroke-width="1.2" points="${pts.join(' ')}"/>`;
  }).join('');
  const fmt = (v) => Math.abs(v) >= 1000 || (Math.abs(v) < 0.01 && v !== 0) ? v.toExponential(1) : +v.toPrecision(3);
  const ticks = [0, 0.5, 1].map(f => {
    const xv = x0 + f * (x1 - x0), yv = y0 + f * (y1 - y0);
    return `<text x="${px(xv)}" y="${H - B + 14}" text-anchor="middle">${fmt(xv)}</text>` +
      `<text x="${L - 4}" y="${py(yv) + 4}" text-anchor="end">${fmt(yv)}</text>`;
  }).join('');
  const legend = curves.map((c, i) => `<text x="${L + 8 + 90 * i}" y="${T - 8}" fill="${c.color}">&#9473; ${text(c.name)}</text>`).join('');
  return `<svg class="plot" viewBox="0 0 ${W} ${H}" width="${W}" height="${H}" font-size="11">` +
    `<rect x="${L}" y="${T}" width="${W - L - R}" height="${H - T - B}" fill="none" stroke="#999"/>` +
    `${lines}${ticks}${legend}<text x="${(W + L) / 2}" y="${H - 4}" text-anchor="middle">${text(xlabel)}</text>` +
    `<text transform="translate(12 ${(H - B) / 2}) rotate(-90)" text-anchor="middle">${text(ylabel)}</text></svg>`;
}
