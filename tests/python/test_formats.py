"""write_image's sample types, compression and quality, as siproject's -d,
--compression and --quality: 16-bit PNG and TIFF equal to an sRGB encoding
computed here (numpy, read back by Pillow), a 16-bit input made by Pillow
kept 16-bit by siproject, compressions reported by the file, and the
refusals as one-line ValueErrors that leave no file."""

import os
import subprocess

import numpy as np
import OpenEXR
import pytest
from PIL import Image

import siproject

SIPROJECT = os.environ.get("SIPROJECT", "siproject")


def srgb_encode(v):
    """IEC 61966-2-1 in float64, written out here (not the library's)."""
    v = np.clip(np.asarray(v, np.float64), 0.0, 1.0)
    return np.where(v <= 0.0031308, 12.92 * v, 1.055 * v ** (1 / 2.4) - 0.055)


def ramp(h=24, w=40):
    y, x = np.mgrid[0:h, 0:w]
    return (1.1 * (x + 0.5) / w + 0.003 * y).astype(np.float32)[:, :, np.newaxis]


def test_uint16_png_and_tiff_equal_an_independent_srgb_encoding(tmp_path):
    # one channel: Pillow reads 16-bit greyscale PNG and TIFF as they are
    result = siproject.project(ramp(48, 80), factor=2)
    want = np.round(65535 * srgb_encode(result[:, :, 0]))
    for ext in ("png", "tif"):
        path = tmp_path / f"o.{ext}"
        siproject.write_image(path, result, dtype="uint16")
        with Image.open(path) as im:
            assert im.mode in ("I;16", "I;16B", "I"), (ext, im.mode)
            got = np.asarray(im).astype(np.float64)
        # the encoder works in float: within a few float ulps (0.01 of a
        # 16-bit step) of the float64 encoding, so a value that close to a
        # rounding midpoint may round the other way, by one step, rarely
        assert np.abs(got - want).max() <= 1, ext
        assert np.mean(got == want) >= 0.97, ext
        assert (result > 1).any()  # clamping is part of it
    # numpy's dtype spelling is the same request
    siproject.write_image(tmp_path / "n.png", result, dtype=np.uint16)
    with Image.open(tmp_path / "n.png") as a, Image.open(tmp_path / "o.png") as b:
        assert np.array_equal(np.asarray(a), np.asarray(b))


def test_float_and_half_tiff_hold_the_exr_samples(tmp_path):
    result = siproject.project(ramp(), factor=2)
    siproject.write_image(tmp_path / "f.tif", result, dtype="float")
    with Image.open(tmp_path / "f.tif") as im:
        assert im.mode == "F"
        assert np.array_equal(np.asarray(im), result[:, :, 0])
    siproject.write_image(tmp_path / "h.exr", result, dtype=np.float16)
    with OpenEXR.File(str(tmp_path / "h.exr")) as f:
        (channel,) = f.channels().values()
        assert channel.pixels.dtype == np.float16
        assert np.array_equal(channel.pixels, result[:, :, 0].astype(np.float16))


def test_a_16_bit_input_made_by_pillow_stays_16_bit(tmp_path):
    codes = np.tile(np.linspace(1000, 64000, 64).astype(np.uint16), (48, 1))
    src = tmp_path / "in16.png"
    Image.fromarray(codes).save(src)  # numpy's uint16 -> a 16-bit greyscale PNG
    for ext in ("png", "tif"):
        out = tmp_path / f"o.{ext}"
        r = subprocess.run([SIPROJECT, str(src), "-o", str(out), "--factor", "2"],
                           capture_output=True, text=True)
        assert r.returncode == 0 and r.stderr == "", r.stderr
        with Image.open(out) as im:
            assert im.mode in ("I;16", "I;16B", "I"), (ext, im.mode)
            assert np.asarray(im).max() > 255  # 16-bit codes, not 8-bit ones
    r = subprocess.run([SIPROJECT, str(src), "-o", str(tmp_path / "o.jpg"), "--factor", "2"],
                       capture_output=True, text=True)
    assert r.returncode == 0
    assert "warning: the input's 16-bit samples are written 8-bit" in r.stderr


def test_compression_as_asked(tmp_path):
    img = np.random.default_rng(3).random((32, 48, 3)).astype(np.float32)
    for comp in ("zip", "piz", "dwaa:45"):
        path = tmp_path / f"{comp.replace(':', '-')}.exr"
        siproject.write_image(path, img, compression=comp)
        with OpenEXR.File(str(path)) as f:
            assert f.header()["compression"].name == comp.split(":")[0].upper() + "_COMPRESSION"
    for q in (50, 95):
        siproject.write_image(tmp_path / f"q{q}.jpg", img, quality=q)
    assert os.path.getsize(tmp_path / "q50.jpg") < os.path.getsize(tmp_path / "q95.jpg")


@pytest.mark.parametrize("name,keywords,message", [
    ("o.jpg", dict(dtype="uint16"), r"^dtype='uint16': .*o\.jpg: JPEG output holds uint8 samples, not uint16$"),
    ("o.exr", dict(dtype="uint8"), r"^dtype='uint8': .*o\.exr: OpenEXR output holds half or float samples"),
    ("o.png", dict(dtype="int8"), r"^dtype='int8': expected \"uint8\", \"uint16\", \"half\" or \"float\"$"),
    ("o.png", dict(half=True, dtype="uint16"), r"^half=True and dtype='uint16': give one$"),
    ("o.png", dict(half=True), r"^half=True: .*o\.png: PNG output holds uint8 or uint16 samples, not half$"),
    ("o.png", dict(compression="zip"), r"^compression='zip': .*o\.png: PNG output takes compression default"),
    ("o.exr", dict(compression="zip:50"), r"^compression='zip:50': .*OpenEXR compression zip takes a quality 1 to 9"),
    ("o.exr", dict(compression="lzw"), r"^compression='lzw': .*OpenEXR output takes compression zip"),
    ("o.bmp", dict(quality=80), r"^quality=80: .*o\.bmp: BMP output takes no compression or quality$"),
    ("o.jpg", dict(quality=0), r"^quality=0: expected 1 to 100$"),
    ("o.jpg", dict(quality=101), r"^quality=101: expected 1 to 100$"),
])
def test_refusals_are_one_line_value_errors_and_leave_no_file(tmp_path, name, keywords, message):
    with pytest.raises(ValueError, match=message) as e:
        siproject.write_image(tmp_path / name, np.zeros((8, 8, 3), np.float32), **keywords)
    assert "\n" not in str(e.value)
    assert not list(tmp_path.iterdir())
