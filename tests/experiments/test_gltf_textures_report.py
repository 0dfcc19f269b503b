"""docs/results/gltf_textures.md's every-method table: the shipped asset's cell, the median and
the worst of the textured cells, the controls left out."""

from sgpipe.experiments.gltf_textures_report import summary_rows


def _row(subject, k, **db):
    return {"subject": subject, "minification": k,
            **{m: {"surface_display_psnr_db": v} for m, v in db.items()}}


def test_summary_rows_take_the_ball_cell_the_median_and_the_worst():
    rows = [_row("ball", 1, sg=30.04, vmf=31.0), _row("ball", 2, sg=33.0, vmf=29.0),
            _row("plane", 4, sg=36.0, vmf=40.0)]
    out = {line.split(" | ")[0][3:-1]: line for line in summary_rows(rows)}
    assert set(out) == {"sg", "vmf"}                    # methods absent from every row: none
    assert out["sg"] == "| `sg` | Wang09 | 30.0 | 33.0 | 30.0 (ball 1×) |"
    assert out["vmf"] == "| `vmf` | Han07 | 31.0 | 31.0 | 29.0 (ball 2×) |"


def test_summary_rows_without_the_shipped_asset():
    out = summary_rows([_row("plane", 1, gmm=20.0), _row("plane", 2, gmm=22.0)])
    assert out == ["| `gmm` | Töral19 | – | 21.0 | 20.0 (plane 1×) |"]
