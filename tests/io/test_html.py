"""The standalone HTML animation: offline, carries the frames, and its script runs (under node, if present)."""

from __future__ import annotations

import json
import re
import shutil
import subprocess

import numpy as np
import pytest

from motionlab.data.embedded.generator import generate_clip
from motionlab.io import html_animation, save_html_animation
from motionlab.representation import KIT, joints_to_features, recover_from_ric


@pytest.fixture(scope="module")
def walk() -> np.ndarray:
    return generate_clip("walk", np.random.default_rng(0), n_frames=50).joints


def _frame_data(page: str) -> dict:
    match = re.search(r'<script type="application/json" id="motion-data">(.*?)</script>', page, re.S)
    assert match, "the page embeds its frames as JSON"
    return json.loads(match.group(1))


def test_file_is_offline_and_carries_the_frames(tmp_path, walk):
    path = save_html_animation(walk, tmp_path / "walk.html", title="a person walks", fps=20)
    page = path.read_text(encoding="utf-8")
    assert page.startswith("<!DOCTYPE html>")
    assert not re.search(r"""(src|href)\s*=\s*["']?\s*(https?:)?//""", page, re.I)  # nothing to fetch
    assert "http" not in page.lower()
    assert "<canvas" in page and 'id="play"' in page  # the figure and its play/pause button
    data = _frame_data(page)
    assert data["fps"] == 20 and data["skeleton"] == "t2m"
    np.testing.assert_allclose(np.array(data["joints"]), walk, atol=5e-5)  # rounded to 0.1 mm
    assert len(data["bones"]) == 21 and len(data["colors"]) == 21
    assert "<title>a person walks</title>" in page


def test_title_and_data_cannot_break_out_of_the_page(walk):
    page = html_animation(walk, title='</script><script>alert("x")</script> __DATA__')
    assert "<script>alert" not in page
    assert "&lt;/script&gt;" in page and "__DATA__" in page  # the title stays text, the data stays data
    assert len(_frame_data(page)["joints"]) == len(walk)


def test_features_and_kit_motions(walk):
    features = joints_to_features(walk)
    data = _frame_data(html_animation(features))
    np.testing.assert_allclose(np.array(data["joints"]), recover_from_ric(features), atol=5e-5)
    kit = np.zeros((4, 21, 3)) + KIT.offsets.cumsum(axis=0)  # in mm, drawn in metres
    data = _frame_data(html_animation(kit))
    assert data["skeleton"] == "kit"
    np.testing.assert_allclose(np.array(data["joints"]), kit / 1000.0, atol=5e-5)


def test_bad_input_raises_and_writes_nothing(tmp_path, walk):
    with pytest.raises(ValueError, match=r"\.html"):
        save_html_animation(walk, tmp_path / "walk.gif")
    nan = walk.copy()
    nan[3, 3, 0] = np.inf
    with pytest.raises(ValueError, match="NaN or inf"):
        save_html_animation(nan, tmp_path / "walk.html")
    with pytest.raises(ValueError, match="shape"):
        save_html_animation(walk[..., :2], tmp_path / "walk.html")
    with pytest.raises(ValueError, match="fps"):
        save_html_animation(walk, tmp_path / "walk.html", fps=0)
    with pytest.raises(ValueError, match="no frames"):
        save_html_animation(walk[:0], tmp_path / "walk.html")
    assert list(tmp_path.iterdir()) == []


# A minimal DOM and canvas: run the page's script, let it animate, press pause, scrub.
_HARNESS = r"""
const fs = require("fs");
const page = fs.readFileSync(process.argv[2], "utf8");
const json = page.match(/<script type="application\/json" id="motion-data">([\s\S]*?)<\/script>/)[1];
const code = [...page.matchAll(/<script>([\s\S]*?)<\/script>/g)].map((m) => m[1]);
let pen = null, segments = 0;
const ctx = { clearRect() { segments = 0; }, beginPath() {}, stroke() {}, fill() {}, arc() {}, fillRect() {},
              moveTo(x, y) { pen = [x, y]; }, lineTo(x, y) { if (isFinite(x + y + pen[0] + pen[1])) segments++; } };
const on = {}, els = {};
function el(id) {
  return { value: id === "azimuth" ? "-35" : "0", max: "0", textContent: id === "motion-data" ? json : "",
           width: 520, height: 520, getContext: () => ctx, addEventListener(t, f) { on[id + ":" + t] = f; } };
}
global.document = { getElementById: (id) => (els[id] = els[id] || el(id)),
                    addEventListener(t, f) { on["document:" + t] = f; } };
const queue = [];
global.window = { requestAnimationFrame(f) { queue.push(f); } };
code.forEach((c) => eval(c));
const out = { first: els.label.textContent, max: els.frame.max };
for (let k = 0; k < 12; k++) queue.shift()(k * 50);
out.played = els.label.textContent; out.segments = segments;
out.action = els.segment ? els.segment.textContent : null;
on["play:click"](); out.button = els.play.textContent;
els.frame.value = "3"; on["frame:input"](); out.scrubbed = els.label.textContent;
out.scrubbedAction = els.segment ? els.segment.textContent : null;
console.log(JSON.stringify(out));
"""


def test_page_script_runs_plays_and_pauses(tmp_path, walk):
    node = shutil.which("node")
    if node is None:
        pytest.skip("node is not installed")
    page = save_html_animation(walk, tmp_path / "walk.html")
    harness = tmp_path / "harness.js"
    harness.write_text(_HARNESS)
    run = subprocess.run([node, str(harness), str(page)], capture_output=True, text=True, timeout=60)
    assert run.returncode == 0, run.stderr
    out = json.loads(run.stdout)
    assert out["first"].startswith("frame 1 / 50") and out["max"] == "49"
    assert out["played"].startswith("frame 12 / 50")  # 0.55 s at 20 fps
    assert out["segments"] > 21  # bones, floor grid and path, all finite
    assert out["button"] == "Play" and out["scrubbed"].startswith("frame 4 / 50")


SEGMENTS = [(0, "a person walks"), (10, "a person waves </script> with both hands")]


def test_segments_name_the_action_playing_and_mark_the_boundaries(tmp_path, walk):
    page = html_animation(walk, title="two actions", segments=SEGMENTS)
    assert _frame_data(page)["segments"] == [
        {"start": 0, "label": SEGMENTS[0][1]},
        {"start": 10, "label": SEGMENTS[1][1]},
    ]
    assert '<div id="segment">' in page and '<canvas id="timeline" width="520" height="18">' in page
    assert "</script> with" not in page  # a label stays data
    plain = html_animation(walk)
    assert '<div id="segment" hidden>' in plain and "segments" not in _frame_data(plain)
    node = shutil.which("node")
    if node is None:
        pytest.skip("node is not installed")
    path = save_html_animation(walk, tmp_path / "two.html", segments=SEGMENTS)
    harness = tmp_path / "harness.js"
    harness.write_text(_HARNESS)
    run = subprocess.run([node, str(harness), str(path)], capture_output=True, text=True, timeout=60)
    assert run.returncode == 0, run.stderr
    out = json.loads(run.stdout)
    assert out["played"].startswith("frame 12 / 50") and out["action"] == f"2/2: {SEGMENTS[1][1]}"
    assert out["scrubbed"].startswith("frame 4 / 50") and out["scrubbedAction"] == f"1/2: {SEGMENTS[0][1]}"


@pytest.mark.parametrize(
    "segments, match",
    [([], "non-empty"), ([(3, "a")], "begin at 0"), ([(0, "a"), (50, "b")], "below 50"), ([(0, 1)], "str label")],
)
def test_bad_segments_raise(walk, segments, match):
    with pytest.raises(ValueError, match=match):
        html_animation(walk, segments=segments)
