"""Image metrics against a reference (PSNR, SSIM, relative MSE, false-colour difference): the
`compare` command, the render stage's comparisons and the experiments' tables (`image`)."""

from sgpipe.metrics.image import (PSNR_PEAK, REL_MSE_EPS, as_rgb, compare_images,
                                  difference_scale, false_color_difference, luminance, mse, psnr,
                                  psnr_display, relative_mse, ssim, ssim_map)

__all__ = ["PSNR_PEAK", "REL_MSE_EPS", "as_rgb", "compare_images", "difference_scale",
           "false_color_difference", "luminance", "mse", "psnr", "psnr_display",
           "relative_mse", "ssim", "ssim_map"]
