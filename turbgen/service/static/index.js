// The catalog page: the run form built from /form.json (the run schemas), its command and Python call, the catalog.
'use strict';
let FORM = null;
let pendingDelete = null;  // id whose delete button was clicked once (a second click deletes)
// the first run of the form: small enough to finish in seconds (the defaults make 4096 x 11 x 64 x 64)
const STARTER = {U: '10', seed: '1', nt: '256', ny: '8', nz: '8', planes: '0,50'};

function fieldHtml(f) {
  const unit = f.unit && f.unit !== '-' ? f.unit : '';  // after the interval: "[1, 1000] m, increasing"
  const hint = /^[\[(][^\]]*\]/.test(f.range) ? f.range.replace(/^([\[(][^\]]*\])/, '$1 ' + unit) : [f.range, unit && '(' + unit + ')'].filter(Boolean).join(' ');
  const ph = text(f.default);
  let input;
  if (f.kind === 'choice') {
    input = `<select name="${f.name}"><option value="">${f.default ? 'default (' + ph + ')' : '(none)'}</option>` +
      f.choices.map(c => `<option>${text(c)}</option>`).join('') + '</select>';
  } else if (f.kind === 'flag') {
    input = `<input type="checkbox" name="${f.name}" value="true">`;
  } else if (f.kind === 'upload') {
    input = `<input type="file" name="${f.name}" accept=".json,.csv"><span class="uploads"></span>`;
  } else {
    input = `<input type="text" name="${f.name}" placeholder="${ph}" value="${text(STARTER[f.name] || '')}">`;
  }
  return `<div class="field" data-name="${f.name}"><label title="${text(f.help)}">${f.name}</label>${input} ` +
    `<span class="hint">${text(hint)}</span><span class="field-err"></span></div>`;
}

function renderForm() {
  const model = $('#model').value;
  const fields = FORM.models[model];
  $('#groups').innerHTML = FORM.groups.map(g => {
    const fs = fields.filter(f => f.group === g);
    return fs.length ? `<fieldset><legend>${text(g)}</legend>${fs.map(fieldHtml).join('')}</fieldset>` : '';
  }).join('') + (model === 'kaimal' ? '<p class="hint">constraints: the service conditions Mann runs only</p>' : '');
  $$('#groups input, #groups select').forEach(e => { e.oninput = schedulePreview; e.onchange = schedulePreview; });
  $$('#groups input[type=file]').forEach(e => { e.onchange = () => upload(e); });
  preview();
}

// the form's values as the server's GET /form/request takes them (field name -> text; uploads by id)
function formQuery() {
  const q = new URLSearchParams({model: $('#model').value});
  $$('#groups .field').forEach(div => {
    const name = div.dataset.name, e = $('[name]', div);
    let v = e.type === 'checkbox' ? (e.checked ? 'true' : '') : e.type === 'file' ? (div.dataset.ids || '') : e.value;
    if (v.trim()) q.set(name, v.trim());
  });
  return q;
}

function showFieldError(detail) {
  $$('#groups .field').forEach(d => { d.classList.remove('bad'); $('.field-err', d).textContent = ''; });
  if (!detail) return;
  const div = fieldOf(detail);
  if (div) { div.classList.add('bad'); $('.field-err', div).textContent = detail; }
}

// the field a server message names: its form name, option, run key or range label, earliest in the message
function fieldOf(detail) {
  let best = null, at = Infinity;
  for (const f of FORM.models[$('#model').value]) {
    const key = f.key.replace(/^grid\./, '');
    for (const m of [f.name, f.flag, key, 'grid.' + key, f.label]) {
      if (!m) continue;  // a whole word: "nt" is not the "nt" of "points"
      const found = new RegExp('(^|[^\\w.-])' + m.replace(/[.*+?^${}()|[\]\\]/g, '\\$&') + '(?![\\w])').exec(detail);
      if (found && found.index < at) { at = found.index; best = f.name; }
    }
  }
  return best && $(`#groups .field[data-name="${best}"]`);
}

let timer = null;
function schedulePreview() { clearTimeout(timer); timer = setTimeout(preview, 250); }

let asked = 0;  // previews answered out of order: only the latest is shown
async function preview() {
  const n = ++asked;
  const r = await fetch('/form/request?' + formQuery());
  const out = await r.json();
  if (n !== asked) return r.ok ? out : null;
  if (!r.ok) { showFieldError(out.detail); return null; }
  showFieldError(null);
  $('#command').textContent = out.command;
  $('#python').textContent = out.python;
  return out;
}

async function upload(input) {
  const div = input.closest('.field'), file = input.files[0];
  if (!file) return;
  const type = file.name.toLowerCase().endsWith('.csv') ? 'text/csv' : 'application/json';
  const r = await fetch('/constraints', {method: 'POST', headers: authHeaders({'Content-Type': type}), body: await file.text()});
  const out = await r.json();
  if (!r.ok) { showFieldError('constrain: ' + out.detail); return; }
  const ids = (div.dataset.ids ? div.dataset.ids.split(',') : []).concat([out.id]);
  div.dataset.ids = ids.join(',');
  $('.uploads', div).textContent = ' uploaded: ' + ids.join(', ');
  input.value = '';
  preview();
}

async function submitRun(ev) {
  ev.preventDefault();
  const req = await preview();
  if (!req) { $('#message').innerHTML = '<span class="err">see the field marked above</span>'; return; }
  const body = Object.assign({}, req.body);
  const r = await fetch('/runs', {method: 'POST', headers: authHeaders({'Content-Type': 'application/json'}), body: JSON.stringify(body)});
  const out = await r.json();
  if (r.ok) { $('#message').textContent = 'submitted ' + out.id; showFieldError(null); }
  else { $('#message').innerHTML = '<span class="err">' + text(out.detail) + '</span>'; showFieldError(out.detail); }
  refresh();
}

function params(run) {
  const p = run.parameters || {};
  if (run.model === 'mann' && p.fit && p.length_scale_m == null) return 'fitted to the data (replay)';
  if (run.model === 'mann') {
    const evo = p.evo_time_s == null ? 'frozen' : p.evo_time_s + ' s';
    return `L ${p.length_scale_m} m, &Gamma; ${p.gamma}, evo ${evo}, ${p.lifetime || ''}`;
  }
  return `class ${text(p.turb_class || '-')}, &sigma; ${text((p.sigma_m_s || []).map(s => +s.toPrecision(3)).join('/'))} m/s, ${text(p.long_model || '')}`;
}

function row(run) {
  const g = run.grid || {}, pr = run.progress;
  const pct = pr ? Math.round(100 * pr.chunks_done / Math.max(1, pr.chunks_total)) : 0;
  const store = location.origin + '/runs/' + run.id + '/store';
  const actions = (run.status === 'complete' ? `<button class="show-plots" data-id="${run.id}">plots</button> ` : text(run.error) + ' ') +
    (run.status === 'queued' || run.status === 'running' ? '' :
      `<button class="delete" data-id="${run.id}">${pendingDelete === run.id ? 'really delete?' : 'delete'}</button>`);
  return `<tr id="run-${run.id}"><td><a class="view" href="/runs/${run.id}/view">${run.id}</a></td><td>${text(run.model)}</td>` +
    `<td>${text(run.preset || '')}</td><td>${text(run.U_m_s)}</td><td>${text(run.seed)}</td><td>${params(run)}</td>` +
    `<td>${g.nt} &times; ${(g.x_m || []).length} &times; ${g.ny} &times; ${g.nz}, dt ${g.dt_s} s</td>` +
    `<td class="status">${text(run.status)}</td><td><progress max="100" value="${pct}"></progress> ${pct} %</td>` +
    `<td>${bytes(run.size_bytes)}</td><td>${run.status === 'complete' ? `<code class="store-url">${text(store)}</code>` : ''}</td>` +
    `<td>${actions}</td></tr>`;
}

async function refresh() {
  const q = new URLSearchParams();
  for (const k of ['model', 'preset', 'U', 'seed']) { const v = $('#f-' + k).value; if (v) q.set(k, v); }
  let data;
  try { data = await getJSON('/runs?' + q); } catch (e) { $('#catalog-message').textContent = e.message; return; }
  $('#catalog-message').textContent = '';
  $('#catalog tbody').innerHTML = data.runs.map(row).join('');
  $$('.show-plots').forEach(b => b.onclick = () => showPlots(b.dataset.id));
  $$('button.delete').forEach(b => b.onclick = () => deleteRun(b.dataset.id));
}

async function deleteRun(id) {
  if (pendingDelete !== id) { pendingDelete = id; refresh(); return; }
  pendingDelete = null;
  const r = await fetch('/runs/' + id, {method: 'DELETE', headers: authHeaders()});
  const out = await r.json();
  $('#catalog-message').textContent = r.ok ? 'deleted ' + id : out.detail;
  refresh();
}

async function showPlots(id) {
  $('#plots').innerHTML = 'validating ' + id + ' ...';
  let v;
  try { v = await getJSON('/runs/' + id + '/validation'); } catch (e) { $('#plots').innerHTML = '<p class="err">' + text(e.message) + '</p>'; return; }
  $('#plots').innerHTML = '<h2>Validation of ' + id + ': ' + (v.report.passed ? 'passed' : 'failed') + '</h2>' +
    v.plots.map(u => '<img class="plot" alt="validation plot" src="' + u + '">').join('');
}

function start() {
  FORM = JSON.parse($('#form-data').textContent);  // /form.json, in the page: the form exists once it has loaded
  $('#version').textContent = FORM.turbgen;
  $('#token-row').hidden = !FORM.token_required;
  const models = Object.keys(FORM.models).map(m => `<option>${text(m)}</option>`).join('');  // the registry's
  $('#model').innerHTML = models;
  $('#f-model').innerHTML += models;
  $('#f-preset').innerHTML += FORM.models.mann.find(f => f.name === 'preset').choices.map(c => `<option>${text(c)}</option>`).join('');
  $('#model').onchange = renderForm;
  $('#submit').onsubmit = submitRun;
  $$('.filters select, .filters input').forEach(e => e.oninput = refresh);
  renderForm();
  refresh();
  setInterval(refresh, 1000);
}
start();
