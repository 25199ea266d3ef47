"""Integer samples are display-encoded: a flat grey of 128 written by
oiiotool or Pillow as an 8- or 16-bit TIFF, a PNG or a JPEG, or held as a
uint8 or uint16 array, is decoded as sRGB, projected and encoded again to
128. Arrays and files follow one rule (the library's), so an array gives the
same image as the file that holds it; input_transfer / --input-transfer
states another transfer."""

import json
import os
import subprocess

import numpy as np
import pytest
from PIL import Image

import siproject

SIPROJECT = os.environ.get("SIPROJECT", "siproject")

W, H = 40, 32
GREY16 = 128 * 257  # the 16-bit code of 128 / 255


def srgb_to_linear(v):
    """IEC 61966-2-1, written out here (not the library's)."""
    v = np.asarray(v, np.float64)
    return np.where(v <= 0.04045, v / 12.92, ((v + 0.055) / 1.055) ** 2.4)


LINEAR_128 = float(srgb_to_linear(128 / 255))  # 0.2158605...


def oiiotool(*args):
    subprocess.run(["oiiotool", *map(str, args)], check=True, capture_output=True)


def run(*args):
    r = subprocess.run([SIPROJECT, *map(str, args), "-q"], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    return r


@pytest.fixture(scope="module")
def greys(tmp_path_factory):
    """Flat 128 files by their writer and format: name -> (path, bits)."""
    d = tmp_path_factory.mktemp("transfer")
    files = {}
    pattern = ["--pattern", f"constant:color={128 / 255:.10f},{128 / 255:.10f},{128 / 255:.10f}",
               f"{W}x{H}", "3"]
    for name, ext, bits in [("oiio8.tif", "tif", 8), ("oiio16.tif", "tif", 16),
                            ("oiio8.png", "png", 8), ("oiio16.png", "png", 16),
                            ("oiio8.jpg", "jpg", 8)]:
        oiiotool(*pattern, "-d", f"uint{bits}", "-o", d / name)
        files[name] = (d / name, bits)
    rgb = np.full((H, W, 3), 128, np.uint8)
    for name, fmt in [("pil8.tif", "TIFF"), ("pil8.png", "PNG"), ("pil8.jpg", "JPEG")]:
        Image.fromarray(rgb).save(d / name, fmt, **({"quality": 95} if fmt == "JPEG" else {}))
        files[name] = (d / name, 8)
    # Pillow's 16-bit greyscale TIFF
    Image.fromarray(np.full((H, W), GREY16, np.uint16)).save(d / "pil16.tif", "TIFF")
    files["pil16.tif"] = (d / "pil16.tif", 16)
    return d, files


@pytest.mark.parametrize("name", ["oiio8.tif", "oiio16.tif", "oiio8.png", "oiio16.png",
                                  "oiio8.jpg", "pil8.tif", "pil16.tif", "pil8.png", "pil8.jpg"])
def test_flat_128_stays_128_through_siproject(greys, name):
    d, files = greys
    path, bits = files[name]
    # the input holds 128 (JPEG's flat blocks included: a DC term only),
    # read in linear light
    np.testing.assert_allclose(siproject.read_image(path), LINEAR_128, rtol=1e-6)
    out = d / (name + ".out.png")
    run(path, "-o", out, "--factor", "2", "-d", "uint8")
    got = np.asarray(Image.open(out))
    # Exact: the projection reproduces a constant to float rounding (1e-6
    # relative), far inside the half code step (0.5 / 255 in encoded units)
    # that would move the 8-bit value.
    assert got.shape[:2] == (H // 2, W // 2)
    assert np.all(got == 128), (name, np.unique(got))
    if bits == 16:  # by default a 16-bit input gives a 16-bit output: 128 * 257
        out16 = d / (name + ".out16.png")
        run(path, "-o", out16, "--factor", "2")
        info = subprocess.run(["oiiotool", "--info", out16], capture_output=True, text=True).stdout
        assert "uint16 png" in info, info
        with Image.open(out16) as im:
            if im.mode.startswith("I"):  # Pillow reads 16-bit greyscale as it is
                assert np.all(np.asarray(im) == GREY16), (name, np.unique(np.asarray(im)))
    # the linear result is the decoded grey
    exr = d / (name + ".out.exr")
    run(path, "-o", exr, "--factor", "2", "-d", "float")
    lin = siproject.read_image(exr)
    np.testing.assert_allclose(lin, LINEAR_128, rtol=2e-6)
    info = subprocess.run(["oiiotool", "--info", "-v", exr], capture_output=True, text=True).stdout
    assert 'sis:input_transfer: "srgb"' in info


def test_input_transfer_linear_and_iscolorspace(greys):
    d, files = greys
    path, _ = files["oiio8.tif"]
    for opts, want, name in [(["--input-transfer", "linear"], 128 / 255, "linear"),
                             (["--iscolorspace", "linear"], 128 / 255, "linear"),
                             (["--iscolorspace", "sRGB"], LINEAR_128, "srgb"),
                             (["--input-transfer", "gamma2.2"], (128 / 255) ** 2.2, "gamma2.2")]:
        out = d / "stated.exr"
        run(path, "-o", out, "--factor", "2", "-d", "float", *opts)
        np.testing.assert_allclose(siproject.read_image(out), want, rtol=2e-6)
        info = subprocess.run(["oiiotool", "--info", "-v", out], capture_output=True,
                              text=True).stdout
        assert f'sis:input_transfer: "{name}"' in info
    r = subprocess.run([SIPROJECT, path, "-o", d / "x.exr", "--factor", "2",
                        "--input-transfer", "log"], capture_output=True, text=True)
    assert r.returncode == 2 and "--input-transfer 'log'" in r.stderr
    assert not (d / "x.exr").exists()


def test_file_tags_are_followed(greys):
    """A PNG tagged linear (gAMA 1.0) is linear; one tagged Gamma2.2 a power."""
    d, _ = greys
    grey = f"{128 / 255:.10f}"
    for tag, want in [("Linear", 128 / 255), ("Gamma2.2", (128 / 255) ** 2.2)]:
        png = d / f"tagged-{tag}.png"
        oiiotool("--pattern", f"constant:color={grey},{grey},{grey}", f"{W}x{H}", "3",
                 "-d", "uint8", "--attrib", "oiio:ColorSpace", tag, "-o", png)
        out = d / "tagged.exr"
        run(png, "-o", out, "--factor", "2", "-d", "float")
        np.testing.assert_allclose(siproject.read_image(out), want, rtol=2e-6)


@pytest.mark.parametrize("dtype,code,file", [(np.uint8, 128, "oiio8.png"),
                                             (np.uint16, GREY16, "oiio16.png")])
def test_integer_arrays_are_what_files_are(greys, dtype, code, file):
    d, files = greys
    a = np.full((H, W, 3), code, dtype)
    got = siproject.project(a, factor=2)
    # the same rule as the file that holds these samples, bit for bit
    by_path = siproject.project(files[file][0], factor=2)
    np.testing.assert_array_equal(got, by_path)
    np.testing.assert_allclose(got, LINEAR_128, rtol=2e-6)
    out = d / f"array-{np.dtype(dtype).name}.png"
    siproject.write_image(out, got)
    assert np.all(np.asarray(Image.open(out)) == 128)
    # stated linear: the scaled codes themselves
    lin = siproject.project(a, factor=2, input_transfer="linear")
    np.testing.assert_allclose(lin, code / np.iinfo(dtype).max, rtol=2e-6)
    k = siproject.coefficients(a, factor=2, input_transfer="linear")
    np.testing.assert_allclose(k.resample(), lin, rtol=1e-6)


def test_photo_array_range(greys):
    """A Pillow RGB image as numpy holds it: the result lies in [0, 1] as the
    file's does (the projection's overshoot aside), not in [0, 255]."""
    d, _ = greys
    y, x = np.mgrid[0:64, 0:64]
    rgb = np.stack([(x * 4) % 256, (y * 4) % 256, ((x + y) * 2) % 256], -1).astype(np.uint8)
    Image.fromarray(rgb).save(d / "photo.png")
    a = np.asarray(Image.open(d / "photo.png"))
    got = siproject.project(a, factor=2)
    np.testing.assert_array_equal(got, siproject.project(d / "photo.png", factor=2))
    assert got.min() > -0.2 and got.max() < 1.2


def test_other_integer_arrays_refused():
    with pytest.raises(ValueError, match="int64"):
        siproject.project(np.full((8, 8, 3), 1, np.int64), factor=2)


SIMETRICS = os.environ.get("SIMETRICS", "simetrics")


@pytest.mark.parametrize("name", ["oiio8.tif", "oiio16.png", "pil8.png", "pil16.tif"])
def test_read_image_is_linear_light(greys, name):
    """read_image decodes integer files as siproject's inputs are decoded:
    a flat 128 reads as sRGB's 128 / 255 in linear light, and writing it back
    to an 8-bit PNG gives 128 again."""
    path, _ = greys[1][name]
    a = siproject.read_image(path)
    np.testing.assert_allclose(a, LINEAR_128, rtol=1e-6)


def test_integer_arrays_written_as_they_mean(tmp_path):
    """write_image of a uint8 or uint16 array writes what the samples mean: an
    8-bit PNG holds the same codes, an EXR the linear values, and a
    read_image -> write_image round trip of a PNG keeps every code."""
    codes = np.arange(256, dtype=np.uint8).reshape(16, 16)
    siproject.write_image(tmp_path / "u8.png", codes)
    assert np.array_equal(np.asarray(Image.open(tmp_path / "u8.png")), codes)
    siproject.write_image(tmp_path / "u8.exr", codes)
    np.testing.assert_allclose(siproject.read_image(tmp_path / "u8.exr")[:, :, 0],
                               srgb_to_linear(codes / 255.0), rtol=2e-6, atol=1e-9)
    siproject.write_image(tmp_path / "again.png", siproject.read_image(tmp_path / "u8.png"))
    assert np.array_equal(np.asarray(Image.open(tmp_path / "again.png")), codes)
    words = (np.arange(256, dtype=np.uint16) * 257).reshape(16, 16)
    siproject.write_image(tmp_path / "u16.png", words, dtype="uint16")
    assert np.array_equal(np.asarray(Image.open(tmp_path / "u16.png")), words)


def test_measures_of_integer_arrays_are_the_files(greys, tmp_path):
    """The measures take uint8 arrays as the files that hold them: the same
    numbers as the images read from those files, and as simetrics prints."""
    rng = np.random.default_rng(11)
    a = rng.integers(0, 256, (H, W, 3), dtype=np.uint8)
    b = np.clip(a.astype(int) + rng.integers(-9, 10, a.shape), 0, 255).astype(np.uint8)
    Image.fromarray(a).save(tmp_path / "a.png")
    Image.fromarray(b).save(tmp_path / "b.png")
    fa, fb = siproject.read_image(tmp_path / "a.png"), siproject.read_image(tmp_path / "b.png")
    assert siproject.rms_difference(a, b) == siproject.rms_difference(fa, fb)
    assert siproject.psnr(a, b) == siproject.psnr(fa, fb)
    assert siproject.highpass_share(a) == siproject.highpass_share(fa)
    assert siproject.rms_difference(a, b) > 0.01  # in linear light, not codes 0..255 (about 5)
    r = subprocess.run([SIMETRICS, tmp_path / "a.png", "--reference", tmp_path / "b.png",
                        "--json"], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    assert json.loads(r.stdout)["rms"] == pytest.approx(siproject.rms_difference(a, b), rel=1e-12)
