"""`python -m validation --out DIR`: sgpipe's reference against Mitsuba 3 on every stored scene
(validation/scenes/); exit 1 when a scene's whole-frame display PSNR is below 40 dB and more
than 2 dB under its joint noise floor."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(prog="python -m validation", description=__doc__)
    ap.add_argument("--out", type=Path, default=Path("out/validate"))
    ap.add_argument("--scenes", nargs="*", help="scene names (default: all)")
    ap.add_argument("--mode", choices=("auto", "filter", "centre"), default="auto",
                    help="filter: both integrate over the pixel with each scene's "
                         "render.pixel_filter (box by default; needs sgpipe's pixel filter); "
                         "centre: both trace through pixel centres only; auto: filter when "
                         "sgpipe has a pixel filter")
    ap.add_argument("--spp", type=int, default=None,
                    help="sgpipe reference spp (default: each scene's render.spp)")
    ap.add_argument("--mitsuba-spp", type=int, default=8192)
    ap.add_argument("--size", type=int, default=None, help="square image size override")
    ap.add_argument("--quick", action="store_true",
                    help="64² at 256 / 1024 spp: a smoke run (numbers below the goal)")
    args = ap.parse_args(argv)
    from validation import import_mitsuba
    try:
        import_mitsuba()
    except ImportError as e:
        print(f"validate: Mitsuba 3 is not installed ({e}); `make validate` installs the "
              "[validate] extra", file=sys.stderr)
        return 2
    from validation.report import passes, table_lines, write_images, write_report
    from validation.run import MIN_DISPLAY_PSNR_DB, NOISE_FLOOR_MARGIN_DB, run_scene, \
        scene_paths, sgpipe_has_pixel_filter
    has_filter = sgpipe_has_pixel_filter()
    mode = args.mode if args.mode != "auto" else ("filter" if has_filter else "centre")
    if mode == "filter" and not has_filter:
        print("validate: sgpipe's reference has no pixel filter: use --mode centre",
              file=sys.stderr)
        return 2
    spp, mspp, size = args.spp, args.mitsuba_spp, args.size
    if args.quick:
        spp, mspp, size = spp or 256, min(mspp, 1024), size or 64
    try:
        paths = scene_paths(args.scenes)
    except KeyError as e:
        print(f"validate: {e.args[0]}", file=sys.stderr)
        return 2
    notes = [f"mode {mode}: " + ("each scene's render.pixel_filter (box unless it says "
                                 "otherwise) vs the same Mitsuba rfilter"
                                 if mode == "filter" else
                                 "both renderers trace only through pixel centres")]
    results = []
    for p in paths:
        r = run_scene(p, mode=mode, spp_sgpipe=spp, spp_mitsuba=mspp, size=size)
        write_images(args.out, r)
        results.append(r)
    write_report(args.out, results, notes=notes)
    print("\n".join(table_lines(results)))
    print(f"validate: wrote {args.out / 'table.md'}, table.json and per-scene PNGs")
    bad = [r.name for r in results if not passes(r)]
    if bad:
        print(f"validate: below {MIN_DISPLAY_PSNR_DB:.0f} dB whole-frame display PSNR and more "
              f"than {NOISE_FLOOR_MARGIN_DB:.0f} dB under the joint noise floor: "
              + ", ".join(bad), file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
