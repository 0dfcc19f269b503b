"""Wang09 §5 visibility: Embree-traced hemisphere visibility, SSDFs (eq 23), PCA (eq 24) and
SG–visibility products (eq 28–31). Artifact contract: docs/ARTIFACTS.md, visibility/."""

from sgpipe.visibility.decode import bilinear, decode_ssdf, decode_ssdf_image, decode_ssdf_local
from sgpipe.visibility.pca import SsdfPCA, streaming_pca
from sgpipe.visibility.products import (raytraced_sg_visibility, sample_sg_directions,
                                        sg_visibility_integral, sg_visibility_product)
from sgpipe.visibility.ssdf import (downsample_visibility, ssdf_bruteforce, ssdf_eq23_samples,
                                    ssdf_from_visibility)

__all__ = ["bilinear", "decode_ssdf", "decode_ssdf_image", "decode_ssdf_local", "SsdfPCA",
           "streaming_pca", "raytraced_sg_visibility", "sample_sg_directions",
           "sg_visibility_integral", "sg_visibility_product", "downsample_visibility",
           "ssdf_bruteforce", "ssdf_eq23_samples", "ssdf_from_visibility"]
