"""A disk that fills mid-stage, through a real `sgpipe` subprocess writing to a small tmpfs
(mounted in a private user + mount namespace, so no root is needed and nothing outlives the
test): one line naming the file and saying the disk is full, exit 2, no staging or temp folder
left, no worker left, earlier stages intact."""

import os
import shutil
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
SAMPLES = ROOT / "data_samples"
CONFIG = f"""
name: full
scene:
  objects:
    - {{name: floor, mesh: {SAMPLES / 'floor.obj'}, material: m}}
    - {{name: teapot, mesh: {SAMPLES / 'teapot.obj'}, material: m}}
envmap: {{environment: {SAMPLES / 'sky_sun.exr'}, cube_resolution: 64}}
visibility: {{trace_resolution: 32, resolution: 16, pca_terms: 8}}
"""


def _in_private_tmpfs(tmp_path, size: str, commands: str, done: str, timeout: int) -> Path:
    """Run the shell `commands` with a tmpfs of `size` mounted at the returned folder (`{mnt}`
    in them) inside a private user + mount namespace; skip the test where that cannot be made
    or where the commands did not write tmp_path/`done`."""
    mnt = tmp_path / "mnt"
    mnt.mkdir()
    script = f"mount -t tmpfs -o size={size} tmpfs {mnt} || exit 99; " + commands.format(mnt=mnt)
    r = subprocess.run(["unshare", "--user", "--map-root-user", "--mount", "sh", "-c", script],
                       capture_output=True, text=True, timeout=timeout)
    if r.returncode == 99 or not (tmp_path / done).exists():
        pytest.skip(f"no private tmpfs here: {r.stderr.strip()[:200]}")
    return mnt


def _run_on_tmpfs(tmp_path, size: str, workers: int) -> tuple[int, str, list[str], str]:
    """(exit status, stderr, what is left under --out, `df` of the tmpfs afterwards)."""
    cfg = tmp_path / "c.yaml"
    cfg.write_text(textwrap.dedent(CONFIG))
    _in_private_tmpfs(tmp_path, size,
                      f"{sys.executable} -m sgpipe precompute {cfg} --out {{mnt}}/out "
                      f"--set workers={workers} 2>{tmp_path}/err; echo $? > {tmp_path}/rc; "
                      f"ls -A {{mnt}}/out > {tmp_path}/left 2>/dev/null; "
                      f"df -B1 --output=used {{mnt}} | tail -1 > {tmp_path}/used",
                      "rc", 300)
    left = (tmp_path / "left").read_text().split()
    return (int((tmp_path / "rc").read_text()), (tmp_path / "err").read_text(), left,
            (tmp_path / "used").read_text().strip())


pytestmark = pytest.mark.skipif(shutil.which("unshare") is None or sys.platform != "linux",
                                reason="needs util-linux unshare (Linux)")


@pytest.mark.parametrize("workers", [1, 2])
def test_visibility_scratch_on_a_full_disk(tmp_path, workers):
    """20 MB: the envmap stage fits, the visibility scratch (20k vertices × 16² float32,
    ~21 MB) does not. Its memmap was sparse: the writing worker died of SIGBUS (exit 135 with
    workers: 1, a BrokenProcessPool traceback with 2) and the disk stayed full."""
    rc, err, left, used = _run_on_tmpfs(tmp_path, "20m", workers)
    lines = [ln for ln in err.splitlines() if ln.startswith("sgpipe:")]
    assert rc == 2, err
    assert len(lines) == 1 and "no space left on device" in lines[0], err
    assert ".visibility.tmp/ssdf_" in lines[0] and "MB needed" in lines[0]
    assert "Traceback" not in err
    assert left == ["envmap"], left            # no staging / temp folder, envmap intact
    assert int(used) < 8e6                     # the scratch's space is given back


def test_exr_write_on_a_full_disk(tmp_path):
    """1 MB: the envmap stage's EXRs do not fit. OpenImageIO reports no errno; the message
    said only 'Failed to write pixel data'."""
    rc, err, left, used = _run_on_tmpfs(tmp_path, "1m", 1)
    lines = [ln for ln in err.splitlines() if ln.startswith("sgpipe:")]
    assert rc == 2, err
    assert len(lines) == 1 and ".exr: no space left on device" in lines[0], err
    assert left == [] and int(used) == 0


def test_any_write_that_finds_the_disk_full_is_one_line(tmp_path, monkeypatch, capsys):
    """JSON / NPY writes (timings.json in the publish step) raised OSError [Errno 28] with a
    traceback, exit 1; anywhere in a stage, or as the cause of another error, it is one line."""
    import errno
    from sgpipe import cli
    import sgpipe.stages.fit as fit

    def full(cfg, out, force=False):
        try:
            raise OSError(errno.ENOSPC, "No space left on device", str(out / "timings.json"))
        except OSError as e:
            raise RuntimeError("publish failed") from e

    monkeypatch.setattr(fit, "run", full)
    cfg = tmp_path / "c.yaml"
    cfg.write_text("name: x\n")
    with pytest.raises(SystemExit) as e:
        cli.main(["fit", str(cfg), "--out", str(tmp_path / "out")])
    assert e.value.code == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith(f"sgpipe: error: {tmp_path / 'out'}/timings.json:")
    assert "no space left on device" in err[0] and "MB free there" in err[0]


def test_png_that_does_not_fit_is_not_renamed_into_place(tmp_path):
    """OpenImageIO's PNG writer reports a short write only as a pending error (write_image and
    close return True): a 1 MB tmpfs got a truncated preview PNG under the final name."""
    code = ("import numpy as np\nfrom sgpipe.io import write_png\n"
            "rng = np.random.default_rng(0)\n"
            "try:\n    write_png('{mnt}/big.png', rng.random((1500, 1500, 3)))\n"
            "except OSError as e:\n    print('errno', e.errno)\n"
            "write_png('{mnt}/small.png', rng.random((64, 64, 3)))\n")
    _in_private_tmpfs(tmp_path, "1m",
                      f"{sys.executable} -c \"{code}\" > {tmp_path}/out 2>&1; "
                      f"ls -A {{mnt}} > {tmp_path}/left", "left", 120)
    assert (tmp_path / "out").read_text().strip() == "errno 28"
    assert (tmp_path / "left").read_text().split() == ["small.png"]
