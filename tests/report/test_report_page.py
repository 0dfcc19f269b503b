"""`sgpipe report` without a browser: what the page holds (numbers from the manifests, every
picture copied beside it, nothing fetched from the network), byte-identical rewrites, partial
runs, and bad input (exit 2, one line naming the folder, nothing written)."""

from __future__ import annotations

import json
import re
import shutil
from html.parser import HTMLParser
from pathlib import Path

import pytest

from sgpipe.cli import main
from sgpipe.report import build


class _Links(HTMLParser):
    """Every src / href of the page, and the text of its tables' cells."""

    def __init__(self):
        super().__init__()
        self.links, self.imgs, self.cells, self._cell = [], [], [], None

    def handle_starttag(self, tag, attrs):
        a = dict(attrs)
        for k in ("src", "href"):
            if a.get(k) is not None:
                self.links.append(a[k])
        if tag == "img":
            self.imgs.append(a["src"])
        if tag == "td":
            self._cell = ""

    def handle_data(self, data):
        if self._cell is not None:
            self._cell += data

    def handle_endtag(self, tag):
        if tag == "td" and self._cell is not None:
            self.cells.append(self._cell.strip())
            self._cell = None


def _cli(args) -> int:
    with pytest.raises(SystemExit) as e:
        main([str(a) for a in args])
    return e.value.code


def _files(root: Path) -> dict[str, bytes]:
    return {p.relative_to(root).as_posix(): p.read_bytes() for p in sorted(root.rglob("*"))
            if p.is_file()}


def _parse(index: Path) -> _Links:
    p = _Links()
    p.feed(index.read_text())
    return p


def test_full_run_report(tiny_run, tmp_path, capsys):
    out = tmp_path / "rep"
    assert _cli(["report", tiny_run, "--out", out]) == 0
    assert capsys.readouterr().out.strip() == f"report: {out / 'index.html'}"
    html = (out / "index.html").read_text()
    page = _parse(out / "index.html")
    # self-contained: every link is a file inside the report folder, an anchor or data: URI
    for link in page.links:
        assert not re.match(r"^[a-z]+://|^//", link), link
        if not (link.startswith("#") or link.startswith("data:")):
            assert (out / link).is_file(), link
    assert not re.search(r"url\(\s*['\"]?(https?:)?//", html)
    # each method beside the reference, with its slider and difference view
    for m in ("sg", "gmm"):
        assert f"assets/render/{m}.png" in page.imgs
        assert f"assets/render/{m}.diff.png" in page.imgs
        assert f'data-left="{m}" data-right="reference"' in html
    assert html.count('type="range"') == 2
    assert page.imgs.count("assets/render/reference.png") == 2
    # the metrics table carries the manifest's numbers
    compare = json.loads((tiny_run / "render" / "manifest.json").read_text())["report"]["compare"]
    timings = json.loads((tiny_run / "render" / "timings.json").read_text())
    for m in ("sg", "gmm"):
        d = compare[m]
        row = [f"{d['display_psnr_db']:.2f}", f"{d['surface']['display_psnr_db']:.2f}",
               f"{d['flip_ldr']:.4f}", f"{d['surface']['flip_ldr']:.4f}",
               f"{d['flip_hdr']:.4f}", f"{d['rel_mse']:.4g}", f"{d['surface']['rel_mse']:.4g}",
               f"{d['psnr_db']:.2f}", f"{d['ssim']:.4f}", f"{1e3 * timings[m + '_s']:.3g}"]
        i = page.cells.index(m)
        assert page.cells[i + 1:i + 11] == row
    # fit plots (matplotlib PNGs of the fit stage), envmap previews, charts, manifests
    for name in ("shiny", "matte"):
        assert f"assets/fit/{name}/error_vs_lobes.png" in page.imgs
        assert f"assets/fit/{name}/slices.png" in page.imgs
    assert "assets/envmap/preview_pyramid.png" in page.imgs
    for chart in ("metrics", "timings", "fit_views", "visibility_pca"):
        assert f"assets/plots/{chart}.png" in page.imgs
    for stage in ("fit", "envmap", "visibility", "render"):
        assert f"{stage}/manifest.json:" in html
    assert "No render stage" not in html and "not run" not in html
    # the same run folder gives the same bytes; a rewrite replaces the previous report
    first = _files(out)
    assert _cli(["report", tiny_run, "--out", out]) == 0
    assert _files(out) == first
    assert [p.name for p in tmp_path.iterdir()] == ["rep"]          # no staging left


def test_default_folder_and_partial_run(tiny_run, tmp_path):
    part = tmp_path / "partial"
    shutil.copytree(tiny_run / "fit", part / "fit")                 # only `sgpipe fit` done
    assert _cli(["report", part]) == 0
    html = (part / "report" / "index.html").read_text()
    for stage, cmd in (("render", "render"), ("envmap", "precompute"),
                       ("visibility", "precompute")):
        assert f"No {stage} stage in this run folder (run <code>sgpipe {cmd}" in html
    assert "assets/fit/shiny/slices.png" in html and "assets/render/" not in html
    assert html.count("not run") == 3


def test_listed_but_missing_picture_is_reported_not_linked(tiny_run, tmp_path):
    run = tmp_path / "run"
    shutil.copytree(tiny_run, run, ignore=shutil.ignore_patterns("report"))
    (run / "render" / "gmm.diff.png").unlink()
    assert _cli(["report", run]) == 0
    html = (run / "report" / "index.html").read_text()
    assert "gmm.diff.png" in html.split("listed in the manifest but not on disk")[1]
    assert "assets/render/gmm.diff.png" not in html


def test_changed_artifact_is_reported_not_shown(tiny_run, tmp_path):
    """A flipped byte in a listed output gave a report identical to the intact run's."""
    run = tmp_path / "run"
    shutil.copytree(tiny_run, run, ignore=shutil.ignore_patterns("report"))
    png = run / "render" / "sg.png"
    data = bytearray(png.read_bytes())
    data[-20] ^= 0xFF
    png.write_bytes(bytes(data))
    assert _cli(["report", run]) == 0
    html = (run / "report" / "index.html").read_text()
    assert "1 outputs changed since written" in html
    assert "sg.png" in html.split("changed since the stage wrote them")[1].split("</p>")[0]
    assert "assets/render/sg.png" not in html


def _one_line_error(capsys) -> str:
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1, err
    return err[0]


def test_missing_or_non_run_folder_is_bad_input(tmp_path, capsys):
    missing = tmp_path / "nope"
    assert _cli(["report", missing]) == 2
    assert _one_line_error(capsys) == f"sgpipe: error: {missing}: RUN_DIR: run folder not found"
    assert not missing.exists()
    empty = tmp_path / "empty"
    empty.mkdir()
    (empty / "notes.txt").write_text("hi")
    assert _cli(["report", empty]) == 2
    line = _one_line_error(capsys)
    assert line.startswith(f"sgpipe: error: {empty}: RUN_DIR: not an sgpipe run folder")
    assert sorted(p.name for p in empty.iterdir()) == ["notes.txt"]
    afile = tmp_path / "file.txt"
    afile.write_text("x")
    assert _cli(["report", afile]) == 2
    assert f"{afile}: RUN_DIR: not a folder" in _one_line_error(capsys)


def test_bad_manifest_and_foreign_out_folder(tiny_run, tmp_path, capsys):
    run = tmp_path / "run"
    (run / "fit").mkdir(parents=True)
    (run / "fit" / "manifest.json").write_text("{not json")
    assert _cli(["report", run]) == 2
    assert f"{run / 'fit' / 'manifest.json'}: fit: unreadable JSON" in _one_line_error(capsys)
    assert sorted(p.name for p in run.iterdir()) == ["fit"]
    mine = tmp_path / "mine"
    mine.mkdir()
    (mine / "keep.txt").write_text("mine")
    assert _cli(["report", tiny_run, "--out", mine]) == 2
    assert f"{mine}: --out: folder exists and is not an sgpipe report" in _one_line_error(capsys)
    assert _files(mine) == {"keep.txt": b"mine"}


def test_failure_while_writing_keeps_the_previous_report(tiny_run, tmp_path, monkeypatch):
    out = tmp_path / "deep" / "rep"
    index = build.write_report(tiny_run, out)
    before = _files(out)

    def boom(*a, **k):
        raise RuntimeError("template failed")
    monkeypatch.setattr("sgpipe.report.page.render_page", boom)
    with pytest.raises(RuntimeError):
        build.write_report(tiny_run, out)
    assert _files(out) == before and index.is_file()
    assert [p.name for p in out.parent.iterdir()] == ["rep"]        # no staging / old folder
    fresh = tmp_path / "new" / "sub" / "rep"
    with pytest.raises(RuntimeError):
        build.write_report(tiny_run, fresh)
    assert not (tmp_path / "new").exists()                           # created parents removed


def test_render_without_comparisons_shows_a_gallery(tiny_run, tmp_path):
    run = tmp_path / "run"
    shutil.copytree(tiny_run / "render", run / "render")
    man_path = run / "render" / "manifest.json"
    man = json.loads(man_path.read_text())
    man["params"]["render"]["compare_to"] = None            # as `render.compare_to: null` writes
    del man["report"]["compare"]
    man_path.write_text(json.dumps(man))
    assert _cli(["report", run]) == 0
    html = (run / "report" / "index.html").read_text()
    assert 'type="range"' not in html and "compared nothing" in html
    imgs = _parse(run / "report" / "index.html").imgs
    assert {"assets/render/sg.png", "assets/render/gmm.png", "assets/render/reference.png"} <= \
        set(imgs)


def test_waits_for_a_run_holding_the_folder(tiny_run, tmp_path):
    import subprocess
    import sys
    run = tmp_path / "run"
    shutil.copytree(tiny_run / "fit", run / "fit")
    holder = subprocess.Popen(
        [sys.executable, "-c", "import fcntl, os, sys, time\n"
         f"fd = os.open({str(run)!r}, os.O_RDONLY); fcntl.flock(fd, fcntl.LOCK_EX)\n"
         "print('locked', flush=True); time.sleep(2.0)"], stdout=subprocess.PIPE, text=True)
    try:
        assert holder.stdout.readline().strip() == "locked"
        r = subprocess.run([sys.executable, "-m", "sgpipe", "report", str(run)],
                           capture_output=True, text=True, timeout=120)
        assert holder.wait(timeout=30) == 0
    finally:
        holder.kill()
    assert r.returncode == 0, r.stderr
    assert "waiting for another sgpipe run" in r.stderr
    assert (run / "report" / "index.html").is_file()
