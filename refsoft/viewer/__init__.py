"""``trace.html``: one search in the browser, one self-contained file (data, script and style
inline; nothing fetched; opens from disk).

:func:`write_page` writes the data of :mod:`refsoft.viewer.data` into the page: the search's
heat map with its colour bar and formula, the path step by step (a slider, step and play
buttons, the arrow, Home and End keys), each step's candidates in a table linked both ways to the
picture (hovering highlights; a click chooses the step), a
side view of the geometry and the stop reason in words (docs/teaching.md).
"""

from __future__ import annotations

import html
import json
from importlib import resources

from .data import hierarchy_data, ldt_data, walk_data

__all__ = ["write_page", "write_trace_page", "trace_data", "page_html", "walk_data", "hierarchy_data", "ldt_data"]

_STYLE = """
body { font: 15px/1.4 sans-serif; margin: 1em 2em; color: #222; max-width: 1200px; }
h1 { font-size: 1.35em; margin: 0.2em 0; }
#meta { color: #555; }
#stop { background: #fff6d6; border-left: 4px solid #e0a800; padding: 0.4em 0.8em; margin: 0.6em 0; }
.row { display: flex; gap: 2em; flex-wrap: wrap; align-items: flex-start; }
#heat { image-rendering: pixelated; border: 1px solid #aaa; cursor: crosshair; display: block; }
#heat-box { position: relative; padding: 18px 0 30px 40px; display: inline-block; }
.tick { position: absolute; font-size: 11px; color: #444; white-space: nowrap; }
.axis { position: absolute; font-size: 11px; color: #666; }
#controls { margin: 0.5em 0; display: flex; gap: 0.5em; align-items: center; }
#slider { width: 320px; }
#formula, #bar-label, #hover, #side-caption, .legend { font-size: 0.9em; color: #444; max-width: 520px; }
table { border-collapse: collapse; font: 12px monospace; margin-top: 1em; }
th, td { border: 1px solid #ddd; padding: 2px 5px; text-align: right; }
th { position: sticky; top: 0; background: #f2f2f2; }
tr.current { background: #ffe9b3; }
tr.linked, td.linked { outline: 2px solid #ff00ff; }
td.chosen { font-weight: bold; color: #c25400; }
td.uncovered, td.outside, td.rejected { color: #999; }
#table-box { max-height: 420px; overflow: auto; }
"""

_BODY = """
<h1 id="title"></h1>
<div id="meta"></div>
<div id="stop"></div>
<div>result: <span id="result"></span></div>
<div class="row">
 <div>
  <h2 id="heat-title" style="font-size:1.05em"></h2>
  <div id="grid-pick" hidden><label for="grid-choice">heat map: </label><select id="grid-choice"></select></div>
  <div id="heat-box"><canvas id="heat" width="10" height="10"></canvas></div>
  <div id="hover">&nbsp;</div>
  <canvas id="bar" width="520" height="46"></canvas>
  <div id="bar-label"></div>
  <div id="formula"></div>
  <div class="legend" id="legend"></div>
 </div>
 <div>
  <h2 style="font-size:1.05em">Side view</h2>
  <svg id="side" width="420" height="300"></svg>
  <div id="side-caption"></div>
 </div>
</div>
<div id="controls">
 <button id="prev" title="previous step (left arrow)">◀ step</button>
 <button id="play" title="play / pause (space)">▶ play</button>
 <button id="next" title="next step (right arrow)">step ▶</button>
 <input id="slider" type="range" min="0" max="0" value="0" step="1" aria-label="step">
 <span id="step-label"></span>
</div>
<div id="table-box"><table id="steps"></table></div>
"""


def page_html(data: dict) -> str:
    """The page for ``data`` (a dict of :mod:`refsoft.viewer.data`), as one HTML string."""
    # JSON inside <script>: "<" escaped so that no "</script>" ends the block early
    payload = json.dumps(data, separators=(",", ":"), allow_nan=False).replace("<", "\\u003c")
    script = resources.files(__package__).joinpath("viewer.js").read_text(encoding="utf-8")
    return ("<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\">\n"
            f"<title>{html.escape(data['title'])}</title>\n<style>{_STYLE}</style></head>\n<body>{_BODY}\n"
            f"<script type=\"application/json\" id=\"trace-data\">{payload}</script>\n"
            f"<script>\n{script}</script>\n</body></html>\n")


def write_page(path, data: dict) -> None:
    """Write :func:`page_html` of ``data`` to ``path`` atomically."""
    from ..io import atomic_path

    with atomic_path(path, ".html") as tmp:
        with open(tmp, "w", encoding="utf-8") as fh:
            fh.write(page_html(data))


def trace_data(trace, images=None) -> dict:
    """The page's data of any trace: a :class:`~refsoft.search.trace.VertexReplay` (walk or
    hierarchy) or a :class:`~refsoft.ldt.trace.PixelTrace`. ``images``: the vertex's reflection
    pixels (M, 2), drawn on the walk's heat map."""
    from ..errors import RefsoftError
    from ..ldt.trace import PixelTrace
    from ..search.trace import VertexReplay

    if isinstance(trace, PixelTrace):
        return ldt_data(trace)
    if not isinstance(trace, VertexReplay):
        raise RefsoftError(f"trace must be a VertexReplay or a PixelTrace, got {type(trace).__name__}")
    if trace.method == "hierarchy":
        return hierarchy_data(trace, trace.eye, trace.position)
    return walk_data(trace, images)


def write_trace_page(out, trace, images=None) -> str:
    """Write ``trace.html`` of ``trace`` (see :func:`trace_data`) into folder ``out``; returns its name."""
    import os

    os.makedirs(out, exist_ok=True)
    write_page(os.path.join(out, "trace.html"), trace_data(trace, images))
    return "trace.html"
