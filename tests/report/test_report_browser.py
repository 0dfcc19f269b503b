"""The report in a real headless Chromium (file://): the page is not blank, every image loaded,
nothing on the console at error level, the slider moves the split; and the checks themselves
catch a broken image, a script error and a blank page."""

from __future__ import annotations

import shutil

import pytest

from report import browser
from report.browser import page_problems
from sgpipe.report.build import write_report


def test_report_in_headless_chromium(tiny_run, tmp_path, chromium):
    index = write_report(tiny_run, tmp_path / "rep")
    assert page_problems(chromium, index) == []
    n_img = chromium.execute_script("return document.images.length")
    assert n_img >= 20                        # renders, diffs, fit plots, previews, charts
    # dragging the slider to 80 % shows 80 % of the method: the clip keeps its left part
    clip = chromium.execute_script("""
        var box = document.querySelector('.compare'), s = box.querySelector('input');
        s.value = 80; s.dispatchEvent(new Event('input'));
        return [box.querySelector('img.over').style.clipPath,
                box.querySelector('.divider').style.left,
                document.getElementById(box.dataset.readout).textContent];""")
    assert clip[0].replace("0px", "0") == "inset(0 20% 0 0)"
    assert clip[1] == "80%" and clip[2] == "80% sg | 20% reference"


def test_partial_run_report_in_headless_chromium(tiny_run, tmp_path, chromium):
    part = tmp_path / "partial"
    shutil.copytree(tiny_run / "fit", part / "fit")
    assert page_problems(chromium, write_report(part)) == []


def test_the_checks_catch_broken_pages(tiny_run, tmp_path, chromium):
    index = write_report(tiny_run, tmp_path / "rep")
    html = index.read_text()
    broken = index.with_name("broken_image.html")
    broken.write_text(html.replace('src="assets/render/sg.png"', 'src="assets/render/nope.png"',
                                   1))
    problems = page_problems(chromium, broken)
    assert any(p == "image not loaded: assets/render/nope.png" for p in problems), problems
    erroring = index.with_name("script_error.html")
    erroring.write_text(html.replace("</body>", "<script>undefinedFunction();</script></body>"))
    problems = page_problems(chromium, erroring)
    assert any(p.startswith("console error:") and "undefinedFunction" in p
               for p in problems), problems
    blank = index.with_name("blank.html")
    blank.write_text("<!doctype html><html><head><link rel='icon' href='data:,'></head>"
                     "<body></body></html>")
    assert [p.split(":")[0] for p in page_problems(chromium, blank)] == ["blank page"]


def test_missing_browser_fails_under_ci_and_skips_locally(monkeypatch):
    monkeypatch.setattr(browser, "find_browser", lambda: None)
    monkeypatch.setenv("CI", "true")
    with pytest.raises(pytest.fail.Exception, match="chromium chromium-driver"):
        browser.require_browser()
    monkeypatch.delenv("CI")
    with pytest.raises(pytest.skip.Exception, match="Chromium or chromedriver not found"):
        browser.require_browser()
