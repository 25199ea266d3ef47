#!/usr/bin/env python3
"""Pyramids against maketx and splineops (make compare-mip [QUICK=1]; docs/studies.md).

For each scene, from one render at --factor of a --res frame: the levels
0..L-1 by siproject (min-error box, tent, cubic: the levels `siproject --mip`
writes, bit for bit; tests/test_mip.cpp) against maketx's levels of the same
render (its default box filter, --filter lanczos3, and lanczos3 with
--hicomp, its highlight compensation: the range compressed before the
filter and expanded after; maketx's level log2(factor) + j has level j's
size) and against splineops' least-squares cubic resize of the same render
to each level's size (scripts/splineops_resize.py, one process per level:
degree 3 interpolation, analysis and synthesis; its output of the render's
sample type, half, as maketx's).

splineops' geometry is not the level's: it maps the first and last samples
of a line onto the first and last output samples (scale (M - 1) / (N - 1)),
so its M output samples sit at x_m = x0 + m h with x0 = W / (2 N) (the
render's first sample) and h = W (N - 1) / (N (M - 1)) (W = M level pixels,
N the render's samples), not at the pixel centres (m + 1/2). Its output
samples are the samples, at that lattice, of its continuous least-squares
spline sum c_m beta3((x - x0) / h - m) with c extended by whole-sample
symmetry about the end samples (splineops' boundary); that spline is the
cubic interpolating spline of the output on the lattice (same extension),
and its continuous L2 error is measured in that geometry. The script checks
the geometry on a ramp and the extension against splineops' own cubic
interpolation (mip.json: splineops_geometry) before measuring.

Measures per level:
  l2       continuous L2 error (RMS over the frame; the zone plate at 8 * 2^j
           points per level-j pixel and axis) of the approximation
           against the truth: the zone plate's closed form, else the render
           at --ref-factor. siproject: its level's coefficients. maketx: its
           level's pixels as a piecewise-constant image (the box space; a
           texture lookup with closest texels). splineops: its cubic spline
           on its own lattice (above), evaluated at every point of the truth
           (the points siproject.l2_error uses, border 0, every channel);
           the same evaluator applied to siproject's cubic coefficients
           (lattice (m + 1/2), half-sample symmetric extension) must give
           siproject.l2_error's value to 1e-6 relative (mip.json:
           evaluator_check).
  shown    RMS of the displayed level against the truth's area averages over
           each pixel of the level (the reference render at --ref-factor
           projected onto the box space, an exact area average). splineops'
           displayed level is its output samples, which sit on its own
           lattice, not at the level's pixel centres: this measure compares
           grids misaligned by up to half a pixel at the borders (x_0 and
           x_{M-1} are W / (2 N) from the frame's edges, the centres 1/2).
  negative samples below zero in the displayed level.
  best     diagnostic: the truth's own least-squares projection onto the
           cubic splines of siproject's lattice and of splineops' (both
           extensions as above), the least error each space allows.
  l2_inside  diagnostic, siproject cubic and splineops, levels of 64 pixels
           and more: l2 without the 8 level pixels along each edge (where
           the two lattices and extensions differ most), checked as above.
and the time and peak memory (RSS) of the whole pyramid: `siproject --mip`
against `maketx` and `maketx --filter lanczos3` from the same render
(medians of --repeat runs, /usr/bin/time); splineops per level (one
splineops_resize.py process each: start-up and reading the render each
time), summed over the levels (peak: the largest level's).
Writes REPORT/mip.md and REPORT/mip.json.
"""
import argparse
import json
import math
import os
import statistics
import subprocess
import sys

import numpy as np
import scipy.linalg
import scipy.sparse
from scipy.interpolate import BSpline
from scipy.ndimage import spline_filter1d

import siproject
from renders import zp_k  # noqa: E402  (the Makefile's ZP_K)


# --- cubic splines on a lattice, evaluated at the truth's points -------------
# s(x) = sum_m c_m beta3((x - x0) / h - m), m in [0, n), c extended beyond by
# whole-sample symmetry (c[-m] = c[m], splineops') or half-sample symmetry
# (c[-1 - m] = c[m], siproject's mirror).


def fold(index, n, whole):
    """The coefficient index that the extension puts at `index`."""
    if n == 1:
        return np.zeros_like(index)
    period = 2 * n - 2 if whole else 2 * n
    r = np.mod(index, period)
    return np.where(r >= n, period - r - (0 if whole else 1), r)


def axis_matrix(points, n, x0, h, whole):
    """Sparse (len(points), n): row i evaluates the spline of n coefficients
    on the lattice x0 + m h (extension `whole` or half-sample) at points[i]."""
    pad = 4
    u = (np.asarray(points, dtype=np.float64) - x0) / h
    if u.min() < 1 - pad or u.max() > n + pad - 2:
        raise ValueError("axis_matrix(): points beyond the padded lattice")
    knots = np.arange(-pad - 2, n + pad + 2, dtype=np.float64)  # basis i centred at i - pad
    b = scipy.sparse.csr_matrix(BSpline.design_matrix(u, knots, 3))
    rows = np.arange(n + 2 * pad)
    f = scipy.sparse.csr_matrix((np.ones(rows.size), (rows, fold(rows - pad, n, whole))),
                                shape=(rows.size, n))
    return (b @ f).tocsr()


class Truth:
    """The truth's sample points and values in row bands, over a frame of
    w x h level pixels: the reference render's samples, or the zone plate's
    closed form at `spp` points per pixel and axis (as siproject.l2_error);
    with `border`, only the points in [border, w - border] x [border, h -
    border] (as siproject.l2_error's border)."""

    def __init__(self, w, h, channels, reference=None, K=None, spp=None, border=0):
        self.w, self.h, self.C, self.ref, self.K = w, h, channels, reference, K
        nx, ny = ((reference.shape[1], reference.shape[0]) if reference is not None
                  else (max(1, round(w * spp)), max(1, round(h * spp))))
        px = (np.arange(nx) + 0.5) * w / nx
        py = (np.arange(ny) + 0.5) * h / ny
        ix = np.flatnonzero((px >= border) & (px <= w - border))
        iy = np.flatnonzero((py >= border) & (py <= h - border))
        self.x0, self.y0 = ix[0], iy[0]
        self.px, self.py = px[ix], py[iy]

    def rows(self, r0, r1):
        if self.ref is not None:
            return self.ref[self.y0 + r0:self.y0 + r1, self.x0:self.x0 + self.px.size]
        u = self.px / self.w - 0.5
        v = self.py[r0:r1] / self.h - 0.5
        f = 0.5 + 0.5 * np.cos(self.K * (u[None, :] ** 2 + v[:, None] ** 2))
        return np.repeat(f[:, :, None], self.C, axis=2)

    def bands(self, band=256):
        for r0 in range(0, self.py.size, band):
            r1 = min(self.py.size, r0 + band)
            yield r0, r1, self.rows(r0, r1)


def spline_l2(coef, lattice, whole, truth):
    """RMS over every truth point and channel of spline - truth; lattice
    ((x0, hx), (y0, hy)) in level pixels, coef (rows, columns, channels)."""
    ny, nx, C = coef.shape
    (x0, hx), (y0, hy) = lattice
    bx = axis_matrix(truth.px, nx, x0, hx, whole)
    by = axis_matrix(truth.py, ny, y0, hy, whole)
    c = np.asarray(coef, dtype=np.float64)
    g = (bx @ c.transpose(1, 0, 2).reshape(nx, ny * C)).reshape(truth.px.size, ny, C)
    g = np.ascontiguousarray(g.transpose(1, 0, 2)).reshape(ny, truth.px.size * C)
    total = 0.0
    for r0, r1, f in truth.bands():
        d = by[r0:r1] @ g
        d -= f.reshape(r1 - r0, -1)
        total += float(np.einsum("ij,ij->", d, d))
    return math.sqrt(total / (truth.px.size * truth.py.size * C))


def best_l2(n, lattice, whole, truth):
    """The least RMS error of any spline on the lattice (n x n coefficients):
    the truth's least-squares projection, from its acquisition a = By' F Bx
    and the Gram matrices: error^2 = (sum f^2 - <c, a>) / count."""
    (x0, hx), (y0, hy) = lattice
    bx = axis_matrix(truth.px, n[0], x0, hx, whole)
    by = axis_matrix(truth.py, n[1], y0, hy, whole)
    C = truth.C
    z = np.zeros((n[1], truth.px.size * C))
    energy = 0.0
    for r0, r1, f in truth.bands():
        f = np.asarray(f, dtype=np.float64).reshape(r1 - r0, -1)
        z += by[r0:r1].T @ f
        energy += float(np.einsum("ij,ij->", f, f))
    gx = scipy.linalg.cho_factor((bx.T @ bx).toarray())
    gy = scipy.linalg.cho_factor((by.T @ by).toarray())
    z = z.reshape(n[1], truth.px.size, C)
    cross = 0.0
    for ch in range(C):
        a = np.asarray(bx.T @ z[:, :, ch].T).T  # By' F Bx, (ny, nx)
        c = scipy.linalg.cho_solve(gy, scipy.linalg.cho_solve(gx, a.T).T)
        cross += float(np.sum(c * a))
    return math.sqrt(max(0.0, energy - cross) / (truth.px.size * truth.py.size * C))


def splineops_lattice(M, N, W):
    """(x0, h) of splineops' M output samples from N input samples over W
    level pixels: endpoint-aligned, the render's first and last samples (a
    single output is the line's mean: a constant, placed at the centre)."""
    step = W / N
    return (0.5 * step, step * (N - 1) / (M - 1)) if M > 1 else (0.5 * W, 1.0)


def splineops_coefficients(samples):
    """The cubic interpolating spline's coefficients of splineops' output on
    its lattice, whole-sample symmetric (scipy's mode 'mirror')."""
    c = spline_filter1d(np.asarray(samples, dtype=np.float64), order=3, axis=0, mode="mirror")
    return spline_filter1d(c, order=3, axis=1, mode="mirror")


def check_splineops_geometry():
    """splineops' lattice and extension, checked on 1-D lines: a ramp of 4096
    samples resized to 64 (endpoint-aligned: m * 65 in the middle, pixel
    centres would give 64 m + 31.5), and the interpolating spline of 9
    random samples (this script's evaluator, whole-sample extension) against
    splineops' own cubic interpolation of them at 97 endpoint-aligned points."""
    from splineops.resize import resize_degrees
    N, M = 4096, 64
    ramp = resize_degrees(np.arange(N, dtype=np.float64), output_size=(M,), interp_degree=3,
                          analy_degree=3, synthe_degree=3)
    middle = (31, 32)
    rng = np.random.default_rng(1)
    s = rng.random(9)
    fine = resize_degrees(s, output_size=(97,), interp_degree=3, analy_degree=-1, synthe_degree=3)
    c = spline_filter1d(s, order=3, mode="mirror")
    ours = axis_matrix(np.arange(97) * 8 / 96, 9, 0.0, 1.0, True) @ c
    r = {"ramp_4096_to_64": {str(m): float(ramp[m]) for m in middle},
         "endpoint_aligned": {str(m): m * (N - 1) / (M - 1) for m in middle},
         "pixel_centres": {str(m): (m + 0.5) * N / M - 0.5 for m in middle},
         "interpolation_max_difference": float(np.abs(ours - fine).max())}
    if (max(abs(ramp[m] - m * (N - 1) / (M - 1)) for m in middle) > 1e-6
            or r["interpolation_max_difference"] > 1e-9):
        sys.exit(f"compare_mip.py: splineops' geometry is not as assumed: {r}")
    return r


INSIDE = 8  # level pixels left out along each edge by the inside diagnostic (levels of 64 pixels and more)


def run(cmd, **kw):
    return subprocess.run(cmd, check=True, **kw)


def render(args, scene, res, factor):
    path = os.path.join(args.out, "render", f"{scene}-{res}-f{factor}.exr")
    run(["make", "-s", "render", f"SCENE={scene}", f"RES={res}", f"FACTOR={factor}",
         f"OUT={args.out}", "PREBUILT=1"], stdout=subprocess.DEVNULL)
    return path


def shown_command(cmd):
    """cmd as the report prints it: paths inside the working folder relative."""
    here = os.getcwd() + os.sep
    return " ".join(os.path.relpath(c) if c.startswith(here) else c for c in cmd)


def timed(cmd):
    """(seconds, peak RSS in MiB) of one run."""
    r = subprocess.run(["/usr/bin/time", "-f", "%e %M"] + cmd, check=True,
                       stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    e, m = r.stderr.strip().splitlines()[-1].split()
    return float(e), float(m) / 1024


def sizes(w, h):
    out = [(w, h)]
    while w > 1 or h > 1:
        w, h = max(1, w // 2), max(1, h // 2)
        out.append((w, h))
    return out


def db(a, b):
    return 20 * math.log10(b / a) if a > 0 and b > 0 else float("nan")


def main():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--scenes", default="objects zoneplate checker")
    p.add_argument("--res", type=int, default=1024)
    p.add_argument("--factor", type=int, default=8)
    p.add_argument("--ref-factor", type=int, default=32)
    p.add_argument("--levels", type=int, default=6)
    p.add_argument("--repeat", type=int, default=3)
    p.add_argument("--siproject", default="build/tools/siproject")
    p.add_argument("--maketx", default="maketx")
    p.add_argument("--splineops", default=os.path.join(os.path.dirname(os.path.abspath(__file__)), "splineops_resize.py"),
                   help="splineops' least-squares resize as a command (run with this Python)")
    p.add_argument("--out", default="out")
    p.add_argument("--work", default="out/compare-mip")
    p.add_argument("--report", default="out/report/mip")
    args = p.parse_args()
    os.makedirs(args.work, exist_ok=True)
    os.makedirs(args.report, exist_ok=True)
    F, R = args.factor, args.res
    shift = int(round(math.log2(F)))
    if 2 ** shift != F:
        sys.exit("compare_mip.py: --factor must be a power of 2 (maketx's levels halve the render)")
    levels = sizes(R, R)[: args.levels]
    ours = [("box", "centred"), ("tent", "centred"), ("tent", "2x2"), ("cubic", "centred"), ("cubic", "2x2")]
    results = {"command": " ".join(sys.argv), "res": R, "factor": F, "ref_factor": args.ref_factor,
               "levels": levels, "splineops_geometry": check_splineops_geometry(), "scenes": {}}
    spl = "splineops least-squares cubic"
    for scene in args.scenes.split():
        src = render(args, scene, R, F)
        ref_path = render(args, scene, R, args.ref_factor)
        ref = siproject.Reference(siproject.read_image(ref_path)) if scene != "zoneplate" else None
        K = zp_k(R) if scene == "zoneplate" else None

        def l2(k, j):
            # the closed form at 8 * 2^j points per level-j pixel and axis:
            # the same points over the frame at every level
            return (siproject.l2_error(k, zoneplate=K, samples_per_pixel=8 * 2 ** j) if K
                    else siproject.l2_error(k, ref))

        tx = {}
        for name, extra in (("maketx box", []), ("maketx lanczos3", ["--filter", "lanczos3"]),
                            ("maketx lanczos3 --hicomp", ["--filter", "lanczos3", "--hicomp"])):
            out = os.path.join(args.work, f"{scene}-{'-'.join(name.split()[1:]).strip('-')}.tx.exr")
            run([args.maketx, src, "-o", out] + extra, stdout=subprocess.DEVNULL)
            tx[name] = out
        # splineops' levels: one process per level, timed (its output is measured below)
        sp_levels, sp_timing = {}, {}
        for j, (w, h) in enumerate(levels):
            out = os.path.join(args.work, f"{scene}-splineops-{j}.exr")
            cmd = [sys.executable, args.splineops, src, "-o", out, "--size", f"{w}x{h}"]
            runs = [timed(cmd) for _ in range(args.repeat)]
            sp_levels[j] = out
            sp_timing[j] = {"seconds": statistics.median(r[0] for r in runs),
                            "peak_mib": statistics.median(r[1] for r in runs), "command": shown_command(cmd)}
        src_w, src_h = siproject.read_image(src).shape[1::-1]  # N: the render's samples per axis
        rows, check, best = {}, {}, {}
        for j, (w, h) in enumerate(levels):
            area = siproject.project(ref_path, size=(w, h), generator="box", display="centred")
            row = {}
            for gen, disp in ours:
                k = siproject.coefficients(src, size=(w, h), generator=gen)
                shown = siproject.project(src, size=(w, h), generator=gen, display=disp)
                row[f"siproject {gen} {disp}"] = {
                    "l2": l2(k, j), "shown": float(np.sqrt(np.mean((shown - area) ** 2))),
                    "negative": int((shown < 0).sum())}
                if gen == "cubic" and disp == "centred":
                    cubic = k
            C = cubic.array.shape[2]
            truth = (Truth(w, h, C, reference=ref.array) if ref is not None
                     else Truth(w, h, C, K=K, spp=8 * 2 ** j))
            # the spline evaluator against siproject.l2_error on siproject's cubic level
            ours_geometry = ((0.5, 1.0), (0.5, 1.0))
            e = spline_l2(cubic.array, ours_geometry, False, truth)
            e0 = row["siproject cubic centred"]["l2"]
            check[j] = {"l2_error": e0, "evaluated": e, "relative": (e - e0) / e0}
            if abs(e - e0) > 1e-6 * e0:
                sys.exit(f"compare_mip.py: the spline evaluator gives {e} for siproject's cubic level {j}, "
                         f"siproject.l2_error {e0}")
            sp = siproject.read_image(sp_levels[j])
            assert sp.shape[:2] == (h, w), (spl, j, sp.shape)
            sp_geometry = (splineops_lattice(w, src_w, w), splineops_lattice(h, src_h, h))
            row[spl] = {"l2": spline_l2(splineops_coefficients(sp), sp_geometry, True, truth),
                        "shown": float(np.sqrt(np.mean((sp - area) ** 2))),
                        "negative": int((sp < 0).sum()),
                        "lattice": {"x0": sp_geometry[0][0], "h": sp_geometry[0][1]}}
            best[j] = {"siproject's lattice": best_l2((w, h), ours_geometry, False, truth),
                       "splineops' lattice": best_l2((w, h), sp_geometry, True, truth)}
            del truth
            if min(w, h) >= 8 * INSIDE:
                # diagnostic: the same errors without the INSIDE pixels along each edge
                inside = (Truth(w, h, C, reference=ref.array, border=INSIDE) if ref is not None
                          else Truth(w, h, C, K=K, spp=8 * 2 ** j, border=INSIDE))
                e0 = (siproject.l2_error(cubic, zoneplate=K, samples_per_pixel=8 * 2 ** j, border=INSIDE) if K
                      else siproject.l2_error(cubic, ref.array, border=INSIDE))
                e = spline_l2(cubic.array, ours_geometry, False, inside)
                check[j]["inside"] = {"l2_error": e0, "evaluated": e, "relative": (e - e0) / e0}
                if abs(e - e0) > 1e-6 * e0:
                    sys.exit(f"compare_mip.py: the spline evaluator gives {e} for siproject's cubic level {j} "
                             f"inside, siproject.l2_error {e0}")
                row["siproject cubic centred"]["l2_inside"] = row["siproject cubic 2x2"]["l2_inside"] = e0
                row[spl]["l2_inside"] = spline_l2(splineops_coefficients(sp), sp_geometry, True, inside)
                del inside
            for name, path in tx.items():
                lvl = os.path.join(args.work, f"{scene}-level.exr")
                run(["oiiotool", path, "--selectmip", str(shift + j), "-d", "float", "-o", lvl])
                img = siproject.read_image(lvl)
                assert img.shape[:2] == (h, w), (name, j, img.shape)
                k = siproject.coefficients(img, factor=1, generator="box")  # the pixels, as they are
                row[name] = {"l2": l2(k, j), "shown": float(np.sqrt(np.mean((img - area) ** 2))),
                             "negative": int((img < 0).sum())}
            rows[j] = row
        timing = {}
        mip = os.path.join(args.work, f"{scene}-mip.exr")
        for name, cmd in (("siproject --mip (cubic, 2x2)", [args.siproject, src, "-o", mip, "--factor", str(F), "--mip", "-q"]),
                          ("siproject --mip --generator box --display centred",
                           [args.siproject, src, "-o", mip, "--factor", str(F), "--mip", "-q", "--generator", "box", "--display", "centred"]),
                          ("maketx", [args.maketx, src, "-o", tx["maketx box"]]),
                          ("maketx --filter lanczos3", [args.maketx, src, "-o", tx["maketx lanczos3"], "--filter", "lanczos3"]),
                          ("maketx --filter lanczos3 --hicomp",
                           [args.maketx, src, "-o", tx["maketx lanczos3 --hicomp"], "--filter", "lanczos3", "--hicomp"])):
            runs = [timed(cmd) for _ in range(args.repeat)]
            timing[name] = {"seconds": statistics.median(r[0] for r in runs),
                            "peak_mib": statistics.median(r[1] for r in runs), "command": " ".join(cmd)}
        timing[f"splineops_resize.py, levels 0-{len(levels) - 1} (sum of one process per level)"] = {
            "seconds": sum(t["seconds"] for t in sp_timing.values()),
            "peak_mib": max(t["peak_mib"] for t in sp_timing.values()),
            "command": shown_command([sys.executable, args.splineops, src, "-o",
                                      os.path.join(args.work, f"{scene}-splineops-J.exr"), "--size", "WxH"])}
        results["scenes"][scene] = {"render": src, "truth": f"zoneplate K={K}" if K else ref_path,
                                    "levels": rows, "timing": timing, "splineops_timing": sp_timing,
                                    "evaluator_check": check, "best_in_space": best}
        del ref
    with open(os.path.join(args.report, "mip.json"), "w") as f:
        json.dump(results, f, indent=1)
    write_md(results, os.path.join(args.report, "mip.md"))


def checks(c):
    """A level's evaluator checks: the whole frame's and the inside's."""
    return [c] + ([c["inside"]] if "inside" in c else [])


def write_md(res, path):
    L = []
    L.append(f"# Pyramids: siproject's min-error levels against maketx and splineops\n")
    L.append(f"`{res['command']}`: {res['res']} x {res['res']} frame, render at factor {res['factor']}, "
             f"truth at factor {res['ref_factor']} (zone plate: its closed form).\n")
    for scene, s in res["scenes"].items():
        L.append(f"## {scene}\n")
        names = list(s["levels"][0].keys())
        for key, what in (("l2", "continuous L2 error (RMS over the frame)"),
                          ("shown", "displayed level against the truth's area averages (RMS)")):
            L.append(f"{what}:\n")
            L.append("| method | " + " | ".join(f"level {j} ({w}x{h})" for j, (w, h) in enumerate(res["levels"])) + " |")
            L.append("| --- |" + " --- |" * len(res["levels"]))
            for n in names:
                L.append(f"| {n} | " + " | ".join(f"{s['levels'][j][n][key]:.5f}" for j in range(len(res["levels"]))) + " |")
            L.append("")
        spl = "splineops least-squares cubic"
        L.append(f"`{spl}`'s samples sit on its own lattice (endpoint-aligned: x0 + m h, "
                 f"level 0: x0 = {s['levels'][0][spl]['lattice']['x0']:.4f}, h = {s['levels'][0][spl]['lattice']['h']:.5f} "
                 f"pixels), not at the level's pixel centres: its continuous L2 error is its cubic spline's on that "
                 "lattice, and its displayed level is compared with area averages over grids misaligned by up to "
                 "half a pixel at the borders.\n")
        L.append("The least continuous L2 error in each cubic space (the truth's own least-squares projection; a diagnostic):\n")
        L.append("| lattice | " + " | ".join(f"level {j}" for j in range(len(res["levels"]))) + " |")
        L.append("| --- |" + " --- |" * len(res["levels"]))
        for n in s["best_in_space"][0]:
            L.append(f"| {n} | " + " | ".join(f"{s['best_in_space'][j][n]:.5f}" for j in range(len(res["levels"]))) + " |")
        L.append("")
        withi = [j for j in range(len(res["levels"])) if "l2_inside" in s["levels"][j][spl]]
        if withi:
            L.append(f"Continuous L2 error without the {INSIDE} pixels along each edge (levels of {8 * INSIDE} "
                     "pixels and more; a diagnostic of the borders):\n")
            L.append("| method | " + " | ".join(f"level {j}" for j in withi) + " |")
            L.append("| --- |" + " --- |" * len(withi))
            for n in ("siproject cubic 2x2", spl):
                L.append(f"| {n} | " + " | ".join(f"{s['levels'][j][n]['l2_inside']:.5f}" for j in withi) + " |")
            L.append("")
        L.append("Evaluator check (the spline evaluator on siproject's cubic coefficients against siproject.l2_error), "
                 "largest relative difference: "
                 f"{max(abs(c['relative']) for j in range(len(res['levels'])) for c in checks(s['evaluator_check'][j])):.1e}\n")
        L.append("Goal checks (continuous L2, dB = 20 log10(other / cubic); cubic is `siproject cubic`'s coefficients):\n")
        L.append("| level | cubic vs maketx box (dB) | cubic vs maketx lanczos3 (dB) | "
                 "cubic vs lanczos3 --hicomp (dB) | cubic vs splineops (dB) | >= 1 dB vs box | better than lanczos3 |")
        L.append("| --- | --- | --- | --- | --- | --- | --- |")
        for j in range(len(res["levels"])):
            r = s["levels"][j]
            c = r["siproject cubic 2x2"]["l2"]
            a, b = db(c, r["maketx box"]["l2"]), db(c, r["maketx lanczos3"]["l2"])
            hc = db(c, r["maketx lanczos3 --hicomp"]["l2"])
            so = db(c, r[spl]["l2"])
            L.append(f"| {j} | {a:+.2f} | {b:+.2f} | {hc:+.2f} | {so:+.2f} | {'yes' if a >= 1 else 'no'} | "
                     f"{'yes' if b > 0 else 'no'} |")
        L.append("")
        L.append("Negative samples in the displayed levels (all levels): " + ", ".join(
            f"{n} {sum(s['levels'][j][n]['negative'] for j in range(len(res['levels'])))}" for n in names) + "\n")
        L.append("Whole pyramid (median of runs, wall seconds and peak RSS):\n")
        L.append("| command | seconds | peak MiB |")
        L.append("| --- | --- | --- |")
        for n, t in s["timing"].items():
            L.append(f"| `{t['command']}` | {t['seconds']:.2f} | {t['peak_mib']:.0f} |")
        L.append("")
        L.append("splineops per level (one `splineops_resize.py` process each; median of runs):\n")
        L.append("| level | size | seconds | peak MiB |")
        L.append("| --- | --- | --- | --- |")
        for j, (w, h) in enumerate(res["levels"]):
            t = s["splineops_timing"][j]
            L.append(f"| {j} | {w}x{h} | {t['seconds']:.2f} | {t['peak_mib']:.0f} |")
        L.append("")
    with open(path, "w") as f:
        f.write("\n".join(L) + "\n")


if __name__ == "__main__":
    main()
