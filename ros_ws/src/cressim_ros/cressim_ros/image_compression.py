"""sensor_msgs/CompressedImage for image_transport's `compressed` and `compressedDepth` transports,
as ROS 2 Jazzy's plugins write them (image_transport_plugins 4.0.x, compressed_publisher.cpp and
compressed_depth_image_transport/codec.cpp), so that their subscribers, rviz and bag tools decode
`<image>/compressed` and `<depth>/compressedDepth` from the twin.

    compressed, jpeg   format "rgb8; jpeg compressed bgr8", "mono8; jpeg compressed mono8"
    compressed, png    format "rgb8; png compressed bgr8", "mono8; png compressed " (sic: trailing space)
                       data: an ordinary JPEG / PNG ("bgr8" names what cv::imdecode returns)
    compressedDepth    format "32FC1; compressedDepth png" / "16UC1; compressedDepth png"
                       data: 12-byte ConfigHeader {int32 format = 0 (INV_DEPTH), float32 A, float32 B}
                       (little endian, as the C++ memcpy's it), then a 16-bit greyscale PNG:
                       32FC1: n = trunc(A / d + B), 0 = no return; decoded d = A / (n - B),
                              A = q (q + 1), B = 1 - A / depth_max (q: depth_quantization)
                       16UC1: the values as they are; A, B unused (uninitialised in the C++; 0 here)

Defaults are the plugins': jpeg_quality 95, png_level 3, depth_max 10 m, depth_quantization 100.
Deviations, on purpose: depths too close to fit 16 bits are clamped to the nearest representable
one (the C++ overflows the conversion); a 16UC1 image is not cut at depth_max * 1000 (the plugin
takes 16UC1 for millimetres; ours are segmentation ids).
"""
from __future__ import annotations

import io
import math
import struct
from array import array

import numpy as np
from PIL import Image as PILImage
from sensor_msgs.msg import CompressedImage

JPEG_QUALITY = 95
PNG_LEVEL = 3
DEPTH_MAX = 10.0
DEPTH_QUANTIZATION = 100.0
INV_DEPTH = 0
CONFIG_HEADER = struct.Struct("<iff")  # compressionFormat (a C enum: int32), float depthParam[2]


def _encode(image: np.ndarray, fmt: str, **options) -> bytes:
    buf = io.BytesIO()
    PILImage.fromarray(image).save(buf, format=fmt, **options)
    return buf.getvalue()


def _message(fmt: str, data: bytes, header) -> CompressedImage:
    m = CompressedImage()
    if header is not None:
        m.header = header
    m.format = fmt
    m.data = array("B", data)  # an array is taken as is; bytes would be checked element by element
    return m


def compress_image(image: np.ndarray, fmt: str = "jpeg", *, jpeg_quality: int = JPEG_QUALITY,
                   png_level: int = PNG_LEVEL, header=None) -> CompressedImage:
    """`compressed` transport of an (H, W, 3) uint8 rgb8 or (H, W) uint8 mono8 image; fmt "jpeg"
    or "png" ("png" also takes (H, W) uint16 as 16UC1)."""
    a = np.ascontiguousarray(image)
    colour = a.dtype == np.uint8 and a.ndim == 3 and a.shape[2] == 3
    if colour:
        encoding = "rgb8"
    elif a.dtype == np.uint8 and a.ndim == 2:
        encoding = "mono8"
    elif a.dtype == np.uint16 and a.ndim == 2 and fmt == "png":
        encoding = "16UC1"
    else:
        raise ValueError(f"compress_image: no {fmt} encoding for a {a.dtype} array of shape {a.shape}")
    if fmt == "jpeg":
        data = _encode(a, "JPEG", quality=int(jpeg_quality))
        return _message(f"{encoding}; jpeg compressed {'bgr8' if colour else 'mono8'}", data, header)
    if fmt == "png":
        data = _encode(a, "PNG", compress_level=int(png_level))
        return _message(f"{encoding}; png compressed {'bgr8' if colour else ''}", data, header)
    raise ValueError(f"compress_image: format {fmt!r} is not jpeg or png")


def depth_quantization_params(depth_max: float = DEPTH_MAX,
                              depth_quantization: float = DEPTH_QUANTIZATION) -> tuple[float, float]:
    """(A, B) of the header, in float32 arithmetic as the plugin computes them."""
    z0 = np.float32(depth_quantization)
    a = z0 * (z0 + np.float32(1.0))
    return float(a), float(np.float32(1.0) - a / np.float32(depth_max))


def depth_quantization_for(near: float, depth_max: float = DEPTH_MAX) -> float:
    """The largest depth_quantization for which depths down to `near` fit in 16 bits (the plugin's
    default 100 with depth_max 10 stops at 0.152 m: too far for the twin's close-up camera)."""
    a = 65534.0 / (1.0 / near - 1.0 / depth_max) * 0.999  # margin for float32 rounding
    return (math.sqrt(1.0 + 4.0 * a) - 1.0) / 2.0


def compress_depth(depth: np.ndarray, *, depth_max: float = DEPTH_MAX,
                   depth_quantization: float = DEPTH_QUANTIZATION, png_level: int = PNG_LEVEL,
                   header=None) -> CompressedImage:
    """`compressedDepth` transport of (H, W) float32 metres (NaN, <= 0 or >= depth_max: no
    return) as 32FC1, or of (H, W) uint16 (segmentation ids) as 16UC1, lossless."""
    d = np.asarray(depth)
    if d.ndim != 2:
        raise ValueError(f"compress_depth: expected an (H, W) image, got shape {d.shape}")
    if d.dtype == np.uint16:
        data = CONFIG_HEADER.pack(INV_DEPTH, 0.0, 0.0) + _encode(np.ascontiguousarray(d), "PNG",
                                                                  compress_level=int(png_level))
        return _message("16UC1; compressedDepth png", data, header)
    if not np.issubdtype(d.dtype, np.floating):
        raise ValueError(f"compress_depth: expected float32 metres or uint16, got {d.dtype}")
    d = d.astype(np.float32, copy=False)
    a, b = depth_quantization_params(depth_max, depth_quantization)
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        inv = np.float32(a) / d + np.float32(b)  # float32, as the C++
        valid = (d > 0) & (d < np.float32(depth_max))  # NaN compares false
    np.clip(inv, 1.0, 65535.0, out=inv)  # 1: a valid depth never reads as "no return"
    inv[~valid] = 0.0
    data = CONFIG_HEADER.pack(INV_DEPTH, a, b) + _encode(inv.astype(np.uint16), "PNG", compress_level=int(png_level))
    return _message("32FC1; compressedDepth png", data, header)


__all__ = ["CONFIG_HEADER", "DEPTH_MAX", "DEPTH_QUANTIZATION", "INV_DEPTH", "JPEG_QUALITY", "PNG_LEVEL",
           "compress_depth", "compress_image", "depth_quantization_for", "depth_quantization_params"]
