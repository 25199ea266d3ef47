"""siproject.pyramid: every level of a min-error pyramid, as siproject --mip
forms them. Levels at maketx's sizes, each level project()'s own image at
that size bit for bit, a flat image flat at every level, a pyramid's
coefficient file evaluated again, and the requests a pyramid cannot meet
refused naming pyramid()."""

import os
import subprocess

import numpy as np
import pytest

import siproject

SIPROJECT = os.environ.get("SIPROJECT", "siproject")


def render(h=84, w=148, c=3, seed=5):
    rng = np.random.default_rng(seed)
    y, x = np.mgrid[0:h, 0:w].astype(np.float64)
    img = np.empty((h, w, c), np.float32)
    for ch in range(c):
        img[:, :, ch] = 0.5 + 0.3 * np.sin(x / (3 + ch)) * np.cos(y / 5) + 0.1 * rng.random((h, w))
    return img


def test_levels_have_maketxs_sizes():
    # 148 x 84 at factor 4 is 37 x 21; maketx's levels of 37 x 21 (floor of
    # each side halved, down to 1 x 1) are written out here by hand.
    levels = siproject.pyramid(render(), factor=4)
    shapes = [a.shape for a in levels]
    assert shapes == [(21, 37, 3), (10, 18, 3), (5, 9, 3), (2, 4, 3), (1, 2, 3), (1, 1, 3)]
    assert all(a.dtype == np.float32 for a in levels)


@pytest.mark.parametrize("generator", ["cubic", "tent", "box"])
def test_every_level_is_its_own_projection(generator):
    img = render()
    levels = siproject.pyramid(img, factor=4, generator=generator, threads=2)
    assert np.array_equal(levels[0], siproject.project(img, factor=4, generator=generator))
    for a in levels[1:]:
        h, w = a.shape[:2]
        direct = siproject.project(img, size=(w, h), generator=generator, threads=1)
        assert np.array_equal(a, direct), (generator, a.shape)


def test_a_flat_image_is_flat_at_every_level():
    flat = np.full((64, 96), 0.25, np.float32)
    levels = siproject.pyramid(flat, factor=2)
    assert [a.shape for a in levels] == [(32, 48), (16, 24), (8, 12), (4, 6), (2, 3), (1, 1)]
    for a in levels:
        # Min-error reproduces constants; the float32 result and the FFT's
        # rounding leave a few units in the last place of 0.25 (2^-24 each).
        assert np.max(np.abs(a - 0.25)) < 1e-6, a.shape


def test_a_pyramids_coefficient_file_gives_the_levels_again(tmp_path):
    src = tmp_path / "in.exr"
    img = render()
    siproject.write_image(str(src), img)
    r = subprocess.run([SIPROJECT, str(src), "-o", str(tmp_path / "t.exr"), "--mip", "--factor", "4",
                        "--coeffs", str(tmp_path / "k.exr")], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    from_file = siproject.pyramid(str(tmp_path / "k.exr"))
    from_samples = siproject.pyramid(str(src), factor=4)
    assert [a.shape for a in from_file] == [a.shape for a in from_samples]
    for a, b in zip(from_file, from_samples):
        # The file keeps the coefficients in float (as every coefficient
        # file does): the levels agree to float32 rounding of coefficients
        # of size about 1, propagated through a few taps of the display.
        assert np.max(np.abs(a - b)) < 1e-5, a.shape


def test_what_a_pyramid_cannot_do_is_refused(tmp_path):
    img = render()
    with pytest.raises(ValueError, match="larger than the image"):
        siproject.pyramid(img, factor=1000)
    one_level = tmp_path / "k1.exr"
    siproject.coefficients(img, factor=4).save(str(one_level))
    with pytest.raises(ValueError, match=r"^pyramid\(\): .*coefficient file of one level"):
        siproject.pyramid(str(one_level))
    with pytest.raises(TypeError):
        siproject.pyramid(img, factor=4, lattice="hex")
    with pytest.raises(TypeError):
        siproject.pyramid(img, factor=4, positions=np.zeros((3, 2)))
    with pytest.raises(ValueError, match="generator"):
        siproject.pyramid(img, factor=4, generator="nope")
