// A run's page (/runs/<id>/view): parameters, the field (a point's time series, yz snapshots over time), exports,
// the virtual lidar and the validation, each made by the server on first request and cached there.
'use strict';
const RID = location.pathname.split('/')[2];
const BASE = '/runs/' + RID;
let RUN = null, playing = null;

function showParameters(run) {
  const g = run.grid, p = Object.assign({}, run.parameters, {preset: run.preset});
  const rows = Object.entries(p).filter(([, v]) => v !== null && v !== undefined)
    .map(([k, v]) => `<tr><th>${text(k)}</th><td>${text(Array.isArray(v) ? v.join(', ') : v)}</td></tr>`);
  rows.push(`<tr><th>grid</th><td>nt ${g.nt}, dt ${g.dt_s} s, ny ${g.ny}, nz ${g.nz}, dy ${g.dy_m} m, dz ${g.dz_m} m, ` +
    `planes x = ${g.x_m.join(', ')} m</td></tr>`);
  if (run.summary) rows.push(`<tr><th>&sigma; u, v, w</th><td>${['u', 'v', 'w'].map(c => (+run.summary['sigma_' + c]).toFixed(3)).join(', ')} m/s</td></tr>`);
  if (run.summary && run.summary.conditioning)  // the command's lines about the fit and the data (notes among them)
    rows.push(`<tr><th>conditioning</th><td>${run.summary.conditioning.map(text).join('<br>')}</td></tr>`);
  $('#parameters').innerHTML = rows.join('');
}

async function showSeries() {
  const q = String(new URLSearchParams({plane: $('#plane').value, y: $('#y').value, z: $('#z').value}));
  const box = $('#series');
  box.dataset.want = q;
  let s;
  try { s = await getJSON(BASE + '/series?' + q); } catch (e) { $('#series-message').textContent = e.message; return; }
  if (box.dataset.want !== q) return;  // a later point was asked for meanwhile
  $('#series-message').textContent = '';
  const t = s.u.map((_, i) => i * s.dt_s);
  $('#point').textContent = `x = ${s.x_m} m, y = ${s.y_m} m, z = ${s.z_m} m`;
  $('#series').innerHTML = linePlot([{name: 'u', x: t, y: s.u, color: '#c33'}, {name: 'v', x: t, y: s.v, color: '#36c'},
    {name: 'w', x: t, y: s.w, color: '#393'}], 't [s]', 'velocity fluctuation [m/s]');
  $('#series').dataset.point = `${s.plane},${s.y},${s.z}`;
}

async function showSnapshot() {
  const t = +$('#t').value;
  $('#t-label').textContent = `t = ${(t * RUN.grid.dt_s).toFixed(3)} s (index ${t})`;
  const q = new URLSearchParams({plane: $('#plane').value, t: t, component: $('#component').value});
  return loadImage($('#snapshot'), BASE + '/snapshot?' + q, $('#snapshot-message'));
}

// a click on the image picks the nearest grid point (the axes span the image's inner ~70 %: approximate)
function pickPoint(ev) {
  const img = ev.target, r = img.getBoundingClientRect();
  const fx = (ev.clientX - r.left) / r.width, fz = (ev.clientY - r.top) / r.height;
  const clamp = (v, n) => Math.max(0, Math.min(n - 1, Math.round(v)));
  $('#y').value = clamp((fx - 0.15) / 0.62 * (RUN.grid.ny - 1), RUN.grid.ny);
  $('#z').value = clamp((0.88 - fz) / 0.76 * (RUN.grid.nz - 1), RUN.grid.nz);
  showSeries();
}

async function play() {
  if (playing) { playing = null; $('#play').textContent = 'play'; return; }
  const token = playing = {};
  $('#play').textContent = 'stop';
  const n = RUN.grid.nt, stride = Math.max(1, Math.round(n / 100));
  while (playing === token) {
    $('#t').value = (+$('#t').value + stride) % n;
    if (await showSnapshot() === false) break;
    await new Promise(ok => setTimeout(ok, 150));
  }
}

async function makeExport(fmt) {
  const runner = $('#runner-files').checked && fmt !== 'evo';
  const url = `${BASE}/export?format=${fmt}` + (runner ? '&runner_files=true' : '');
  $('#export-message').textContent = 'making ' + fmt + ' ...';
  const r = await fetch(url, {headers: authHeaders()});
  if (!r.ok) { $('#export-message').textContent = (await r.json()).detail; return; }
  if (r.body) r.body.cancel();  // made and cached: the link below downloads it (no token needed once cached)
  const name = (/filename="?([^";]+)"?/.exec(r.headers.get('content-disposition') || '') || [])[1] || fmt;
  $('#export-message').textContent = '';
  $('#exports').innerHTML += `<li><a class="export" data-format="${fmt}" href="${text(url)}" download="${text(name)}">${text(name)}</a>` +
    ` <span class="hint">${bytes(+r.headers.get('content-length'))}</span></li>`;
}

async function runLidar() {
  $('#lidar-message').textContent = 'measuring ...';
  try { showLidar(await getJSON(`${BASE}/lidar?lidar=${encodeURIComponent($('#lidar').value)}`)); } catch (e) { $('#lidar-message').textContent = e.message; }
}

// a lidar file of the user's: its content is the body of POST /runs/<id>/lidar (the server reads no client path)
async function runLidarFile(input) {
  const file = input.files[0];
  if (!file) return;
  $('#lidar-message').textContent = 'measuring with ' + file.name + ' ...';
  const r = await fetch(BASE + '/lidar', {method: 'POST', headers: authHeaders({'Content-Type': 'application/json'}), body: await file.text()});
  const out = await r.json().catch(() => ({detail: r.status + ' ' + r.statusText}));
  input.value = '';
  if (!r.ok) { $('#lidar-message').textContent = out.detail; return; }
  showLidar(out);
}

function showLidar(d) {
  $('#lidar-message').textContent = '';
  const r = d.report, s = r.simulated, t = r.theory, v = r.verdict, num = (x) => x == null ? '-' : (+x).toFixed(4);
  $('#lidar-report').innerHTML = `<p class="lidar-name">${text(d.lidar)}</p><p class="${v.passed ? 'passed' : 'failed'}">coherence &gamma;&sup2;<sub>RL</sub>: ` +
    `${v.passed ? 'passed' : 'failed'} (max |z| ${num(v.max_abs_z)}, z_crit ${num(v.z_crit)}, ${v.n_tests} bins)</p>` +
    `<table><tr><th></th><th>simulated</th><th>theory</th></tr><tr><th>k<sub>0.5</sub> [rad/m]</th><td>${num(s.k05_rad_m)}</td><td>${num(t.k05_rad_m)}</td></tr>` +
    `<tr><th>cut-off [Hz]</th><td>${num(s.cutoff_hz)}</td><td>${num(t.cutoff_hz)}</td></tr>` +
    `<tr><th>TI lidar (uncorrected), rotor</th><td colspan="2">${num(r.ti_lidar_uncorrected)}, ${num(r.ti_rotor)}</td></tr></table>` +
    linePlot([{name: 'simulated', x: r.f_simulated, y: r.coh2_RL_simulated, color: '#c33'},
      {name: 'theory', x: r.f_theory, y: r.coh2_RL_theory, color: '#222'}], 'f [Hz]', 'coherence γ²_RL [-]', {ymin: 0, ymax: 1});
}

async function validate() {
  $('#validation-message').textContent = 'validating ...';
  let v;
  try { v = await getJSON(BASE + '/validation'); } catch (e) { $('#validation-message').textContent = e.message; return; }
  $('#validation-message').textContent = '';
  $('#validation-status').innerHTML = `<span class="${v.report.passed ? 'passed' : 'failed'}">${v.report.passed ? 'passed' : 'failed'}</span>`;
  $('#validation').innerHTML = v.plots.map(u => `<img class="plot" alt="validation plot" src="${u}">`).join('');
}

function setUp(run, form) {
  const g = run.grid;
  $('#plane').innerHTML = g.x_m.map((x, i) => `<option value="${i}">${i}: x = ${x} m</option>`).join('');
  $('#y').max = g.ny - 1; $('#z').max = g.nz - 1;
  $('#y').value = Math.floor(g.ny / 2); $('#z').value = Math.floor(g.nz / 2);
  $('#t').max = g.nt - 1;
  $('#export-buttons').innerHTML = form.export_formats.map(f => `<button class="make-export" data-format="${f}">${f}</button>`).join(' ');
  $$('.make-export').forEach(b => b.onclick = () => makeExport(b.dataset.format));
  $('#lidar').innerHTML = form.lidar_presets.map(p => `<option>${text(p)}</option>`).join('');
  $('#validation-status').textContent = run.validation ? (run.validation.passed ? 'passed' : 'failed') : 'not validated yet';
  $('#show-series').onclick = showSeries;
  $('#plane').onchange = () => { showSeries(); showSnapshot(); };
  $('#component').onchange = showSnapshot;
  $('#t').oninput = showSnapshot;
  $('#play').onclick = play;
  $('#snapshot').onclick = pickPoint;
  $('#run-lidar').onclick = runLidar;
  $('#lidar-file').onchange = () => runLidarFile($('#lidar-file'));
  $('#validate').onclick = validate;
  $('#complete').hidden = false;
  showSeries();
  showSnapshot();
}

async function start() {
  $('#rid').textContent = RID;
  $('#store-url').textContent = `xr.open_zarr("${location.origin}${BASE}/store")`;
  const form = JSON.parse($('#form-data').textContent);  // /form.json, in the page
  $('#token-row').hidden = !form.token_required;
  while (true) {
    try { RUN = await getJSON(BASE); } catch (e) { $('#run-message').textContent = e.message; return; }
    const pr = RUN.progress;
    $('#status').textContent = RUN.status + (pr && RUN.status !== 'complete' ? ` (${pr.chunks_done}/${pr.chunks_total} chunks)` : '');
    showParameters(RUN);
    if (RUN.status === 'complete') return setUp(RUN, form);
    if (RUN.status === 'failed' || RUN.status === 'interrupted') { $('#run-message').textContent = RUN.error || RUN.status; return; }
    await new Promise(ok => setTimeout(ok, 1000));
  }
}
start();
