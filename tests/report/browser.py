"""Headless Chromium (Debian's chromium + chromedriver) through selenium, and the checks the
report's browser test makes on a loaded page: not blank, every <img> loaded, no console error."""

from __future__ import annotations

import io
import os
import shutil
from pathlib import Path

import numpy as np

CHROMIUM = ("/usr/bin/chromium", "/usr/bin/chromium-browser", "/usr/bin/google-chrome")
FIX = ("bash tools/ensure_browser.sh (as root), or: sudo apt-get update && sudo apt-get "
       "install -y chromium chromium-driver")
#: a page whose screenshot has less pixel variance than this (0–255 grey levels²) is blank
BLANK_VARIANCE = 4.0

_IMAGES = """return Array.from(document.images).map(function (im) {
  return [im.getAttribute('src'), im.complete, im.naturalWidth]; });"""


def find_browser() -> tuple[str, str] | None:
    """(chromium, chromedriver) paths, or None when either is missing."""
    binary = next((b for b in CHROMIUM if os.access(b, os.X_OK)), None) or \
        shutil.which("chromium")
    driver = shutil.which("chromedriver") or (
        "/usr/bin/chromedriver" if os.access("/usr/bin/chromedriver", os.X_OK) else None)
    return (binary, driver) if binary and driver else None


def require_browser() -> tuple[str, str]:
    """(chromium, chromedriver); without them the test fails under CI (CI=true: the browser
    test must run there) and is skipped elsewhere, naming the fix either way."""
    import pytest
    found = find_browser()
    if found is None:
        msg = f"headless Chromium or chromedriver not found; install them: {FIX}"
        if os.environ.get("CI", "").lower() in ("true", "1"):
            pytest.fail(msg, pytrace=False)
        pytest.skip(msg)
    return found


def start(binary: str, driver_path: str, width: int = 1280, height: int = 2400):
    """A headless Chromium driven by selenium, logging the browser console."""
    from selenium import webdriver
    from selenium.webdriver.chrome.service import Service
    opts = webdriver.ChromeOptions()
    opts.binary_location = binary
    for a in ("--headless=new", "--no-sandbox", "--disable-gpu", "--disable-dev-shm-usage",
              f"--window-size={width},{height}", "--hide-scrollbars",
              "--allow-file-access-from-files"):
        opts.add_argument(a)
    opts.set_capability("goog:loggingPrefs", {"browser": "ALL"})
    return webdriver.Chrome(service=Service(driver_path), options=opts)


def screenshot_variance(driver) -> float:
    """Grey-level variance of a screenshot of the viewport."""
    from PIL import Image
    img = Image.open(io.BytesIO(driver.get_screenshot_as_png())).convert("L")
    return float(np.asarray(img, np.float64).var())


def page_problems(driver, page: Path) -> list[str]:
    """Open `page` by file:// and list what is wrong with it: a blank screenshot, an <img> that
    did not load (complete && naturalWidth > 0), a console message at level SEVERE."""
    driver.get_log("browser")                     # drop what earlier pages logged
    driver.get(Path(page).resolve().as_uri())     # returns once the load event fired
    problems = []
    var = screenshot_variance(driver)
    if var < BLANK_VARIANCE:
        problems.append(f"blank page: screenshot variance {var:.2f}")
    images = driver.execute_script(_IMAGES)
    for src, complete, width in images:
        if not (complete and width > 0):
            problems.append(f"image not loaded: {src}")
    for entry in driver.get_log("browser"):
        if entry.get("level") == "SEVERE":
            problems.append(f"console error: {entry.get('message')}")
    return problems
