"""The README and the guides stay runnable: every `sgpipe` / `make` command line in their fenced
blocks parses against the real CLI (click) and the Makefile's targets, and every relative
markdown link resolves to a file (and, for `#anchor` links into markdown, to a heading)."""

from __future__ import annotations

import re
import shlex
from pathlib import Path

import click
import pytest

from sgpipe.cli import cli

ROOT = Path(__file__).resolve().parents[2]
PAGES = [ROOT / "README.md", *sorted((ROOT / "docs" / "guide").glob("*.md"))]

_FENCE = re.compile(r"^(\s*)```")
_LINK = re.compile(r"\[[^\]]*\]\(([^)\s]+)\)")


def _blocks(text: str) -> list[list[str]]:
    """The lines of every fenced block (``` ... ```), continuation lines (`\\`) joined."""
    blocks, cur = [], None
    for line in text.splitlines():
        if _FENCE.match(line):
            if cur is None:
                cur = []
            else:
                blocks.append(cur)
                cur = None
            continue
        if cur is not None:
            if cur and cur[-1].endswith("\\"):
                cur[-1] = cur[-1][:-1] + " " + line.strip()
            else:
                cur.append(line.strip())
    return blocks


def commands(text: str) -> list[list[str]]:
    """Command lines in fenced blocks: `$ sgpipe ...`, `$ .venv/bin/sgpipe ...`, `$ make ...`
    and the same without the prompt; shell comments dropped, placeholders kept as words."""
    out = []
    for block in _blocks(text):
        for line in block:
            line = line[2:] if line.startswith("$ ") else line
            if not re.match(r"^(\.venv/bin/)?sgpipe(\s|$)|^make(\s|$)", line):
                continue
            words = shlex.split(line, comments=True)
            part: list[str] = []
            for w in [*words, "&&"]:
                if w in ("&&", ";"):
                    if part:
                        out.append(part)
                    part = []
                else:
                    part.append(w)
    return out


def make_targets() -> set[str]:
    text = (ROOT / "Makefile").read_text()
    return {m.group(1) for m in re.finditer(r"^([A-Za-z][\w-]*)\s*:(?!=)", text, re.M)}


def parse_cli(args: list[str]) -> None:
    """Parse `sgpipe ARGS` as the CLI would, without running the command: raises
    click.UsageError (or a subclass) for an unknown command, option or a missing argument."""
    with cli.make_context("sgpipe", list(args)) as ctx:
        name, cmd, rest = cli.resolve_command(ctx, ctx._protected_args + ctx.args)
        cmd.make_context(name, rest, parent=ctx).close()


def check_command(words: list[str]) -> None:
    head, args = words[0], words[1:]
    if head == "make":
        targets, skip = [], False
        for w in args:
            if skip:            # the folder / file of -C DIR, -f FILE
                skip = False
            elif w in ("-C", "-f"):
                skip = True
            elif "=" not in w and not w.startswith("-"):
                targets.append(w)
        unknown = set(targets) - make_targets()
        if unknown:
            raise AssertionError(f"make: no target {sorted(unknown)}")
        return
    parse_cli(args)


def links(text: str) -> list[str]:
    # links inside fenced blocks are code, not links
    prose = re.sub(r"^```.*?^```", "", text, flags=re.M | re.S)
    return [m.group(1) for m in _LINK.finditer(prose)]


def _anchors(md: Path) -> set[str]:
    """GitHub's heading anchors: lower case, punctuation but `-` and `_` dropped, spaces → -."""
    out = set()
    for line in md.read_text().splitlines():
        if line.startswith("#"):
            title = line.lstrip("#").strip().lower()
            slug = re.sub(r"[^\w\- ]", "", title).replace(" ", "-")
            out.add(slug)
    return out


def check_link(page: Path, target: str) -> None:
    if re.match(r"^[a-z]+:", target):      # http:, https:, mailto:
        return
    path, _, anchor = target.partition("#")
    dest = (page.parent / path).resolve() if path else page
    if not dest.exists():
        raise AssertionError(f"{page.relative_to(ROOT)}: link {target!r}: no such file")
    if anchor and dest.suffix == ".md" and anchor not in _anchors(dest):
        raise AssertionError(f"{page.relative_to(ROOT)}: link {target!r}: no such heading")


@pytest.mark.parametrize("page", PAGES, ids=lambda p: str(p.relative_to(ROOT)))
def test_commands_parse(page):
    found = commands(page.read_text())
    for words in found:
        try:
            check_command(words)
        except (click.UsageError, AssertionError) as e:
            raise AssertionError(f"{page.relative_to(ROOT)}: `{shlex.join(words)}`: {e}")


def test_readme_has_commands():
    found = commands((ROOT / "README.md").read_text())
    heads = {(w[0], w[1] if len(w) > 1 else "") for w in found}
    assert ("make", "demo") in heads and ("make", "test") in heads
    used = {w[1] for w in found if w[0].endswith("sgpipe") and len(w) > 1}
    assert {"run", "precompute", "export", "compare", "report", "doctor",
            "config-doc"} <= used, used


@pytest.mark.parametrize("page", PAGES, ids=lambda p: str(p.relative_to(ROOT)))
def test_links_resolve(page):
    for target in links(page.read_text()):
        check_link(page, target)


def test_guides_exist_and_are_short():
    assert len(PAGES) > 1
    for page in PAGES[1:]:
        assert len(page.read_text().splitlines()) <= 260, page


def test_readme_results_come_from_the_results_pages():
    """Each row of the README's results tables is copied from one line of a results page that
    the paragraph above the table links to: all the row's numbers stand in that line."""
    text = (ROOT / "README.md").read_text()
    section = text.split("\n## Results\n", 1)[1].split("\n## ", 1)[0]
    num = re.compile(r"(?<![\w.])\d+\.\d+(?![\w.])")
    checked, pages, in_table = 0, [], False
    for line in section.splitlines():
        if not line.startswith("|"):
            if in_table:            # the prose before the next table names its pages afresh
                pages, in_table = [], False
            pages += [(ROOT / t).read_text().splitlines() for t in links(line)
                      if t.startswith("docs/results/")]
            continue
        in_table = True
        numbers = num.findall(line)
        if not numbers:
            continue
        assert pages, f"no results page linked above {line!r}"
        ok = any(all(re.search(rf"(?<![\d.]){re.escape(n)}(?![\d])", src) for n in numbers)
                 for page in pages for src in page)
        assert ok, f"README results row not in its results page: {line!r}"
        checked += 1
    assert checked >= 8, checked


def test_readme_length():
    assert len((ROOT / "README.md").read_text().splitlines()) <= 350


# the checks themselves must be able to fail

@pytest.mark.parametrize("line", [
    "$ sgpipe frobnicate configs/demo.yaml",          # no such command
    "$ sgpipe run configs/demo.yaml --outt out/x",    # no such option
    "$ sgpipe export out/x --sizee 64",               # no such option of export
    "$ sgpipe compare",                               # missing argument
    "$ make demoo",                                   # no such target
])
def test_bad_command_is_caught(line):
    (words,) = commands(f"```\n{line}\n```\n")
    with pytest.raises((click.UsageError, AssertionError)):
        check_command(words)


def test_good_commands_pass():
    text = ("```\n$ sgpipe run configs/demo.yaml --out out/demo \\\n  --set render.spp=8\n"
            "make demo OUT=/tmp/o   # a comment\n"
            "$ .venv/bin/sgpipe precompute configs/env_studio.yaml && sgpipe export out/x\n```\n")
    found = commands(text)
    assert [w[:2] for w in found] == [["sgpipe", "run"], ["make", "demo"],
                                      [".venv/bin/sgpipe", "precompute"], ["sgpipe", "export"]]
    for words in found:
        check_command(words)


def test_bad_link_is_caught():
    page = ROOT / "README.md"
    with pytest.raises(AssertionError, match="no such file"):
        check_link(page, "docs/guide/no-such-guide.md")
    with pytest.raises(AssertionError, match="no such heading"):
        check_link(page, "docs/CONVENTIONS.md#no-such-heading")
    check_link(page, "docs/CONVENTIONS.md#cubemaps")
    text = "[a](x.md)\n```\n[b](y.md)\n```\n[c](https://e.org)\n"
    assert links(text) == ["x.md", "https://e.org"]
