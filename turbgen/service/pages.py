"""The web page at / : the catalog with status and progress, a submit form, validation plots.

Server-rendered HTML with a little JavaScript (fetch + polling); no front-end build step.
"""

from __future__ import annotations

import html

from turbgen.version import __version__
from turbgen.spec.presets import BUILTIN_PRESETS

_PAGE = """<!doctype html>
<html lang="en"><head><meta charset="utf-8"><title>turbgen serve</title>
<style>
body {{ font-family: sans-serif; margin: 1.5em; max-width: 70em; }}
table {{ border-collapse: collapse; }} td, th {{ border: 1px solid #ccc; padding: 0.2em 0.6em; }}
label {{ margin-right: 1em; }} img {{ max-width: 30em; margin: 0.3em; }} .err {{ color: #b00; }}
</style></head>
<body>
<h1>turbgen serve <small>{version}</small></h1>
<form id="submit">
 <label>model <select name="model"><option>mann</option><option>kaimal</option></select></label>
 <label>preset <select name="preset"><option value="">(none)</option>{presets}</select></label>
 <label>U [m/s] <input name="U_m_s" type="number" step="any" value="10" size="5"></label>
 <label>seed <input name="seed" type="number" value="1" min="0" size="5"></label>
 <label>nt <input name="nt" type="number" value="256" size="5"></label>
 <label>ny <input name="ny" type="number" value="8" size="3"></label>
 <label>nz <input name="nz" type="number" value="8" size="3"></label>
 <label>planes x [m] <input name="x_m" value="0,50" size="10"></label>
 {token}<button type="submit" id="submit-button">Submit</button> <span id="message"></span>
</form>
<h2>Catalog</h2>
<table id="catalog"><thead><tr><th>id</th><th>model</th><th>U</th><th>seed</th><th>status</th><th>progress</th>
<th></th></tr></thead><tbody></tbody></table>
<div id="plots"></div>
<p><a href="/docs">API documentation (OpenAPI)</a></p>
<script>
const $ = (s) => document.querySelector(s);
function text(s) {{ const d = document.createElement('div'); d.textContent = s == null ? '' : String(s); return d.innerHTML; }}
async function refresh() {{
  const r = await fetch('/runs'); const data = await r.json();
  $('#catalog tbody').innerHTML = data.runs.map(run => {{
    const p = run.progress ? Math.round(100 * run.progress.chunks_done / Math.max(1, run.progress.chunks_total)) + ' %' : '';
    const btn = run.status === 'complete' ? `<button class="show-plots" data-id="${{run.id}}">plots</button>` : text(run.error);
    return `<tr id="run-${{run.id}}"><td>${{run.id}}</td><td>${{text(run.model)}}</td><td>${{text(run.U_m_s)}}</td>
      <td>${{text(run.seed)}}</td><td class="status">${{text(run.status)}}</td><td>${{p}}</td><td>${{btn}}</td></tr>`;
  }}).join('');
  document.querySelectorAll('.show-plots').forEach(b => b.onclick = () => showPlots(b.dataset.id));
}}
async function showPlots(id) {{
  $('#plots').innerHTML = 'validating ' + id + ' ...';
  const t = document.querySelector('input[name=token]');  // computing a validation needs the token, if any
  const r = await fetch('/runs/' + id + '/validation', {{headers: t && t.value ? {{'Authorization': 'Bearer ' + t.value}} : {{}}}});
  const v = await r.json();
  if (!r.ok) {{ $('#plots').innerHTML = '<p class="err">' + text(v.detail) + '</p>'; return; }}
  $('#plots').innerHTML = '<h2>Validation of ' + id + ': ' + (v.report.passed ? 'passed' : 'failed') + '</h2>' +
    v.plots.map(u => '<img class="plot" alt="validation plot" src="' + u + '">').join('');
}}
$('#submit').onsubmit = async (ev) => {{
  ev.preventDefault();
  const f = new FormData(ev.target);
  const body = {{model: f.get('model'), U_m_s: Number(f.get('U_m_s')), seed: Number(f.get('seed')),
    grid: {{nt: Number(f.get('nt')), ny: Number(f.get('ny')), nz: Number(f.get('nz')),
            x_m: f.get('x_m').split(',').map(Number)}}}};
  if (f.get('preset')) body.preset = f.get('preset');
  const headers = {{'Content-Type': 'application/json'}};
  if (f.get('token')) headers['Authorization'] = 'Bearer ' + f.get('token');
  const r = await fetch('/runs', {{method: 'POST', headers, body: JSON.stringify(body)}});
  const out = await r.json();
  $('#message').innerHTML = r.ok ? 'submitted ' + text(out.id) : '<span class="err">' + text(out.detail) + '</span>';
  refresh();
}};
refresh(); setInterval(refresh, 1000);
</script>
</body></html>
"""


def index_html(token_required: bool) -> str:
    """The page; with a token configured the form asks for it (kept in the page only, never stored).

    Parameters
    ----------
    token_required : bool
        Whether the server needs a bearer token.

    Returns
    -------
    str
        The HTML page (built-in presets listed, turbgen version shown).
    """
    presets = "".join(f"<option>{html.escape(name)}</option>" for name in sorted(BUILTIN_PRESETS))
    token = '<label>token <input name="token" type="password" size="12"></label>' if token_required else ""
    return _PAGE.format(version=html.escape(__version__), presets=presets, token=token)


_DOCS = """<!doctype html>
<html lang="en"><head><meta charset="utf-8"><title>turbgen serve: API</title>
<style>
body {{ font-family: sans-serif; margin: 1.5em; max-width: 70em; }} code {{ background: #f4f4f4; }}
h2 {{ font-size: 1.1em; margin-top: 1.5em; }} td, th {{ border: 1px solid #ccc; padding: 0.2em 0.6em; }}
table {{ border-collapse: collapse; }}
</style></head>
<body>
<h1>turbgen serve {version}: HTTP API</h1>
<p>{description} The machine-readable description is <a href="/openapi.json">/openapi.json</a> (OpenAPI 3); the
web page is <a href="/">/</a>.</p>
{operations}
</body></html>
"""


def api_docs_html(openapi: dict) -> str:
    """The API reference at /docs, rendered on the server from the OpenAPI description (no script, nothing loaded
    from another host: FastAPI's own /docs loads Swagger UI from a CDN and shows nothing offline).

    Parameters
    ----------
    openapi : dict
        The application's OpenAPI description (``app.openapi()``).

    Returns
    -------
    str
        The HTML page: per operation its method, path, description and parameters.
    """
    esc = html.escape
    parts = []
    for path, item in openapi.get("paths", {}).items():
        for method, op in item.items():
            params = "".join(
                f"<tr><td><code>{esc(p['name'])}</code></td><td>{esc(p.get('in', ''))}</td>"
                f"<td>{esc(str(p.get('schema', {}).get('type', p.get('schema', {}).get('anyOf', ''))))}</td>"
                f"<td>{'required' if p.get('required') else ''}</td></tr>"
                for p in op.get("parameters", ())
            )
            head = "<tr><th>parameter</th><th>in</th><th>type</th><th></th></tr>"
            table = f"<table>{head}{params}</table>" if params else ""
            text = esc(op.get("description") or op.get("summary") or "")
            parts.append(f"<h2><code>{esc(method.upper())} {esc(path)}</code></h2><p>{text}</p>{table}")
    return _DOCS.format(version=esc(openapi.get("info", {}).get("version", "")),
                        description=esc(openapi.get("info", {}).get("description", "")),
                        operations="\n".join(parts))  # fmt: skip
