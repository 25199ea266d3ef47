"""Adaptive rays from Python: refine() finds a busy quadrant's tiles, a
second pass of the refined pixels' extra Sobol' points projected with
refined= equals the same samples given as arrays bit for bit (on both
lattices), nothing
refined is the uniform render bit for bit, and bad budgets are refused
(docs/design.md section 17)."""

import math

import numpy as np
import OpenEXR
import pytest

import siproject

W = H = 32
TILE = 8


def busy(x, y):
    """Flat 0.5 but in the top-right quadrant, a chirp of 0.6 to 1.2 cycles
    a pixel (the C++ test's busy quadrant, at half the frame)."""
    k = 1.2 * math.pi / 45
    v = 0.5 + 0.5 * np.cos(k * (x**2 + (H - y) ** 2) * 4)
    return np.where((x >= W / 2) & (y < H / 2), v, 0.5)


def write_exr(path, values, w, h, attributes, names="RGB"):
    header = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage, **attributes}
    channels = {c: np.ascontiguousarray(values[:, k].reshape(h, w).astype(np.float32))
                for k, c in enumerate(names)}
    with OpenEXR.File(header, channels) as f:
        f.write(str(path))


def base_render(tmp_path, pattern="sobol", rays=4):
    xy = siproject.sample_positions(pattern, seed=0, size=(W, H), rays_per_pixel=rays)
    v = busy(xy[:, 0], xy[:, 1])
    values = np.stack([v, 0.8 * v, 0.6 * v], axis=1)
    s = int(math.isqrt(rays))
    path = tmp_path / f"base-{pattern}.exr"
    write_exr(path, values, W * s, H * s, {"sis:pattern": pattern, "sis:pattern_seed": "0",
                                           "sis:pattern_frame": f"{W}x{H}", "sis:pattern_factor": str(s)})
    return path, xy, values


def extra_positions(plan):
    """The refined pixels' points base .. rays - 1 of their own sequence, in
    the refinement's order (tiles, their pixels row by row, the points)."""
    r, b = plan["rays"], plan["base_rays"]
    fine = siproject.sample_positions("sobol", seed=0, size=(W, H), rays_per_pixel=r).reshape(W * H, r, 2)
    cols = (W + TILE - 1) // TILE
    out = []
    for t in plan["tiles"]:
        tx, ty = t % cols, t // cols
        for y in range(ty * TILE, min(H, (ty + 1) * TILE)):
            for x in range(tx * TILE, min(W, (tx + 1) * TILE)):
                out.append(fine[y * W + x, b:])
    return np.concatenate(out)


def test_refine_finds_the_busy_quadrant_and_refined_projects_both_passes(tmp_path):
    base, xy, values = base_render(tmp_path)
    # 4 tiles of 64 pixels to 64 rays: 4 + 4 x 64 x 60 / 1024 = 19 rays per pixel
    plan = siproject.refine(base, rays=19, refine_rays=64, threads=1)
    assert plan["tiles"] == [2, 3, 6, 7]
    assert plan["rays"] == 64 and plan["base_rays"] == 4 and plan["tile"] == 8
    assert plan["extra_rays"] == 4 * 64 * 60 and plan["rays_per_pixel"] == 19
    assert plan["estimates"].shape == (4, 4)
    assert plan["text"].startswith("sis-refinement 1\npattern sobol\nseed 0\nframe 32x32\n")
    ex = extra_positions(plan)
    assert len(ex) == plan["extra_rays"]
    v = busy(ex[:, 0], ex[:, 1])
    ev = np.stack([v, 0.8 * v, 0.6 * v], axis=1)
    gw = 64  # the second pass's rows: as wide as the base's grid
    second = tmp_path / "second.exr"
    write_exr(second, ev, gw, len(ev) // gw, {"sis:refinement": plan["text"]})
    lattices = {"cartesian": dict(generator="cubic"),
                "hex": dict(lattice="hex", generator="hex-quartic")}
    got = {name: siproject.project(base, refined=second, size=(W, H), threads=1, **kw)
           for name, kw in lattices.items()}
    # the same samples as arrays: the base's then the extra rays, each
    # weighing 1/64 in a refined pixel and 1/4 elsewhere (values through
    # float32, as the files hold them)
    refined = np.zeros((H, W), bool)
    for t in plan["tiles"]:
        refined[(t // 4) * 8:(t // 4 + 1) * 8, (t % 4) * 8:(t % 4 + 1) * 8] = True
    px = np.minimum(xy.astype(int), [W - 1, H - 1])
    w = np.where(refined[px[:, 1], px[:, 0]], 1 / 64, 1 / 4)
    allv = np.concatenate([values, ev]).astype(np.float32)
    for name, kw in lattices.items():
        want = siproject.project(allv, positions=np.concatenate([xy, ex]),
                                 weights=np.concatenate([w, np.full(len(ex), 1 / 64)]),
                                 size=(W, H), threads=1, **kw)
        assert np.array_equal(got[name], want), name


def test_nothing_refined_is_the_uniform_render_bit_for_bit(tmp_path):
    base, _, _ = base_render(tmp_path)
    plan = siproject.refine(base, rays=4)
    assert plan["tiles"] == [] and plan["extra_rays"] == 0 and plan["rays_per_pixel"] == 4
    none = tmp_path / "none.exr"
    write_exr(none, np.zeros((1, 1)), 1, 1, {"sis:refinement": plan["text"]}, names=["none"])
    for method in ("min-error", "conventional"):
        a = siproject.project(base, refined=none, size=(W, H), method=method, generator="tent")
        b = siproject.project(base, size=(W, H), method=method, generator="tent")
        assert np.array_equal(a, b)


def test_bad_budgets_and_renders_are_refused(tmp_path):
    base, _, _ = base_render(tmp_path)
    with pytest.raises(ValueError, match=r"rays=3\): a budget of 3 rays per pixel is below the base pattern's 4"):
        siproject.refine(base, rays=3)
    with pytest.raises(ValueError, match="not both"):
        siproject.refine(base, rays=8, refine_rays=16, share=0.5)
    with pytest.raises(ValueError, match=r"share=1\.5\): a share of 1\.5: expected \(0, 1\]"):
        siproject.refine(base, rays=8, share=1.5)
    with pytest.raises(ValueError, match="tile=0"):
        siproject.refine(base, rays=8, tile=0)
    with pytest.raises(ValueError, match="unknown estimator 'mean'"):
        siproject.refine(base, rays=8, estimator="mean")
    jitter, _, _ = base_render(tmp_path, "jitter")
    with pytest.raises(OSError, match="a jitter render: refinement adds sobol points"):
        siproject.refine(jitter, rays=8)
    with pytest.raises(OSError, match="no sis:refinement attribute"):
        siproject.project(base, refined=jitter, size=(W, H))
