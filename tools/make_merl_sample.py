"""Synthesize a MERL `.binary` file from an analytic BRDF (real MERL files are ~35 MB each and
are not committed; this writes one that the fit stage and tests can read).

    python tools/make_merl_sample.py      # -> data_samples/synthetic_ggx_merl.binary
    python tools/make_merl_sample.py --model ward --params '{"alpha": 0.1}' --out /tmp/w.binary

The default is an isotropic GGX with separable Smith shadowing and the dielectric Fresnel of
Wang09 eq 14 (η = 1.33), i.e. exactly the tabulated microfacet form of Wang09 eq 13, so the
measured-BRDF path can be checked against known D, S, kd and ks.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

DEFAULT_OUT = Path(__file__).resolve().parents[1] / "data_samples" / "synthetic_ggx_merl.binary"
DEFAULT_PARAMS = {"alpha": 0.15, "kd": [0.10, 0.06, 0.03], "ks": [0.9, 0.8, 0.7],
                  "fresnel": "dielectric", "eta": 1.33}


def make_sample(out: str | Path = DEFAULT_OUT, model: str = "ggx", params: dict | None = None):
    """Tabulate `model(params)` at MERL cell centres and write it to `out`; returns the path."""
    from sgpipe.brdf import make_brdf, synthesize_merl, write_merl
    brdf = make_brdf(model, DEFAULT_PARAMS if params is None else params)
    return write_merl(out, synthesize_merl(brdf))


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", type=Path, default=DEFAULT_OUT, help="output .binary path")
    ap.add_argument("--model", default="ggx", help="sgpipe.brdf model name")
    ap.add_argument("--params", default=None, help="model parameters as JSON")
    a = ap.parse_args(argv)
    params = json.loads(a.params) if a.params else (DEFAULT_PARAMS if a.model == "ggx" else {})
    path = make_sample(a.out, a.model, params)
    print(f"wrote {path} ({path.stat().st_size} bytes)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
