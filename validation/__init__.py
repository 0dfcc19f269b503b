"""`make validate`: sgpipe's Monte Carlo reference against Mitsuba 3 on scenes of its own.

    python -m validation --out out/validate [--scenes NAME ...] [--quick]

Each scene is an sgpipe config (validation/scenes/*.yaml); `validation.mitsuba_scene` builds the
equivalent Mitsuba scene from the same config through the mappings of `validation.conventions`
(docs/VALIDATION.md lists them). Mitsuba is validation-only: sgpipe never imports it.
"""

import os

#: Debian's libLLVM 19, which Mitsuba's llvm_ad_rgb variant loads (tools/ensure_llvm.sh).
DEFAULT_LIBLLVM = "/usr/lib/x86_64-linux-gnu/libLLVM-19.so"


def import_mitsuba():
    """Mitsuba with the llvm_ad_rgb variant set (DRJIT_LIBLLVM_PATH defaults to Debian's)."""
    if not os.environ.get("DRJIT_LIBLLVM_PATH") and os.path.exists(DEFAULT_LIBLLVM):
        os.environ["DRJIT_LIBLLVM_PATH"] = DEFAULT_LIBLLVM
    import mitsuba as mi
    mi.set_variant("llvm_ad_rgb")
    return mi
