"""The book as a reader runs it: JupyterLab from this environment, chapter 03 run to the end, its slider moved.

Starts ``jupyter lab`` from the test's own environment on 127.0.0.1 with a random token, in a temporary folder holding
a copy of chapter 03 (so nothing in the repository is written; ``MOTIONLAB_LAB_NOTEBOOK`` names another notebook),
opens it in headless Chromium, runs every cell (smoke profile, one torch thread) and waits for the kernel. No cell may
fail. Then it types 8 into the ``steps`` slider of the chapter's sampling widget, presses Enter and waits for the
widget's figure to change; the page must never show "Error displaying widget" nor an error in a widget's output (a
callback that raises). A second, planted notebook whose callback raises proves the check sees such an error. Skips
where no browser is installed (see ``conftest.py``).
"""

from __future__ import annotations

import json
import os
import secrets
import shutil
import socket
import subprocess
import sys
import time
import urllib.request
from pathlib import Path

import nbformat
import pytest

REPO = Path(__file__).resolve().parents[2]
NOTEBOOK = Path(os.environ.get("MOTIONLAB_LAB_NOTEBOOK", REPO / "notebooks" / "03_rectified_flow.ipynb"))
SLIDER = "steps"  # the description of the slider the test moves
RUN_TIMEOUT = 600  # seconds for the whole chapter on a busy 2-core machine (15 s when idle)

pytestmark = pytest.mark.browser


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def venv_bin(name: str) -> str:
    """An executable of the environment the tests run in (``.venv/bin``), else from PATH."""
    candidate = Path(sys.executable).parent / name
    found = str(candidate) if candidate.exists() else shutil.which(name)
    if found is None:
        pytest.skip(f"{name} is not installed (it comes with the book extra)")
    return found


def planted_notebook():
    """A notebook whose widget callback raises once its slider moves: what the test must catch."""
    nb = nbformat.v4.new_notebook()
    nb.cells = [
        nbformat.v4.new_code_cell(
            "import ipywidgets as widgets\nimport matplotlib.pyplot as plt\n\n\n"
            "def show(steps=2):\n"
            "    if steps != 2:\n"
            "        raise RuntimeError('planted fault: this callback raises')\n"
            "    fig, ax = plt.subplots(figsize=(2, 2))\n"
            "    ax.plot([0, steps])\n"
            "    plt.show()\n\n\n"
            "widgets.interact(show, steps=widgets.IntSlider(value=2, min=1, max=9, description='steps'));"
        )
    ]
    nb.metadata["kernelspec"] = {"name": "python3", "display_name": "Python 3", "language": "python"}
    return nb


@pytest.fixture(scope="module")
def lab(tmp_path_factory):
    """A running JupyterLab on a folder with a copy of the chapter and the planted notebook: yields name -> URL."""
    jupyter = venv_bin("jupyter")
    root = tmp_path_factory.mktemp("lab-root")
    shutil.copy(NOTEBOOK, root / NOTEBOOK.name)
    nbformat.write(planted_notebook(), root / "planted_fault.ipynb")
    settings = root.parent / f"{root.name}-settings"
    # With JupyterLab's default windowing, cells off screen are not in the page: render them all.
    tracker = settings / "@jupyterlab" / "notebook-extension" / "tracker.jupyterlab-settings"
    tracker.parent.mkdir(parents=True)
    tracker.write_text(json.dumps({"windowingMode": "none"}))
    port, token = free_port(), secrets.token_hex(16)
    env = os.environ | {
        "MOTIONLAB_PROFILE": "smoke",
        "MOTIONLAB_THREADS": os.environ.get("MOTIONLAB_THREADS", "1"),
        "JUPYTERLAB_SETTINGS_DIR": str(settings),
        "JUPYTERLAB_WORKSPACES_DIR": str(settings / "workspaces"),
        "JUPYTER_RUNTIME_DIR": str(settings / "runtime"),
    }
    log = root.parent / f"{root.name}-lab.log"
    cmd = [
        jupyter,
        "lab",
        "--no-browser",
        "--ServerApp.ip=127.0.0.1",
        f"--ServerApp.port={port}",
        f"--IdentityProvider.token={token}",
        f"--ServerApp.root_dir={root}",
        "--LabApp.expose_app_in_browser=True",
        "--ServerApp.port_retries=0",
        "--LabApp.news_url=",
        "--LabApp.check_for_updates_class=jupyterlab.NeverCheckForUpdate",
    ]
    if os.geteuid() == 0:
        cmd.append("--allow-root")
    with open(log, "w") as out:
        proc = subprocess.Popen(cmd, stdout=out, stderr=subprocess.STDOUT, env=env, cwd=root)
    try:
        base = f"http://127.0.0.1:{port}"
        deadline = time.monotonic() + 120
        while True:
            try:
                with urllib.request.urlopen(f"{base}/api/status?token={token}", timeout=5) as answer:
                    if answer.status == 200:
                        break
            except OSError:
                pass
            if proc.poll() is not None or time.monotonic() > deadline:
                pytest.fail(f"JupyterLab did not start:\n{log.read_text()[-3000:]}")
            time.sleep(0.5)
        # Each notebook in a workspace of its own: in the default one, a second browser restores the first one's
        # notebook beside its own, and the panel that has focus (where a run-all goes) is then a matter of timing.
        yield lambda name: f"{base}/lab/workspaces/{Path(name).stem}/tree/{name}?reset&token={token}"
    finally:
        proc.terminate()
        try:
            proc.wait(timeout=20)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait()


# `nb`: the notebook panel of the path given (arguments[0]), wherever the focus is.
FIND_PANEL = """
const app = window.jupyterapp;
const nb = app && [...app.shell.widgets('main')].find(w => w.context && w.context.path === arguments[0]);
"""

STATE_JS = (
    FIND_PANEL
    + """
if (!nb || !nb.content || !nb.sessionContext || !nb.sessionContext.session) return null;
const kernel = nb.sessionContext.session.kernel;
const cells = nb.content.widgets.filter(c => c.model.type === 'code');
const errors = [];
for (const c of cells) {
  const outs = c.model.outputs;
  for (let i = 0; i < outs.length; i++) {
    const o = outs.get(i).toJSON();
    if (o.output_type === 'error') errors.push(o.ename + ': ' + o.evalue);
  }
}
return {kernel: kernel ? kernel.status : null, cells: cells.length,
        run: cells.filter(c => c.model.executionCount !== null).length,
        busy: cells.filter(c => c.promptNode && c.promptNode.textContent.includes('*')).length,
        errors: errors};
"""
)

# What the reader sees of widgets: broken views, and errors printed into a widget's output area.
WIDGETS_JS = """
const text = document.body.innerText;
const outputs = [...document.querySelectorAll(
  '.widget-interact .jp-OutputArea-output, .widget-output .jp-OutputArea-output')];
return {broken: (text.match(/Error displaying widget[^\\n]*/g) || []),
        errors: outputs.filter(o => o.matches('[data-mime-type="application/vnd.jupyter.stderr"]') ||
                                    o.querySelector('.jp-RenderedText[data-mime-type="application/vnd.jupyter.stderr"]'))
                       .map(o => o.innerText.trim().split('\\n').slice(-1)[0])};  // the exception's last line
"""

# The interact widget that has a slider described `steps`, and the figure it draws.
FIND_JS = """
const label = arguments[0];
for (const box of document.querySelectorAll('.widget-interact')) {
  for (const slider of box.querySelectorAll('.widget-slider')) {
    const desc = slider.querySelector('.widget-label');
    if (desc && desc.textContent.trim() === label) {
      const img = box.querySelector('.jp-OutputArea img');
      return {readout: slider.querySelector('.widget-readout'), image: img ? img.src : null,
              value: slider.querySelector('.widget-readout').textContent};
    }
  }
}
return null;
"""


def wait_for(driver, script, ready, timeout, what, *args):
    deadline = time.monotonic() + timeout
    value = None
    while time.monotonic() < deadline:
        value = driver.execute_script(script, *args)
        if ready(value):
            return value
        time.sleep(1)
    pytest.fail(f"timed out after {timeout} s waiting for {what}; last state: {value}")


def run_all(driver, url: str, path: str) -> dict:
    """Open the notebook at ``path``, run every cell, wait for the kernel; return the final state (no cell may
    fail)."""
    driver.get(url)
    ready = wait_for(
        driver, STATE_JS, lambda s: s is not None and s["kernel"] == "idle", 180, "the notebook and its kernel", path
    )
    assert ready["run"] == 0, f"{path} opened with cells already run: {ready}"
    start = time.monotonic()
    # The run-all command acts on the notebook that has focus: give it to this one, and send the command again if no
    # cell has started (a command sent while the panel is still settling can be dropped).
    for _ in range(4):
        driver.execute_script(
            FIND_PANEL + "app.shell.activateById(nb.id); app.commands.execute('notebook:run-all-cells');", path
        )
        deadline = time.monotonic() + 30
        while time.monotonic() < deadline:
            s = driver.execute_script(STATE_JS, path)
            if s is not None and (s["errors"] or s["run"] or s["busy"]):
                break
            time.sleep(1)
        else:
            continue
        break
    state = wait_for(
        driver,
        STATE_JS,
        lambda s: s["errors"] or (s["kernel"] == "idle" and s["busy"] == 0 and s["run"] == s["cells"]),
        RUN_TIMEOUT,
        "every cell to run",
        path,
    )
    assert not state["errors"], f"a cell failed: {state['errors']}"
    print(f"{url.split('?')[0].rsplit('/', 1)[-1]} ran in {time.monotonic() - start:.0f} s ({state['cells']} cells)")
    return state


def move_slider(driver, label: str, value: str) -> tuple[dict, dict]:
    """Type ``value`` into the readout of the slider described ``label``; wait for its figure to change or for an
    error in the widget's output. Returns (before, after) as FIND_JS reports them."""
    from selenium.webdriver.common.keys import Keys

    before = wait_for(driver, FIND_JS, lambda f: f is not None and f["image"], 60, f"the '{label}' slider", label)
    readout = before["readout"]
    driver.execute_script("arguments[0].scrollIntoView({block: 'center'});", readout)
    readout.click()
    readout.send_keys(Keys.CONTROL, "a")
    readout.send_keys(value, Keys.ENTER)
    after = wait_for(
        driver,
        FIND_JS,
        lambda f: f is not None and f["image"] != before["image"] or bool(driver.execute_script(WIDGETS_JS)["errors"]),
        120,
        "the figure to change",
        label,
    )
    return before, after


def test_chapter_03_runs_and_its_slider_redraws(lab, browser_factory):
    driver = browser_factory(offline=True, bypass="127.0.0.1")
    run_all(driver, lab(NOTEBOOK.name), NOTEBOOK.name)
    widgets = driver.execute_script(WIDGETS_JS)
    assert not widgets["broken"] and not widgets["errors"], widgets

    before, after = move_slider(driver, SLIDER, "8")
    widgets = driver.execute_script(WIDGETS_JS)
    assert not widgets["broken"], f"a widget view failed: {widgets['broken']}"
    assert not widgets["errors"], f"moving the slider raised in the widget's callback:\n{widgets['errors']}"
    assert after["value"].strip() == "8", after["value"]
    assert after["image"] and after["image"] != before["image"], "the figure did not change"


def test_the_check_sees_a_callback_that_raises(lab, browser_factory):
    """The planted fault: the same checks, on a widget whose callback raises, must report it."""
    driver = browser_factory(offline=True, bypass="127.0.0.1")
    run_all(driver, lab("planted_fault.ipynb"), "planted_fault.ipynb")
    assert not driver.execute_script(WIDGETS_JS)["errors"]  # nothing raised before the slider moves
    move_slider(driver, "steps", "8")
    errors = driver.execute_script(WIDGETS_JS)["errors"]
    assert errors and "planted fault" in errors[0], errors
