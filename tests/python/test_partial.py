"""Partials from Python (siproject.partial) merged by siproject.merge and by
siproject --merge: the single run's bits for every split and order, from
arrays, band files and whole files; splits that overlap, leave a gap or
differ in options refused."""

import os
import random
import subprocess

import numpy as np
import OpenEXR
import pytest

import siproject

SIPROJECT = os.environ.get("SIPROJECT", "siproject")
SIZE = (40, 175)  # 700 rows: three bands of 256 rows, the last of 188


def grid(h=700, w=160, c=3, seed=3):
    rng = np.random.default_rng(seed)
    y, x = np.mgrid[0:h, 0:w].astype(np.float64)
    img = np.empty((h, w, c), np.float32)
    for ch in range(c):
        img[:, :, ch] = 0.4 + 0.3 * np.sin(x / (4 + ch)) * np.cos(y / 9) + 0.1 * rng.random((h, w))
    return img


def write_band(path, rows, first_row, height):
    """A band render as oiiotool --crop leaves it: the data window the band's
    rows, the display window the whole grid (OpenEXR's own writer)."""
    h, w, _ = rows.shape
    header = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage,
              "dataWindow": (np.array((0, first_row), np.int32), np.array((w - 1, first_row + h - 1), np.int32)),
              "displayWindow": (np.array((0, 0), np.int32), np.array((w - 1, height - 1), np.int32))}
    channels = {n: np.ascontiguousarray(rows[:, :, c]) for c, n in enumerate("RGB")}
    with OpenEXR.File(header, channels) as f:
        f.write(str(path))


@pytest.mark.parametrize("parts", [1, 2, 3])
@pytest.mark.parametrize("options", [{}, dict(generator="tent", boundary="periodic"),
                                     dict(lattice="hex", density=1.5)],
                         ids=["cubic", "tent periodic", "hex"])
def test_parts_merged_in_any_order_equal_the_single_run_bit_for_bit(tmp_path, parts, options):
    img = grid()
    single = siproject.coefficients(img, size=SIZE, **options)
    cuts = siproject.band_cuts(img.shape[0], parts)
    assert cuts[0] == 0 and cuts[-1] == img.shape[0] and len(cuts) == parts + 1
    paths = []
    for t in range(parts):
        path = tmp_path / f"part{t}.exr"
        siproject.partial(img, path, rows=(cuts[t], cuts[t + 1] - cuts[t]), size=SIZE, **options)
        paths.append(path)
    random.Random(parts).shuffle(paths)
    k = siproject.merge(paths)
    assert np.array_equal(k.array, single.array)
    assert k.lattice == single.lattice and k.channel_names == single.channel_names
    assert np.array_equal(k.resample(), siproject.project(img, size=SIZE, **options))


def test_bands_rows_grid_rows_files_and_siproject_agree(tmp_path):
    img = grid()
    H = img.shape[0]
    single = siproject.project(img, size=SIZE)
    whole = tmp_path / "whole.exr"
    siproject.write_image(whole, img)
    band0, band1 = tmp_path / "band0.exr", tmp_path / "band1.exr"
    write_band(band0, img[:256], 0, H)
    write_band(band1, img[256:512], 256, H)
    a, b, c, d = (tmp_path / f"{n}.exr" for n in "abcd")
    siproject.partial(band0, a, size=SIZE)                               # a band file: its rows
    siproject.partial(img[256:512], b, bands=(1, 1), grid_rows=H, size=SIZE)  # an array of its rows
    siproject.partial(whole, c, bands=(2, 1), size=SIZE)                 # a whole file's last band
    k = siproject.merge([c, a, b])
    assert np.array_equal(k.resample(), single)
    # siproject --partial of the band file makes what partial() made of it
    r = subprocess.run([SIPROJECT, band1, "--partial", "-o", d, "--size", "40x175"],
                       capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    assert np.array_equal(siproject.merge([a, d, c]).array, k.array)
    # and siproject --merge of the module's partials writes the same image
    out = tmp_path / "merged.exr"
    r = subprocess.run([SIPROJECT, "--merge", b, c, a, "-o", out], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    assert np.array_equal(siproject.read_image(out), single)


def test_splits_that_overlap_leave_a_gap_or_differ_are_refused(tmp_path):
    img = grid()
    p = {n: tmp_path / f"{n}.exr" for n in ("b0", "b12", "b1", "b2", "other")}
    siproject.partial(img, p["b0"], bands=(0, 1), size=SIZE)
    siproject.partial(img, p["b12"], bands=(1, 2), size=SIZE)
    siproject.partial(img, p["b1"], bands=(1, 1), size=SIZE)
    siproject.partial(img, p["b2"], rows=(512, 188), size=SIZE)
    siproject.partial(img, p["other"], bands=(1, 2), size=SIZE, generator="quadratic")
    assert np.array_equal(siproject.merge([p["b0"], p["b1"], p["b2"]]).array,
                          siproject.coefficients(img, size=SIZE).array)
    with pytest.raises(ValueError, match=r"no partial holds band 2 \(rows 512 to 699 of 700\): a gap"):
        siproject.merge([p["b0"], p["b1"]])
    with pytest.raises(ValueError, match=r"b1\.exr and .*b12\.exr both hold band 1 .*partials that overlap"):
        siproject.merge([p["b0"], p["b12"], p["b1"]])
    with pytest.raises(ValueError, match=r"other\.exr: a partial of another request than .*sis:generator"):
        siproject.merge([p["b0"], p["other"]])
    with pytest.raises(ValueError, match=r"is not a partial file"):
        plain = tmp_path / "plain.exr"
        siproject.write_image(plain, img)
        siproject.merge([plain])


BAD = [
    (dict(bands=(0, 1), rows=(0, 256)), r"give bands=\(first, count\) or rows=\(first, count\), not both"),
    (dict(bands=(2, 2)), r"bands=\(2, 2\): the grid of 700 rows has 3 bands of 256 rows \(0 to 2\)"),
    (dict(bands=(-1, 1)), r"bands=\(-1, 1\): the grid of 700 rows has 3 bands"),
    (dict(rows=(600, 200)), r"rows=\(600, 200\): the grid has 700 rows"),
    (dict(rows=(100, 300)), r"array: rows 100 to 399 of 700 are not whole bands of 256 rows"),
    (dict(rows=(0, 300)), r"rows 0 to 299 of 700 are not whole bands"),
    (dict(grid_rows=900), r"grid_rows=900: the array holds the rows bands= or rows= names; give one"),
    (dict(bands=(1, 1), grid_rows=900), r"grid_rows=900: the array holds 700 rows, not the 256 of bands=\(1, 1\)"),
]


@pytest.mark.parametrize("keywords,message", BAD, ids=[m[:40] for _, m in BAD])
def test_bad_partial_requests_are_one_line_value_errors(tmp_path, keywords, message):
    out = tmp_path / "p.exr"
    with pytest.raises(ValueError, match=message) as e:
        siproject.partial(grid(), out, size=SIZE, **keywords)
    assert "\n" not in str(e.value)
    assert not out.exists() and list(tmp_path.iterdir()) == []


def test_partial_files_and_outputs_are_checked(tmp_path):
    img = grid()
    with pytest.raises(ValueError, match=r"out=.*p\.png: partial files are OpenEXR \(\.exr\)"):
        siproject.partial(img, tmp_path / "p.png", size=SIZE)
    band = tmp_path / "band1.exr"
    write_band(band, img[256:512], 256, img.shape[0])
    with pytest.raises(ValueError, match=r"band1\.exr: bands=\(0, 1\) names rows 0 to 255; the file holds rows 256 to 511"):
        siproject.partial(band, tmp_path / "p.exr", bands=(0, 1), size=SIZE)
    with pytest.raises(ValueError, match=r"grid_rows=: a file's display window gives its grid"):
        siproject.partial(band, tmp_path / "p.exr", bands=(1, 1), grid_rows=700, size=SIZE)
    with pytest.raises(ValueError, match=r"give the output size"):
        siproject.partial(img, tmp_path / "p.exr")
    with pytest.raises(TypeError, match=r"bands=3: expected \(first, count\)"):
        siproject.partial(img, tmp_path / "p.exr", bands=3, size=SIZE)
    with pytest.raises(ValueError, match=r"merge\(\): no partial file"):
        siproject.merge([])
    with pytest.raises(TypeError, match=r"paths='a\.exr': expected a sequence of paths"):
        siproject.merge("a.exr")
    assert not (tmp_path / "p.exr").exists()


def test_band_cuts_are_siprojects():
    r = subprocess.run([SIPROJECT, "--band-cuts", "5000,7"], capture_output=True, text=True)
    assert r.returncode == 0
    assert siproject.band_cuts(5000, 7) == [int(v) for v in r.stdout.split()]
    with pytest.raises(ValueError, match=r"700 rows in 4 parts of whole bands of 256 rows: from 1 to 3 parts"):
        siproject.band_cuts(700, 4)
