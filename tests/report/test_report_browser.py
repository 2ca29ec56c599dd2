"""report.html in a real browser: headless Chromium loads the page offline, the DOM holds
the verdict, and the screenshot is not blank. Skipped, with the reason shown, when
Chromium is not installed (CI installs it: see .ci/run)."""

import re
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest

from analyzer.pipeline import findings_document
from analyzer.report import render_report
from analyzer.report.synthetic import SyntheticFault, synthetic_analysis
from analyzer.types import FaultType

TIMEOUT_S = 90


def _chromium() -> str:
    for name in ("chromium", "chromium-browser", "google-chrome"):
        found = shutil.which(name)
        if found:
            return found
    if Path("/usr/bin/chromium").exists():
        return "/usr/bin/chromium"
    pytest.skip("chromium not installed: `apt-get install chromium` to run the browser checks")


def _run(page: Path, tmp: Path, *mode: str) -> subprocess.CompletedProcess[bytes]:
    cmd = [
        _chromium(),
        "--headless",
        "--no-sandbox",
        "--disable-gpu",
        "--disable-background-networking",
        "--disable-component-update",
        "--disable-sync",
        "--no-first-run",
        "--hide-scrollbars",
        f"--user-data-dir={tmp / 'profile'}",
        "--window-size=1200,3000",
        *mode,
        page.resolve().as_uri(),
    ]
    return subprocess.run(cmd, capture_output=True, timeout=TIMEOUT_S, check=True)


@pytest.fixture(scope="module")
def pages(tmp_path_factory):
    out = tmp_path_factory.mktemp("pages")
    faulty = synthetic_analysis(
        120.0,
        3,
        50.0,
        [SyntheticFault(1, FaultType.ADDITIVE, 70.0, None, 1.0)],
        names=["s0", "<b>s1</b>", "s2"],
    )
    healthy = synthetic_analysis(120.0, 3, 50.0, [])
    paths = {}
    for name, a in (("faulty", faulty), ("healthy", healthy)):
        p = out / f"{name}.html"
        p.write_text(render_report(a, findings_document(a)), encoding="utf-8")
        paths[name] = p
    return paths


@pytest.mark.parametrize(
    ("name", "verdict"),
    [("faulty", "1 sensor fault found on 1 sensor"), ("healthy", "No sensor fault found.")],
)
def test_dom_holds_the_verdict(pages, tmp_path, name, verdict):
    dom = _run(pages[name], tmp_path, "--dump-dom").stdout.decode("utf-8", "replace")
    assert verdict in dom
    assert dom.count("<svg") >= 1 and "Method" in dom
    if name == "faulty":
        assert "&lt;b&gt;s1&lt;/b&gt;" in dom and "<b>s1</b>" not in dom


def test_screenshot_is_not_blank(pages, tmp_path):
    from PIL import Image

    shot = tmp_path / "page.png"
    _run(pages["faulty"], tmp_path, f"--screenshot={shot}")
    img = np.asarray(Image.open(shot).convert("RGB"), dtype=np.int16)
    assert img.shape[:2] == (3000, 1200)
    colours = np.unique(img.reshape(-1, 3)[::97], axis=0)
    assert len(colours) > 20, "the page rendered as (almost) a single colour"
    top = img[:400]  # the faulty verdict box is tinted red near the top of the page
    reddish = (top[..., 0] > 240) & (top[..., 1] < 240) & (top[..., 2] < 240)
    assert reddish.mean() > 0.02


WIDTH = """<script>window.onload = function () {
  var d = document.documentElement;
  document.body.setAttribute("data-width", d.scrollWidth + "/" + d.clientWidth);
};</script>"""


def test_a_long_channel_name_does_not_widen_the_page(tmp_path):
    """A 300-character name without spaces: the models' channel lists (a paragraph) and
    their notes (a list) made the page 2470 px wide in a 1285 px window."""
    long = "/robot/" + "x" * 293
    a = synthetic_analysis(
        120.0,
        3,
        50.0,
        [SyntheticFault(1, FaultType.ADDITIVE, 70.0, None, 1.0)],
        names=["s0", long, "s2"],
    )
    page = tmp_path / "long.html"
    html = render_report(a, findings_document(a))
    page.write_text(html.replace("</body>", WIDTH + "</body>"), encoding="utf-8")
    dom = _run(page, tmp_path, "--virtual-time-budget=3000", "--dump-dom").stdout.decode()
    wide, window = (int(x) for x in re.search(r'data-width="(\d+)/(\d+)"', dom).groups())
    assert wide <= window, f"the page is {wide} px wide in a {window} px window"
