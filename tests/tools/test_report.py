"""The batch report: a static page that a browser renders with its images."""
from __future__ import annotations

import re
import shutil
import subprocess

import cv2
import pytest

from synthcompose.cli import main
from synthcompose.synthetic import make_sample

from ..helpers import write_manifest


def _browser() -> str | None:
    return shutil.which("chromium") or shutil.which("chromium-browser") or shutil.which("google-chrome")


@pytest.mark.slow
def test_report_renders_in_a_headless_browser_with_its_images(tmp_path):
    root = tmp_path / "cs"
    ids = make_sample(root, count=2, width=640, height=320, seed=3)
    out = tmp_path / "out"
    assert main(["batch", str(write_manifest(tmp_path / "m.json", root, out)), "--no-progress"]) == 0
    assert main(["report", str(out)]) == 0
    index = out / "report" / "index.html"
    page = index.read_text()
    assert "Inserted objects per class" in page and "mean time per stage" in page and "<svg" in page
    thumbs = sorted((out / "report" / "thumbs").glob("*.jpg"))
    assert len(thumbs) == 2 * len(ids)
    assert all(cv2.imread(str(t)) is not None for t in thumbs)
    browser = _browser()
    if browser is None:
        pytest.skip("no Chromium here (make test installs it)")
    dom = subprocess.run([browser, "--headless", "--no-sandbox", "--disable-gpu", "--virtual-time-budget=5000",
                          "--dump-dom", index.as_uri()], capture_output=True, text=True, timeout=120).stdout
    loaded = re.search(r'data-images-loaded="(\d+)"', dom)
    total = re.search(r'data-images="(\d+)"', dom)
    assert loaded and total, dom[-500:]
    assert int(total.group(1)) == len(thumbs) and int(loaded.group(1)) == len(thumbs)
    shot = tmp_path / "shot.png"
    subprocess.run([browser, "--headless", "--no-sandbox", "--disable-gpu", "--window-size=1000,1400",
                    f"--screenshot={shot}", index.as_uri()], capture_output=True, timeout=120)
    img = cv2.imread(str(shot))
    assert img is not None and img.std() > 20  # not a blank page
