"""A motion as one standalone HTML page: a canvas stick figure with play/pause, a frame slider and a view angle.

The page needs no network: the joint positions travel inside it as JSON (``<script type="application/json">``)
and a few dozen lines of inline JavaScript draw them on a ``<canvas>`` with an orthographic camera::

    x1 =  cos(a) dx + sin(a) dz          # turn about the vertical axis by the azimuth a
    z1 = -sin(a) dx + cos(a) dz          # depth towards the viewer
    screen = (x1, dy cos(e) - z1 sin(e))  # tilt by the elevation e (looking slightly down)

with ``d = p - centre``. Positions are stored in metres rounded to 0.1 mm, so a 200-frame clip is ~100 kB.

A motion of several actions passes ``segments=[(start_frame, label), ...]``: the page then names the action that is
playing above the figure and draws a timeline under it, one span per action, a line at each boundary and the current
frame (:func:`check_segments` is the rule, shared with the book's player, :func:`motionlab.viz.animate_motions`).
"""

from __future__ import annotations

import html as html_lib
import json
import numbers
import os
from collections.abc import Mapping, Sequence
from pathlib import Path

import numpy as np

from ..representation import Skeleton
from .common import as_joints, write_text_atomic
from .palette import CHAIN_COLORS

SEGMENT_COLORS = ("#cfe3f5", "#f7d9a8", "#d5ecd4", "#fbe0e6", "#e8e0f0")  # one per action, in turn (light fills)

_PAGE = """<!DOCTYPE html>
<html lang="en">
<head>
<meta charset="utf-8">
<title>__TITLE__</title>
<style>
  body { font-family: system-ui, sans-serif; margin: 1.5em; color: #222; }
  h1 { font-size: 1.1em; font-weight: 600; }
  canvas { border: 1px solid #ccc; background: #fbfbfb; display: block; }
  .controls { margin-top: 0.6em; display: flex; gap: 0.8em; align-items: center; flex-wrap: wrap; }
  .controls input[type=range] { width: 220px; }
  #label { font-variant-numeric: tabular-nums; }
  .provenance { margin-top: 1em; font-size: 0.85em; color: #555; }
  .provenance dt { float: left; clear: left; width: 5em; font-weight: 600; }
  .provenance dd { margin-left: 5.5em; }
  #segment { font-weight: 600; min-height: 1.3em; margin-bottom: 0.3em; max-width: 520px; }
  #timeline { border: none; background: none; margin-top: 4px; }
</style>
</head>
<body>
<h1>__TITLE__</h1>
<div id="segment"__SEGMENTED__></div>
<canvas id="view" width="520" height="520"></canvas>
<canvas id="timeline" width="520" height="18"__SEGMENTED__></canvas>
<div class="controls">
  <button id="play" type="button">Pause</button>
  <input id="frame" type="range" min="0" max="0" value="0" aria-label="frame">
  <span id="label"></span>
  <label>view <input id="azimuth" type="range" min="-180" max="180" value="-35"></label>
</div>
__PROVENANCE__<script type="application/json" id="motion-data">__DATA__</script>
<script>
(function () {
  "use strict";
  var data = JSON.parse(document.getElementById("motion-data").textContent);
  var frames = data.joints, n = frames.length, fps = data.fps;
  var canvas = document.getElementById("view"), ctx = canvas.getContext("2d");
  var slider = document.getElementById("frame"), label = document.getElementById("label");
  var button = document.getElementById("play"), azimuth = document.getElementById("azimuth");
  var elevation = 15 * Math.PI / 180;
  slider.max = String(n - 1);

  // Centre and extent of the whole motion, so the camera stays still while the figure moves.
  var cx = 0, cz = 0, top = 0, count = 0, radius = 0;
  function eachJoint(fn) { frames.forEach(function (pose) { pose.forEach(fn); }); }
  eachJoint(function (p) { cx += p[0]; cz += p[2]; top = Math.max(top, p[1]); count++; });
  cx /= count; cz /= count;
  eachJoint(function (p) { radius = Math.max(radius, Math.hypot(p[0] - cx, p[2] - cz)); });
  radius = Math.max(radius, 0.5) + 0.2;
  var cy = top / 2;
  var tall = top * Math.cos(elevation) + 2 * radius * Math.sin(elevation) + 0.4;
  var scale = Math.min(canvas.width / (2 * radius), canvas.height / tall);

  function project(p) {
    var a = azimuth.value * Math.PI / 180, dx = p[0] - cx, dy = p[1] - cy, dz = p[2] - cz;
    var x1 = Math.cos(a) * dx + Math.sin(a) * dz, z1 = -Math.sin(a) * dx + Math.cos(a) * dz;
    var up = dy * Math.cos(elevation) - z1 * Math.sin(elevation);
    var depth = z1 * Math.cos(elevation) + dy * Math.sin(elevation);
    return [canvas.width / 2 + scale * x1, canvas.height / 2 - scale * up, depth];
  }

  function line(a, b, color, width) {
    ctx.strokeStyle = color; ctx.lineWidth = width;
    ctx.beginPath(); ctx.moveTo(a[0], a[1]); ctx.lineTo(b[0], b[1]); ctx.stroke();
  }

  function drawFloor() {
    var step = 0.5, r = Math.ceil(radius / step) * step;
    for (var k = -r; k <= r + 1e-9; k += step) {
      line(project([cx - r, 0, cz + k]), project([cx + r, 0, cz + k]), "#e2e2e2", 1);
      line(project([cx + k, 0, cz - r]), project([cx + k, 0, cz + r]), "#e2e2e2", 1);
    }
    for (var t = 1; t < n; t++) {  // the root's path on the floor
      var a = frames[t - 1][0], b = frames[t][0];
      line(project([a[0], 0, a[2]]), project([b[0], 0, b[2]]), "#c9c9c9", 1.5);
    }
  }

  var current = 0, playing = true, last = null, clock = 0;

  function draw() {
    ctx.clearRect(0, 0, canvas.width, canvas.height);
    drawFloor();
    var pts = frames[current].map(project);
    function depth(i) { return pts[data.bones[i][0]][2] + pts[data.bones[i][1]][2]; }
    var order = data.bones.map(function (b, i) { return i; });
    order.sort(function (i, j) { return depth(i) - depth(j); });  // far bones first
    order.forEach(function (i) { line(pts[data.bones[i][0]], pts[data.bones[i][1]], data.colors[i], 3); });
    ctx.fillStyle = "#333";
    pts.forEach(function (p) { ctx.beginPath(); ctx.arc(p[0], p[1], 2.5, 0, 2 * Math.PI); ctx.fill(); });
    slider.value = String(current);
    label.textContent = "frame " + (current + 1) + " / " + n + "  (" + (current / fps).toFixed(2) + " s)";
    if (data.segments) { drawSegments(); }
  }

  // The action playing now, and a timeline: one span per action, a line at each boundary, the current frame.
  function drawSegments() {
    var segs = data.segments, k = 0;
    while (k + 1 < segs.length && segs[k + 1].start <= current) { k++; }
    document.getElementById("segment").textContent = (k + 1) + "/" + segs.length + ": " + segs[k].label;
    var line = document.getElementById("timeline"), tc = line.getContext("2d"), w = line.width, h = line.height;
    var colors = data.segment_colors;
    tc.clearRect(0, 0, w, h);
    segs.forEach(function (seg, i) {
      var a = w * seg.start / n, b = w * (i + 1 < segs.length ? segs[i + 1].start : n) / n;
      tc.fillStyle = colors[i % colors.length]; tc.fillRect(a, 0, b - a, h);
      if (i > 0) { tc.fillStyle = "#333"; tc.fillRect(a - 1, 0, 2, h); }
    });
    tc.fillStyle = "#d55e00"; tc.fillRect(w * current / n - 1.5, 0, 3, h);
  }

  function tick(now) {
    if (playing) {
      if (last !== null) { clock += (now - last) / 1000; }
      var step = Math.floor(clock * fps);
      if (step > 0) { current = (current + step) % n; clock -= step / fps; draw(); }
      last = now;
    }
    window.requestAnimationFrame(tick);
  }

  function setPlaying(value) {
    playing = value; last = null; clock = 0;
    button.textContent = playing ? "Pause" : "Play";
  }
  button.addEventListener("click", function () { setPlaying(!playing); });
  slider.addEventListener("input", function () { setPlaying(false); current = Number(slider.value); draw(); });
  azimuth.addEventListener("input", draw);
  document.addEventListener("keydown", function (e) {
    if (e.key === " ") { e.preventDefault(); setPlaying(!playing); }
  });
  draw();
  window.requestAnimationFrame(tick);
})();
</script>
</body>
</html>
"""


def _bones_and_colors(sk: Skeleton) -> tuple[list[list[int]], list[str]]:
    bones, colors = [], []
    for k, chain in enumerate(sk.chains):
        for a, b in zip(chain[:-1], chain[1:]):
            bones.append([a, b])
            colors.append(CHAIN_COLORS[k % len(CHAIN_COLORS)])
    return bones, colors


def _provenance_html(provenance: Mapping[str, str] | None) -> str:
    # a definition list under the controls: how the motion was made, readable without opening the source
    if not provenance:
        return ""
    rows = "".join(
        f"  <dt>{html_lib.escape(str(k))}</dt><dd>{html_lib.escape(str(v))}</dd>\n" for k, v in provenance.items()
    )
    return f'<dl class="provenance" id="provenance">\n{rows}</dl>\n'


def check_segments(segments, n_frames: int) -> list[tuple[int, str]]:
    """``segments`` as a list of ``(start_frame, label)``: starts are ints, the first 0, increasing, < ``n_frames``."""
    if isinstance(segments, (str, bytes)) or not isinstance(segments, Sequence) or len(segments) == 0:
        raise ValueError(f"segments must be a non-empty list of (start_frame, label), got {segments!r}")
    out = []
    for item in segments:
        if not (isinstance(item, Sequence) and not isinstance(item, str) and len(item) == 2):
            raise ValueError(f"each segment must be a (start_frame, label) pair, got {item!r}")
        start, label = item
        if not isinstance(start, numbers.Integral) or isinstance(start, bool) or not isinstance(label, str):
            raise ValueError(f"each segment must be (int start_frame, str label), got {item!r}")
        out.append((int(start), label))
    starts = [s for s, _ in out]
    if starts[0] != 0 or any(b <= a for a, b in zip(starts, starts[1:])) or starts[-1] >= n_frames:
        raise ValueError(f"segment starts must begin at 0 and increase below {n_frames} frames, got {starts}")
    return out


def html_animation(
    joints,
    title: str = "motion",
    fps: float = 20.0,
    skeleton: str | Skeleton | None = None,
    provenance: Mapping[str, str] | None = None,
    segments: Sequence[tuple[int, str]] | None = None,
) -> str:
    """The text of a standalone HTML page animating ``joints`` ``(T, J, 3)`` (or features ``(T, 263|251)``).

    ``provenance`` (e.g. :func:`motionlab.io.provenance.motion_provenance`) is shown under the animation and kept
    in the page's JSON payload under ``"provenance"``. ``segments=[(start_frame, label), ...]`` (the first at 0)
    names each action of a multi-action motion: the page shows the one playing and marks the boundaries.
    """
    positions, sk = as_joints(joints, skeleton, name="joints")
    if not isinstance(title, str):
        raise ValueError(f"title must be a str, got {type(title).__name__}")
    if not (np.isfinite(fps) and fps > 0):
        raise ValueError(f"fps must be positive, got {fps}")
    metres = np.round(positions * sk.meters_per_unit, 4)  # (T, J, 3)
    bones, colors = _bones_and_colors(sk)
    payload = {
        "skeleton": sk.name,
        "fps": float(fps),
        "joint_names": list(sk.joint_names),
        "bones": bones,
        "colors": colors,
        "joints": metres.tolist(),
    }
    if provenance:
        payload["provenance"] = {str(k): str(v) for k, v in provenance.items()}
    if segments is not None:
        payload["segments"] = [{"start": a, "label": b} for a, b in check_segments(segments, len(metres))]
        payload["segment_colors"] = list(SEGMENT_COLORS)
    # "<" never appears raw inside the <script> element, so no data can close it early.
    data = json.dumps(payload, separators=(",", ":")).replace("<", "\\u003c")
    # Data first, so a title that happens to contain "__DATA__" stays text.
    page = _PAGE.replace("__SEGMENTED__", "" if segments is not None else " hidden").replace("__DATA__", data)
    return page.replace("__PROVENANCE__", _provenance_html(provenance)).replace("__TITLE__", html_lib.escape(title))


def save_html_animation(
    joints,
    path: str | os.PathLike,
    title: str = "motion",
    fps: float = 20.0,
    skeleton: str | Skeleton | None = None,
    provenance: Mapping[str, str] | None = None,
    segments: Sequence[tuple[int, str]] | None = None,
) -> Path:
    """Write :func:`html_animation` to ``path`` (``.html``/``.htm``) atomically; returns the path."""
    path = Path(path)
    if path.suffix.lower() not in (".html", ".htm"):
        raise ValueError(f"path must end in .html or .htm, got {str(path)!r}")
    return write_text_atomic(path, html_animation(joints, title, fps, skeleton, provenance, segments))
