"""cressim_ros.image_compression against image_transport's formats (Jazzy), decoded independently:
PNG by the reader below (zlib + the PNG filters, RFC 2083), JPEG by Pillow, compressedDepth by the
plugin's decode (12-byte header, d = A / (n - B), 0 = no return)."""
import io
import struct
import zlib

import numpy as np
import pytest

pytest.importorskip("sensor_msgs.msg")
from PIL import Image as PILImage  # noqa: E402

from cressim_ros.image_compression import (compress_depth, compress_image, depth_quantization_for,  # noqa: E402
                                           depth_quantization_params)

H, W = 30, 40


def read_png(data: bytes):
    """(array, bit depth, colour type) of a non-interlaced greyscale or RGB PNG."""
    assert data[:8] == b"\x89PNG\r\n\x1a\n"
    pos, idat, ihdr = 8, b"", None
    while pos < len(data):
        n, kind = struct.unpack(">I4s", data[pos:pos + 8])
        body = data[pos + 8:pos + 8 + n]
        assert zlib.crc32(kind + body) == struct.unpack(">I", data[pos + 8 + n:pos + 12 + n])[0]
        if kind == b"IHDR":
            ihdr = struct.unpack(">IIBBBBB", body)
        elif kind == b"IDAT":
            idat += body
        pos += 12 + n
    w, h, bits, ctype, _, _, interlace = ihdr
    assert interlace == 0
    channels = {0: 1, 2: 3}[ctype]
    bpp, stride = channels * bits // 8, w * channels * bits // 8
    raw, prev, rows = zlib.decompress(idat), bytearray(stride), []
    for y in range(h):
        kind, line = raw[y * (stride + 1)], bytearray(raw[y * (stride + 1) + 1:(y + 1) * (stride + 1)])
        for i in range(stride):
            a = line[i - bpp] if i >= bpp else 0
            b, c = prev[i], (prev[i - bpp] if i >= bpp else 0)
            if kind == 4:
                p = a + b - c
                pa, pb, pc = abs(p - a), abs(p - b), abs(p - c)
                pred = a if pa <= pb and pa <= pc else (b if pb <= pc else c)
            else:
                pred = (0, a, b, (a + b) // 2)[kind]
            line[i] = (line[i] + pred) & 0xFF
        rows.append(bytes(line))
        prev = line
    image = np.frombuffer(b"".join(rows), ">u2" if bits == 16 else np.uint8).reshape(h, w, channels)
    return (image[..., 0] if channels == 1 else image), bits, ctype


def decode_depth(msg):
    """The compressedDepth plugin's decode of a 32FC1 message."""
    fmt, a, b = struct.unpack("<iff", bytes(msg.data[:12]))
    assert fmt == 0  # INV_DEPTH
    n, bits, ctype = read_png(bytes(msg.data[12:]))
    assert (bits, ctype) == (16, 0)
    n = n.astype(np.float64)
    with np.errstate(divide="ignore"):
        return np.where(n > 0, a / (n - b), np.nan), (a, b)


def rgb_test_image():
    y, x = np.mgrid[0:H, 0:W]
    image = np.stack([x * 255 // (W - 1), y * 255 // (H - 1), (x + y) * 3], -1).astype(np.uint8)
    image[:8, :8] = (255, 0, 0)  # red, to catch a swapped channel order
    image[-8:, -8:] = (0, 0, 255)
    return image


def test_jpeg_colour_is_a_standard_jpeg_with_the_plugins_format():
    image = rgb_test_image()
    msg = compress_image(image)
    assert msg.format == "rgb8; jpeg compressed bgr8"
    data = bytes(msg.data)
    assert data[:2] == b"\xff\xd8" and data[-2:] == b"\xff\xd9"
    decoded = np.asarray(PILImage.open(io.BytesIO(data)))
    assert decoded.shape == image.shape
    err = np.abs(decoded.astype(int) - image).max(axis=-1)
    smooth = np.ones((H, W), bool)
    smooth[:10, :10] = smooth[-10:, -10:] = False  # 4:2:0 chroma smears the patches' edges
    assert err[smooth].mean() < 3 and err[smooth].max() < 12  # quality 95
    r, g, b = decoded[3, 3].astype(int)
    assert r > 200 and g < 60 and b < 60, decoded[3, 3]
    r, g, b = decoded[-3, -3].astype(int)
    assert b > 200 and r < 60, decoded[-3, -3]
    assert len(compress_image(image, jpeg_quality=30).data) < len(msg.data)


def test_png_colour_and_mono_are_exact():
    image = rgb_test_image()
    msg = compress_image(image, "png")
    assert msg.format == "rgb8; png compressed bgr8"
    decoded, bits, ctype = read_png(bytes(msg.data))
    assert (bits, ctype) == (8, 2) and np.array_equal(decoded, image)
    mono = image[..., 1].copy()
    msg = compress_image(mono, "png", png_level=9)
    assert msg.format == "mono8; png compressed "  # the plugin's trailing space
    decoded, bits, ctype = read_png(bytes(msg.data))
    assert (bits, ctype) == (8, 0) and np.array_equal(decoded, mono)


def test_jpeg_mono_is_one_channel():
    mono = rgb_test_image()[..., 1].copy()
    msg = compress_image(mono)
    assert msg.format == "mono8; jpeg compressed mono8"
    decoded = PILImage.open(io.BytesIO(bytes(msg.data)))
    assert decoded.mode == "L"
    assert np.abs(np.asarray(decoded).astype(int) - mono).max() < 20


def test_header_is_copied_and_bad_inputs_refused():
    from std_msgs.msg import Header
    header = Header(frame_id="camera_color_optical_frame")
    header.stamp.sec, header.stamp.nanosec = 12, 345
    msg = compress_image(rgb_test_image(), header=header)
    assert (msg.header.frame_id, msg.header.stamp.sec, msg.header.stamp.nanosec) == (header.frame_id, 12, 345)
    with pytest.raises(ValueError):
        compress_image(np.zeros((H, W), np.float32))
    with pytest.raises(ValueError):
        compress_image(rgb_test_image(), "tiff")
    with pytest.raises(ValueError):
        compress_image(np.zeros((H, W), np.uint16))  # 16-bit: png only
    with pytest.raises(ValueError):
        compress_depth(np.zeros((H, W, 1), np.float32))


def _step(d, a):
    """One quantisation step at depth d: the plugin truncates n, so d <= decoded < d + step."""
    return d * d / (a - d)


@pytest.mark.parametrize("near, depth_max", [(0.01, 5.0), (0.05, 10.0)])
def test_depth_round_trip_within_one_quantisation_step(near, depth_max):
    q = depth_quantization_for(near, depth_max)
    depth = np.full((H, W), np.nan, np.float32)
    for row, d in enumerate((near, 0.1, 0.5, 2.0)):
        depth[row * 5:row * 5 + 5] = d + np.linspace(0, 0.01 * d, W, dtype=np.float32)
    depth[25, :8] = (0.0, -1.0, np.inf, -np.inf, depth_max, 2 * depth_max, np.nan, np.nan)
    msg = compress_depth(depth, depth_max=depth_max, depth_quantization=q)
    assert msg.format == "32FC1; compressedDepth png"
    decoded, (a, b) = decode_depth(msg)
    assert (a, b) == pytest.approx(depth_quantization_params(depth_max, q))
    valid = np.isfinite(depth) & (depth > 0) & (depth < depth_max)
    assert np.array_equal(np.isnan(decoded), ~valid)  # NaN, 0, < 0, inf, >= depth_max: no return
    d, got = depth[valid].astype(np.float64), decoded[valid]
    assert np.all(got >= d * (1 - 1e-6))
    assert np.all(got - d <= _step(d, a) * 1.01 + 1e-9), np.max((got - d) / _step(d, a))
    for probe in (0.1, 0.5, 2.0):
        at = np.abs(d - probe) < 1e-6
        assert at.any() and np.all(np.abs(got[at] - probe) <= _step(probe, a) * 1.01)


def test_depth_with_the_plugins_defaults():
    depth = np.full((H, W), 0.5, np.float32)
    depth[0, 0], depth[0, 1] = 2.0, 0.1  # 0.1 m is closer than the defaults can code (0.152 m)
    decoded, (a, b) = decode_depth(compress_depth(depth))
    assert (a, b) == (10100.0, -1009.0)  # q (q + 1), 1 - A / depth_max with q = 100, depth_max = 10
    assert abs(decoded[0, 0] - 2.0) <= _step(2.0, a) and abs(decoded[1, 1] - 0.5) <= _step(0.5, a)
    assert decoded[0, 1] == pytest.approx(a / (65535 - b))  # clamped to the nearest depth it can code


def test_labels_16uc1_are_exact():
    labels = (np.arange(H * W).reshape(H, W) % 17).astype(np.uint16)
    labels[0, :3] = (0, 255, 65535)
    msg = compress_depth(labels)
    assert msg.format == "16UC1; compressedDepth png"
    assert struct.unpack("<iff", bytes(msg.data[:12])) == (0, 0.0, 0.0)
    decoded, bits, ctype = read_png(bytes(msg.data[12:]))
    assert (bits, ctype) == (16, 0) and np.array_equal(decoded, labels)
    msg = compress_image(labels, "png")  # the `compressed` transport takes 16UC1 as png too
    assert msg.format == "16UC1; png compressed "
    assert np.array_equal(read_png(bytes(msg.data))[0], labels)
