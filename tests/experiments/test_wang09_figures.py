"""Wang09's experiment page without running the stages: the teapot config validates through the
schema with Table 1's settings, the Fig 7 / Fig 9 plots are written, and the page carries the
measured numbers and the ablation ladder below them."""

from sgpipe.experiments import ladder as ladder_mod
from sgpipe.experiments.wang09 import LADDER
from sgpipe.experiments.wang09_figures import PCA_TERMS, config, write_figures


def _result():
    err = lambda r: {"mean_abs": r / 2, "rms": r, "max_abs": 3 * r}  # noqa: E731
    series = ("err_exact_raw", "err_exact_pca", "err_sigmoid_pca", "err_sigmoid_published_pca")
    products = {f"{lam:g}": {"n": 10, **{k: err(0.01 * (i + 1) / lam ** 0.5)
                                        for i, k in enumerate(series)}}
                for lam in (4.0, 64.0, 1024.0)}
    curve = {str(m): {"rms_rad": 0.3 / (1 + m), "sign_mismatch": 0.1 / (1 + m)}
             for m in (0, 4, 16, 30)}
    return {"table": {"vertices": 20600, "env_lobes": 8, "ssdf_sampling_s": 12.3,
                      "pca_terms": PCA_TERMS, "pca_s": 1.5, "ssdf_bytes": 3 << 20,
                      "fps": {"env": {"sg": 6.1, "sg_wang09": 11.2},
                              "points": {"sg": 5.0, "sg_wang09": 9.0}}},
            "products": products, "pca": {"teapot": curve, "floor": curve}, "seconds": 90.0}


def test_config_is_table1s_teapot():
    cfg = config(lights=True)
    assert cfg.visibility.pca_terms == 30 and len(cfg.render.lights) == 2
    assert cfg.render.methods == ["sg", "sg_wang09"]
    assert config(lights=False).render.lights == []


def test_page_has_plots_table_and_ladder(tmp_path):
    results = tmp_path / "results" / "wang09.md"
    results.parent.mkdir()
    head = write_figures(_result(), results)
    for name in ("wang09_fig7.png", "wang09_fig9.png"):
        assert (results.parent / "figures" / name).stat().st_size > 5000
    rows = [{"seed": 11, "key": "sphere-x", "rungs": {
        label: {"db": 30.0 + k, "flip": 0.1, "ms": 50.0}
        for k, (label, _) in enumerate(LADDER.rungs())}}]
    md = ladder_mod.markdown(LADDER, rows, {"seeds": [11], "size": 96, "spp": 256,
                                            "seconds": 60.0}, head)
    assert "| 20600 | 8 | 12.3 s | 30D (1.5 s) | 3.0 MB | 6.1 / 11.2 | 5.0 / 9.0 |" in md
    assert "![Fig 7](figures/wang09_fig7.png)" in md
    assert md.index("### Fig 9") < md.index("## Ablation ladder") < md.index("### Summary per rung")
    assert "| 1024 | 0.0003 (max 0.001) |" in md
    assert "| floor (RMS rad / sign %) | 0.300 / 10.0 |" in md
