"""Sample patterns from Python: siproject.sample_positions against the
grid's own positions, its seeds, the Sobol' pattern's stratification, its
errors; a render named by its pattern's metadata (written by OpenEXR's own
module) projected by the module and by siproject equals the values
projected at sample_positions(), bit for bit."""

import math
import os
import subprocess

import numpy as np
import OpenEXR
import pytest

import siproject

SIPROJECT = os.environ.get("SIPROJECT", "siproject")


def test_shape_and_the_regular_grid():
    p = siproject.sample_positions("regular", size=(7, 5), rays_per_pixel=9)
    assert p.shape == (21 * 15, 2) and p.dtype == np.float64
    i, l = np.meshgrid(np.arange(21), np.arange(15))
    assert np.array_equal(p[:, 0], ((i.ravel() + 0.5) * 7 / 21))
    assert np.array_equal(p[:, 1], ((l.ravel() + 0.5) * 5 / 15))


def test_densities_need_not_be_squares():
    # the grid of a render at factor sqrt(2): floor(W sqrt 2 + 1/2)
    p = siproject.sample_positions("jitter", seed=1, size="10x6", rays_per_pixel=2)
    assert len(p) == math.floor(10 * math.sqrt(2) + 0.5) * math.floor(6 * math.sqrt(2) + 0.5)
    assert p[:, 0].min() > 0 and p[:, 0].max() < 10 and p[:, 1].min() > 0 and p[:, 1].max() < 6


@pytest.mark.parametrize("pattern", ["jitter", "sobol"])
def test_seeds(pattern):
    a = siproject.sample_positions(pattern, seed=4, size=12, rays_per_pixel=4)
    b = siproject.sample_positions(pattern, seed=4, size=12, rays_per_pixel=4, threads=3)
    c = siproject.sample_positions(pattern, seed=5, size=12, rays_per_pixel=4)
    assert np.array_equal(a, b)
    assert np.all(a != c)
    r = siproject.sample_positions("regular", seed=5, size=12, rays_per_pixel=4)
    assert np.array_equal(r, siproject.sample_positions("regular", size=12, rays_per_pixel=4))


def test_jitter_one_per_cell():
    p = siproject.sample_positions("jitter", seed=2, size=(6, 4), rays_per_pixel=16)
    cells = np.floor(p[:, 1] * 4).astype(int) * 24 + np.floor(p[:, 0] * 4).astype(int)
    assert np.array_equal(cells, np.arange(24 * 16))


def test_sobol_elementary_intervals():
    # 1024 rays per pixel of a 2 x 1 frame: each pixel's interval of area 2^-10 holds one
    p = siproject.sample_positions("sobol", seed=9, size=(2, 1), rays_per_pixel=1024)
    assert len(p) == 2048
    for q in range(2):
        u, v = p[1024 * q:1024 * (q + 1), 0] - q, p[1024 * q:1024 * (q + 1), 1]
        for j in range(11):
            a = np.floor(u * 2 ** j).astype(int)
            b = np.floor(v * 2 ** (10 - j)).astype(int)
            assert np.array_equal(np.bincount(b * 2 ** j + a, minlength=1024), np.ones(1024, int)), (q, j)


def test_errors():
    with pytest.raises(ValueError, match="unknown sample pattern 'halton'; known: regular, jitter, sobol"):
        siproject.sample_positions("halton", size=4, rays_per_pixel=4)
    with pytest.raises(ValueError, match="seed=-1"):
        siproject.sample_positions("jitter", seed=-1, size=4, rays_per_pixel=4)
    with pytest.raises(TypeError, match="seed=1.5"):
        siproject.sample_positions("jitter", seed=1.5, size=4, rays_per_pixel=4)
    with pytest.raises(ValueError, match="rays_per_pixel=0"):
        siproject.sample_positions("jitter", size=4, rays_per_pixel=0)
    with pytest.raises(TypeError, match="rays_per_pixel"):
        siproject.sample_positions("jitter", size=4, rays_per_pixel="4")
    with pytest.raises(ValueError, match="no sample"):
        siproject.sample_positions("jitter", size=4, rays_per_pixel=0.001)


def write_pattern_render(path, values, w, h, attributes):
    header = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage, **attributes}
    channels = {c: np.ascontiguousarray(values[:, k].reshape(h, w)) for k, c in enumerate("RGB")}
    with OpenEXR.File(header, channels) as f:
        f.write(str(path))


@pytest.mark.parametrize("lattice", ["cartesian", "hex"])
@pytest.mark.parametrize("pattern", ["regular", "jitter", "sobol"])
def test_a_pattern_render_is_its_values_at_sample_positions(tmp_path, pattern, lattice):
    W, H, r = 24, 16, 6.25  # factor 2.5: a 60 x 40 grid
    xy = siproject.sample_positions(pattern, seed=3, size=(W, H), rays_per_pixel=r)
    assert len(xy) == 60 * 40
    rng = np.random.default_rng(7)
    values = (0.5 + 0.4 * np.sin(xy[:, :1] * [0.9, 1.3, 0.4] + xy[:, 1:] * [0.3, 0.7, 1.1])
              + 0.01 * rng.standard_normal((len(xy), 3))).astype(np.float16)
    path = tmp_path / "render.exr"
    write_pattern_render(path, values, 60, 40, {"sis:pattern": pattern, "sis:pattern_seed": "3",
                                                "sis:pattern_frame": f"{W}x{H}", "sis:pattern_factor": "2.5"})
    expected = siproject.project(values, positions=xy, size=(W, H), lattice=lattice)
    assert np.array_equal(siproject.project(str(path), size=(W, H), lattice=lattice), expected)
    assert np.array_equal(siproject.project(str(path), factor=2.5, lattice=lattice), expected)
    out = tmp_path / "out.exr"
    run = subprocess.run([SIPROJECT, str(path), "-o", str(out), "--size", f"{W}x{H}", "--lattice", lattice],
                         capture_output=True, text=True)
    assert run.returncode == 0, run.stderr
    assert np.array_equal(siproject.read_image(out), expected.astype(np.float16).astype(np.float32))


def test_a_pattern_render_of_the_wrong_size_is_refused(tmp_path):
    values = np.zeros((50 * 40, 3), np.float16)
    path = tmp_path / "render.exr"
    write_pattern_render(path, values, 50, 40, {"sis:pattern": "jitter", "sis:pattern_seed": "3",
                                                "sis:pattern_frame": "24x16", "sis:pattern_factor": "2.5"})
    with pytest.raises(OSError, match="is 50 x 40 samples, but its pattern \\(jitter, frame 24x16, factor 2.5\\) has 60 x 40"):
        siproject.project(str(path), size=(24, 16))


def test_a_pattern_renders_weights_follow_its_positions_onto_the_output(tmp_path):
    # A weight channel holds each sample's area in the pattern frame's
    # pixels^2; projected onto a frame of another size, the areas scale with
    # the positions: the plain sum (which is not invariant to the weights'
    # scale) equals the file without weights, whose default is the output
    # frame's area / count. 1e-6 of the largest value: the weight channel stores the area in
    # float32 (rounded at 6e-8 relative) and the results are float32; left
    # unscaled, the weights would make the (48, 32) result 4 times smaller.
    W, H, r = 24, 16, 6.25
    xy = siproject.sample_positions("jitter", seed=2, size=(W, H), rays_per_pixel=r)
    values = (0.5 + 0.3 * np.sin(xy[:, :1] * [0.7, 1.1, 0.5] + xy[:, 1:] * [0.4, 0.9, 1.3])).astype(np.float32)
    keys = {"sis:pattern": "jitter", "sis:pattern_seed": "2", "sis:pattern_frame": f"{W}x{H}",
            "sis:pattern_factor": "2.5"}
    plain = tmp_path / "plain.exr"
    write_pattern_render(plain, values, 60, 40, keys)
    weighted = tmp_path / "weighted.exr"
    area = np.full((40, 60), W * H / len(xy), np.float32)
    header = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage, **keys}
    channels = {c: np.ascontiguousarray(values[:, k].reshape(40, 60)) for k, c in enumerate("RGB")}
    channels["weight"] = area
    with OpenEXR.File(header, channels) as f:
        f.write(str(weighted))
    for size in [(48, 32), (W, H)]:
        want = siproject.project(str(plain), size=size, rule="plain")
        got = siproject.project(str(weighted), size=size, rule="plain")
        assert np.abs(want).max() > 0.1, size
        assert np.allclose(got, want, rtol=0, atol=1e-6 * np.abs(want).max()), size
