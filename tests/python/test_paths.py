"""Paths the C++ library would have cut short, and coefficient files in
formats that cannot hold them: refused by the library, so that the module
gets the same refusals as siproject."""
import os

import numpy as np
import pytest

import siproject


def flat(tmp_path, name="in.exr"):
    path = os.path.join(tmp_path, name)
    siproject.write_image(path, np.full((12, 16, 3), 0.25, np.float32))
    return path


def test_paths_holding_nul_are_refused(tmp_path):
    # "a.exr\0.png" was opened as a.exr (C strings end at the NUL); written,
    # it made a file of another name
    good = flat(tmp_path, "a.exr")
    cut = good + "\0.png"
    for call in (lambda: siproject.project(cut, factor=2),
                 lambda: siproject.coefficients(cut, factor=2),
                 lambda: siproject.load(cut),
                 lambda: siproject.read_image(cut)):
        with pytest.raises(OSError, match=r"a\.exr\\0\.png: a file name cannot hold a NUL"):
            call()
    image = siproject.read_image(good)
    k = siproject.coefficients(good, factor=2)
    for call in (lambda: siproject.write_image(good + "\0.png", image),
                 lambda: k.save(os.path.join(tmp_path, "k.exr\0.png"))):
        with pytest.raises(OSError, match=r"\\0\.png: a file name cannot hold a NUL"):
            call()
    assert sorted(os.listdir(tmp_path)) == ["a.exr"]


def test_coefficient_files_only_as_openexr(tmp_path):
    # k.hdr and k.fits were written without their metadata, negative
    # coefficients clamped to 0, and reported no error: a ValueError with
    # siproject's message, as for 8-bit formats
    k = siproject.coefficients(flat(tmp_path), factor=2)
    for ext in ("hdr", "fits", "tif", "png"):
        with pytest.raises(ValueError, match=rf"k\.{ext}: coefficient files are OpenEXR"):
            k.save(os.path.join(tmp_path, "k." + ext))
    assert sorted(os.listdir(tmp_path)) == ["in.exr"]


def test_channel_counts_the_output_format_cannot_hold(tmp_path):
    # a 2-channel DPX ended the interpreter (an assertion in OpenImageIO)
    two = np.full((8, 8, 2), 0.5, np.float32)
    with pytest.raises(OSError, match=r"o\.dpx: DPX output holds 1, 3 or 4 channels, not 2"):
        siproject.write_image(os.path.join(tmp_path, "o.dpx"), two)
    assert os.listdir(tmp_path) == []
