"""Fixtures of the report tests: one small real run (every stage, three methods) and a headless
Chromium. Without Chromium the browser tests skip locally and fail under CI=true."""

from __future__ import annotations

import subprocess
import sys

import pytest

from tiny_scene import tiny_config  # tests/ is on sys.path (this folder is a package)

from report.browser import require_browser, start


@pytest.fixture(scope="session")
def tiny_run(tmp_path_factory):
    """A finished `sgpipe run` of the tiny scene: sg, gmm and the reference, with the fit
    stage's error-vs-lobes plots on (report_lobes 2)."""
    root = tmp_path_factory.mktemp("tiny_run")
    cfg = root / "tiny.yaml"
    text = tiny_config("[sg, gmm, reference]", workers=2).replace("report_lobes: 0}",
                                                                   "report_lobes: 2}")
    assert text.count("report_lobes: 2}") == 2
    cfg.write_text(text)
    out = root / "run"
    r = subprocess.run([sys.executable, "-m", "sgpipe", "run", str(cfg), "--out", str(out)],
                       capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stderr
    return out


@pytest.fixture(scope="session")
def chromium():
    """A headless Chromium (selenium + chromedriver), shared by the browser tests."""
    driver = start(*require_browser())
    try:
        yield driver
    finally:
        driver.quit()
