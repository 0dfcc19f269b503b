"""Unsigned small floats of VK_FORMAT_B10G11R11_UFLOAT_PACK32 (Vulkan spec "Unsigned 11-bit /
10-bit floating-point numbers"): 5 exponent bits (bias 15), 6 / 5 mantissa bits, no sign,
denormals below 2⁻¹⁴; R in bits 0–10, G in 11–21, B in 22–31. Values are rounded to nearest
(ties to even) straight from float64 (no double rounding through half floats), negatives and
NaN go to 0 and values above the largest finite one clamp to it (no Inf: an HDR sun stays
bright instead of becoming a non-number)."""

from __future__ import annotations

import numpy as np

EXP_BIAS = 15
MAX_EXP = 30                       # exponent field 31 is Inf/NaN


def max_finite(mant_bits: int) -> float:
    """Largest finite value: 2^15 · (2 − 2^−m) (65024 for 11-bit, 64512 for 10-bit)."""
    return 2.0 ** (MAX_EXP - EXP_BIAS) * (2.0 - 2.0 ** -mant_bits)


def encode_ufloat(x, mant_bits: int) -> np.ndarray:
    """float → the (5 + mant_bits)-bit field as uint32, round to nearest even."""
    x = np.asarray(x, np.float64)
    x = np.where(np.isnan(x) | (x <= 0.0), 0.0, np.minimum(x, max_finite(mant_bits)))
    # exponent of the representable interval holding x (denormals share exponent −14)
    e = np.floor(np.log2(np.where(x > 0, x, 1.0)))
    e = np.clip(e, 1 - EXP_BIAS, MAX_EXP - EXP_BIAS)
    quantum = np.exp2(e - mant_bits)
    q = np.rint(x / quantum)                       # np.rint: half to even
    # q counts quanta of 2^e: q ≥ 2^m is a normal number (q may reach 2^(m+1): the carry
    # into the next exponent is the same bit pattern arithmetic, handled below)
    normal = q >= 2 ** mant_bits
    carry = q >= 2 ** (mant_bits + 1)
    q = np.where(carry, q / 2, q)
    e = np.where(carry, e + 1, e)
    exp_field = np.where(normal, e + EXP_BIAS, 0)
    mant = np.where(normal, q - 2 ** mant_bits, q)
    return (exp_field.astype(np.uint32) << mant_bits) | mant.astype(np.uint32)


def decode_ufloat(bits, mant_bits: int) -> np.ndarray:
    """The (5 + mant_bits)-bit field → float64 (exponent 31 → Inf / NaN)."""
    bits = np.asarray(bits, np.uint32)
    e = (bits >> mant_bits) & 0x1F
    m = (bits & ((1 << mant_bits) - 1)).astype(np.float64)
    scale = 2.0 ** mant_bits
    val = np.where(e == 0, m / scale * 2.0 ** (1 - EXP_BIAS),
                   (1.0 + m / scale) * np.exp2(e.astype(np.float64) - EXP_BIAS))
    return np.where(e == 31, np.where(m == 0, np.inf, np.nan), val)


def pack_b10g11r11(rgb: np.ndarray) -> np.ndarray:
    """(..., 3) linear RGB → (...,) uint32 texels of B10G11R11_UFLOAT_PACK32."""
    rgb = np.asarray(rgb, np.float64)
    return (encode_ufloat(rgb[..., 0], 6) | (encode_ufloat(rgb[..., 1], 6) << 11)
            | (encode_ufloat(rgb[..., 2], 5) << 22)).astype(np.uint32)


def unpack_b10g11r11(packed: np.ndarray) -> np.ndarray:
    """(...,) uint32 → (..., 3) float64."""
    p = np.asarray(packed, np.uint32)
    return np.stack([decode_ufloat(p & 0x7FF, 6), decode_ufloat((p >> 11) & 0x7FF, 6),
                     decode_ufloat(p >> 22, 5)], axis=-1)


def to_half_rgba(rgb: np.ndarray) -> np.ndarray:
    """(..., 3) → (..., 4) float16 RGBA, alpha 1, clamped to ±65504 (no Inf)."""
    rgb = np.clip(np.asarray(rgb, np.float64), -65504.0, 65504.0)
    a = np.ones(rgb.shape[:-1] + (1,))
    return np.concatenate([rgb, a], axis=-1).astype(np.float16)
