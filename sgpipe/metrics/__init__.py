"""Image metrics against a reference: display PSNR and ꟻLIP (`display`, what a viewer sees),
linear PSNR, SSIM, relative MSE and a false-colour difference (`image`), surface-pixel masks
from the G-buffer (`surface`), threshold checks and JUnit XML for CI (`gates`)."""

from sgpipe.metrics.display import (DISPLAY_PEAK, display_image, display_psnr, flip_hdr,
                                    flip_hdr_map, flip_ldr, flip_ldr_map)
from sgpipe.metrics.image import (PSNR_PEAK, REL_MSE_EPS, as_rgb, compare_images,
                                  difference_scale, false_color_difference, luminance, mse, psnr,
                                  relative_mse, ssim, ssim_map)
from sgpipe.metrics.surface import surface_mask

#: the experiments' name for display_psnr
psnr_display = display_psnr

__all__ = ["DISPLAY_PEAK", "PSNR_PEAK", "REL_MSE_EPS", "as_rgb", "compare_images",
           "difference_scale", "display_image", "display_psnr", "false_color_difference",
           "flip_hdr", "flip_hdr_map", "flip_ldr", "flip_ldr_map", "luminance", "mse", "psnr",
           "psnr_display", "relative_mse", "ssim", "ssim_map", "surface_mask"]
