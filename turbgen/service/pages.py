"""The pages of `turbgen serve`: the static files of the catalog page and the run page (turbgen/service/static:
HTML, CSS and plain JavaScript using fetch, no library, no build step, nothing loaded from another host) and the API
reference rendered from the OpenAPI description."""

from __future__ import annotations

import html
import json
from pathlib import Path

STATIC = Path(__file__).parent / "static"


def static_files() -> frozenset:
    """The names of the scripts and style sheets of the pages: no other name is served under /static/."""
    return frozenset(p.name for p in STATIC.iterdir() if p.suffix in (".js", ".css"))


def page_html(name: str, form: dict) -> str:
    """The page ``name`` ("index.html" or "run.html") with the ``form`` description (GET /form.json) inlined."""
    data = json.dumps(form).replace("<", "\\u003c")  # no "</script>" can end the block early
    return (STATIC / name).read_text().replace("{form}", data)


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
    """The API reference at /docs from the ``openapi`` description (no script, nothing from another host)."""
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
