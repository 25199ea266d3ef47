#!/usr/bin/env python3
"""Adaptive rays (make compare-adaptive): which estimator finds the tiles
where min-error cubic errs, and the error against rays per pixel of uniform
sobol rays and of adaptive ones.

Every sample set here is a subset of one sobol render of 64 rays per pixel
(make SAMPLES=sobol FACTOR=8): a pixel's first n points of its own
scrambled sequence are the sobol pattern's at n rays per pixel (sis/pattern.h),
and a refined tile's rays are the base's and the extra points of the same
sequence (sis/refinement.h), so uniform renders of 4 to 64 rays per pixel and
adaptive ones of any tiles are all read from it, ray for ray. The base is
checked against the factor-2 sobol render, which make SAMPLES=adaptive
refines. Errors: the continuous L2 error of min-error cubic (the fit) against
the regular reference render at --ref-factor, border --border pixels.

The oracle: per 8 x 8 tile, the squared error of the base's approximation
against the reference ("true"), and of the base's against the 64-ray
uniform approximation ("reducible": what rays can remove). The estimators
(sirays refine --estimates) are ranked against both by Spearman's rank
correlation, and each chooses tiles (sirays refine's own plan, refined to
64 rays per pixel) at budgets of 8 to 32 rays per pixel; so do both
oracles (the same greedy plan).

The variational rule (thin plate, lambda by GCV: docs/design.md section
15) of uniform sobol rays at 0.25 and 0.5 rays per pixel (sobol renders at
FACTOR 0.5 and 0.70710678) and at 1, 2 and 4 (the 64-ray render's subsets):
below a few rays per pixel it is the better rule, so min-error's error at
equal rays is the lower of the fit's and its curves.

Per-tile ray counts and two passes, simulated from the same render: each
tile's rays r_t = max(have_t, c sqrt(e_t have_t / p_t)) (the least total
error if a tile's error falls as 1 / its rays), e_t the residual estimate
(computed here; checked against sirays refine's), in one pass from the base
or in two (half the extra budget, the estimate again from both passes' rays,
the rest).

The hexagonal lattice (hex quartic by the fit): the estimators (made on the
Cartesian cubic, as sirays refine makes them) against its own per-tile
error, and its L2 error with uniform rays and with the residual estimate's
tiles.

POV-Ray's own adaptive antialiasing at the final size (POVRAY_AA: +A
threshold, a pixel supersampled where it differs from a neighbour by more;
+AM1 a grid of R x R rays, +AM2 corners subdivided to depth R), rendered by
make (a folder of its own per setting, WORK/pov-aa/NAME/render/), measured
by the rays its statistics count (the pixels it traced and its
supersamples) and its error as a box image (its pixels
piecewise constant), against min-error cubic's best at no more rays per
pixel (uniform or adaptive).

Each row also has its displayed error: the RMS over the pixels inside the
border of the image shown at the output size (min-error: its 2x2 display;
POV-Ray: its pixels), and for min-error its pixel display too (the exact
pixel averages of f_app), against the reference's pixel averages. The zone
plate's truth is its closed form (ZP_NYQUIST as the Makefile's), its
per-tile and pixel references the closed form at --ref-factor points per
pixel and axis. REPORT/adaptive.md, adaptive.csv, estimators.csv,
adaptive.png (L2 against rays per pixel, per scene).

    compare_adaptive.py --work DIR --report DIR --scenes "objects edges"
        --res 128 --ref-factor 16 --seed 0 --sirays build/tools/sirays
"""

import argparse
import csv
import math
import os
import subprocess
import sys
import tempfile
import time

import numpy as np
from scipy.stats import spearmanr

import siproject
from renders import make_render, render_path, zp_k  # noqa: E402  (make render's own names)

ESTIMATORS = ("halves", "contrast", "residual", "highpass")
UNIFORM = (1, 2, 4, 8, 12, 16, 24, 32, 64)
# The variational rule (thin plate, lambda by GCV) of uniform sobol rays: below
# one ray per pixel from sobol renders of their own, (rays per pixel, FACTOR)
# as make names them; from 1 to 4 the 64-ray render's subsets as above.
VARIATIONAL_SPARSE = (("0.25", "0.5"), ("0.5", "0.70710678"))
VARIATIONAL_UNIFORM = (1, 2, 4)
VARIATIONAL = "variational (uniform sobol)"
# The hexagonal lattice's rows (hex quartic, the fit).
HEX = "hex quartic: "
HEX_UNIFORM = (4, 8, 16, 64)
HEX_BUDGETS = (8, 16)
# POV-Ray's adaptive antialiasing: (method +AM, threshold +A, depth +R).
POVRAY_AA = ((1, 0.3, 3), (1, 0.1, 4), (2, 0.3, 2), (2, 0.3, 3), (2, 0.1, 3), (2, 0.1, 4),
             (2, 0.03, 4))
BUDGETS = (6, 8, 12, 16, 24, 32)
FINE = 64
BASE = 4


def need(path):
    if not os.path.isfile(path):
        sys.exit(f"compare_adaptive.py: {path}: no such render (make compare-adaptive makes it)")
    return path


def read_refinement(path):
    with open(path) as f:
        words = f.read().split()
    i = words.index("tiles")
    n = int(words[i + 1])
    return [int(w) for w in words[i + 2:i + 2 + n]], int(words[words.index("rays") + 1])


def aa_name(am, threshold, depth):
    return f"am{am}-a{threshold:g}-r{depth}"


def aa_label(am, threshold, depth):
    return f"POV-Ray +AM{am} +A{threshold:g} +R{depth}"


def zoneplate_k(a):
    return zp_k(a.res, a.zp_nyquist)


class ZonePlateTruth:
    def __init__(self, k, border):
        self.k, self.border = k, border

    def l2_error(self, coefficients):
        return siproject.l2_error(coefficients, zoneplate=self.k, border=self.border)


class Scene:
    def __init__(self, a, scene):
        self.a, self.name = a, scene
        W = H = a.res
        self.W, self.H = W, H
        self.P = W * H
        if scene == "zoneplate":
            # grey: one channel, seen as three without copies
            rf = int(a.ref_factor)
            c = (np.arange(W * rf) + 0.5) / rf
            u = ((c / W - 0.5) ** 2).astype(np.float32)
            k = np.float32(zoneplate_k(a))
            ref = np.float32(0.5) + np.float32(0.5) * np.cos(k * (u[None, :] + u[:, None]))
            self.ref = np.broadcast_to(ref[:, :, None], ref.shape + (3,))
            self.truth = ZonePlateTruth(zoneplate_k(a), a.border)
        else:
            ref = siproject.read_image(need(render_path(a.work, scene, a.res, a.ref_factor, "regular", 0)))
            self.ref = ref
            self.truth = siproject.Reference(ref, border=a.border)
        rf = self.ref.shape[1] // W
        C = self.ref.shape[2]
        self.pixel_ref = np.stack([self.ref[:, :, c].astype(np.float64).reshape(H, rf, W, rf).mean(axis=(1, 3))
                                   for c in range(C)], axis=-1)
        b = int(a.border)
        self.inside = (slice(b, H - b), slice(b, W - b))
        fine = siproject.read_image(need(render_path(a.work, scene, a.res, "8", "sobol", a.seed)))
        C = fine.shape[-1]
        self.C = C
        self.V = fine.reshape(self.P, FINE, C).astype(np.float64)
        self.X = siproject.sample_positions("sobol", seed=a.seed, size=(W, H),
                                            rays_per_pixel=FINE).reshape(self.P, FINE, 2)
        self.base_path = need(render_path(a.work, scene, a.res, "2", "sobol", a.seed))
        base = siproject.read_image(self.base_path).reshape(self.P, BASE, C)
        self.base_check = float(np.max(np.abs(base - self.V[:, :BASE])))
        T = a.tile
        self.tcols = (W + T - 1) // T
        self.trows = (H + T - 1) // T
        py, px = np.mgrid[0:H, 0:W]
        self.tile_of_pixel = ((py // T) * self.tcols + px // T).ravel()

    def project(self, counts, rule="fit", hex_lattice=False):
        j = np.arange(FINE)[None, :]
        mask = j < counts[:, None]
        values = self.V[mask]
        positions = self.X[mask]
        weights = np.repeat(1.0 / counts, counts)
        return siproject.coefficients(values, positions=positions, weights=weights,
                                      size=(self.W, self.H), method="min-error", rule=rule,
                                      **(dict(lattice="hex", generator="hex-quartic") if hex_lattice
                                         else dict(generator="cubic")))

    def residual(self, counts, k):
        """The residual estimator (sis/refinement.h) of the samples the
        counts select: per tile, sum of w_i |f_i - f_app(x_i)|^2, w_i the
        area a sample stands for (1 / its pixel's count)."""
        j = np.arange(FINE)[None, :]
        mask = j < counts[:, None]
        pos = self.X[mask]
        d = self.V[mask] - k.evaluate(pos[:, 0], pos[:, 1])
        r = (d ** 2).sum(axis=-1) / np.repeat(counts, counts)
        tiles = self.tile_of_pixel[np.repeat(np.arange(self.P), counts)]
        return np.bincount(tiles, weights=r, minlength=self.tcols * self.trows)

    def displayed(self, image):
        """RMS of the image shown at the output size against the reference's
        pixel averages, over the pixels inside the border, every channel."""
        C = min(image.shape[-1], self.pixel_ref.shape[-1])
        d = image[self.inside][..., :C].astype(np.float64) - self.pixel_ref[self.inside][..., :C]
        return float(np.sqrt(np.mean(d ** 2)))

    def counts_for(self, tiles, fine=FINE):
        c = np.full(self.P, BASE, dtype=np.int64)
        if len(tiles):
            c[np.isin(self.tile_of_pixel, np.asarray(tiles))] = fine
        return c

    def tile_errors(self, k, other=None):
        """Per tile: squared error of k against the reference (or against
        `other`, coefficients), the mean over the points within the border
        times the tile's area."""
        rf = self.ref.shape[1] // self.W
        f = k.resample(size=(self.W * rf, self.H * rf), display="centred").astype(np.float64)
        g = self.ref if other is None else other.resample(size=(self.W * rf, self.H * rf),
                                                          display="centred")
        d = ((f - g) ** 2).sum(axis=-1)
        c = (np.arange(self.W * rf) + 0.5) / rf
        inside = (c >= self.a.border) & (c <= self.W - self.a.border)
        d = d * inside[None, :] * inside[:, None]
        T = self.a.tile * rf
        e = d.reshape(self.trows, T, self.tcols, T).sum(axis=(1, 3)) / rf**2
        return e.ravel()


def plan(est, budget, P, tile_pixels):
    order = sorted(range(len(est)), key=lambda t: (-est[t], t))
    allowed = math.floor(budget * P + 1e-6) - BASE * P
    used, chosen = 0, []
    for t in order:
        add = tile_pixels[t] * (FINE - BASE)
        if used + add > allowed:
            break
        used += add
        chosen.append(t)
    return sorted(chosen)


def allocate(est, have, budget, P, tile_pixels):
    """Rays per pixel for each tile at `budget` rays per pixel over the
    frame, none fewer than `have` (its rays now) nor more than FINE: under
    the model that a tile's error falls as 1 / its rays (est measured at
    have), the least total error is at r_t = max(have_t, c sqrt(est_t have_t
    / p_t)), c the largest that fits the budget (bisection), rounded down."""
    est, have, p = np.asarray(est, float), np.asarray(have, float), np.asarray(tile_pixels, float)
    want = np.sqrt(np.maximum(est, 0) * have / p)

    def counts(c):
        return np.clip(np.floor(np.maximum(have, c * want)), have, FINE).astype(np.int64)
    allowed = math.floor(budget * P + 1e-6)
    if (have * p).sum() > allowed:
        raise ValueError(f"allocate(): the rays already traced exceed the budget of {budget} a pixel")
    lo, hi = 0.0, 1.0
    while (counts(hi) * p).sum() <= allowed and hi < 1e30 and (counts(hi) < FINE).any():
        hi *= 2
    for _ in range(100):
        mid = 0.5 * (lo + hi)
        if (counts(mid) * p).sum() <= allowed:
            lo = mid
        else:
            hi = mid
    return counts(lo)


def sirays_refine(a, s, budget, estimator, work, fine=FINE):
    """sirays refine's tiles, refined rays (fine None: the tool's choice),
    estimates and wall time."""
    out = os.path.join(work, f"{s.name}-{estimator}-{budget}-{fine}.txt")
    est = os.path.join(work, f"{s.name}-{estimator}.exr")
    t = time.perf_counter()
    subprocess.run([a.sirays, "refine", s.base_path, "-o", out, "--rays", str(budget)] +
                   ([] if fine is None else ["--refine-rays", str(fine)]) +
                   ["--estimator", estimator, "--tile", str(a.tile),
                    "--estimates", est, "--threads", "1"], check=True, stderr=subprocess.DEVNULL)
    seconds = time.perf_counter() - t
    e = siproject.read_image(est)[:, :, 0].astype(np.float64).ravel()
    tiles, rays = read_refinement(out)
    return tiles, rays, e, seconds


def measure(a):
    rows, est_rows, notes = [], [], []
    work = tempfile.mkdtemp(prefix="compare-adaptive-")
    for scene in a.scenes.split():
        s = Scene(a, scene)
        notes.append(f"{scene}: the factor-2 sobol render against the 64-ray render's first 4 points "
                     f"of each pixel: largest difference {s.base_check:g}")
        uniform = {}
        for n in UNIFORM:
            t = time.perf_counter()
            k = s.project(np.full(s.P, n, dtype=np.int64))
            uniform[n] = k
            seconds = time.perf_counter() - t
            rows.append(dict(scene=scene, rays=float(n), method="uniform sobol", l2=s.truth.l2_error(k),
                             displayed=s.displayed(k.resample()),
                             displayed_pixel=s.displayed(k.resample(display="pixel")), tiles=0,
                             seconds=seconds))
        for rays, factor in VARIATIONAL_SPARSE + tuple((n, None) for n in VARIATIONAL_UNIFORM):
            t = time.perf_counter()
            if factor is None:
                k = s.project(np.full(s.P, rays, dtype=np.int64), rule="variational")
            else:
                k = siproject.coefficients(need(render_path(a.work, scene, a.res, factor, "sobol", a.seed)),
                                           size=(s.W, s.H), generator="cubic", method="min-error",
                                           rule="variational")
            seconds = time.perf_counter() - t
            rows.append(dict(scene=scene, rays=float(rays), method=VARIATIONAL, l2=s.truth.l2_error(k),
                             displayed=s.displayed(k.resample()),
                             displayed_pixel=s.displayed(k.resample(display="pixel")), tiles=0,
                             seconds=seconds, note="lambda %.3g" % k.report["lambda"]))
        true = s.tile_errors(uniform[BASE])
        reducible = s.tile_errors(uniform[BASE], uniform[FINE])
        tile_pixels = [int((s.tile_of_pixel == t).sum()) for t in range(len(true))]
        choices = {"oracle (true error)": (true, None), "oracle (reducible error)": (reducible, None)}
        for e in ESTIMATORS:
            _, _, est, secs = sirays_refine(a, s, 16, e, work)
            rt = spearmanr(est, true)[0]
            rr = spearmanr(est, reducible)[0]
            # the share of the true (reducible) error in the tiles it ranks worst 20 %
            top = np.argsort(-est, kind="stable")[: max(1, len(est) // 5)]
            est_rows.append(dict(scene=scene, estimator=e, spearman_true=rt, spearman_reducible=rr,
                                 top20_true_share=true[top].sum() / true.sum(),
                                 top20_reducible_share=reducible[top].sum() / reducible.sum(),
                                 seconds=secs))
            choices[e] = (est, e)
        for n in (("oracle (true error)", true), ("oracle (reducible error)", reducible)):
            top = np.argsort(-n[1], kind="stable")[: max(1, len(true) // 5)]
            est_rows.append(dict(scene=scene, estimator=n[0], spearman_true=spearmanr(n[1], true)[0],
                                 spearman_reducible=spearmanr(n[1], reducible)[0],
                                 top20_true_share=true[top].sum() / true.sum(),
                                 top20_reducible_share=reducible[top].sum() / reducible.sum(),
                                 seconds=0.0))
        for budget in BUDGETS:
            for name, (est, e) in choices.items():
                for fine in ((FINE,) if e is None else (FINE, None)):
                    t = time.perf_counter()
                    if e is None:
                        tiles, rays = plan(est, budget, s.P, tile_pixels), FINE
                    else:
                        tiles, rays, _, _ = sirays_refine(a, s, budget, e, work, fine)
                    counts = s.counts_for(tiles, rays)
                    k = s.project(counts)
                    seconds = time.perf_counter() - t
                    label = "adaptive " + name + (f", {FINE} rays" if fine else ", the tool's rays")
                    rows.append(dict(scene=scene, rays=float(counts.sum()) / s.P, method=label,
                                     l2=s.truth.l2_error(k), displayed=s.displayed(k.resample()),
                                     displayed_pixel=s.displayed(k.resample(display="pixel")),
                                     tiles=len(tiles), budget=budget, refined=rays, seconds=seconds))
        # Per-tile rays and two passes, simulated from the same 64-ray
        # render with the residual estimator computed here (checked against
        # sirays refine's at the base).
        ntiles = s.tcols * s.trows
        base_counts = np.full(s.P, BASE, dtype=np.int64)
        e0 = s.residual(base_counts, uniform[BASE])
        check = spearmanr(e0, choices["residual"][0])[0]
        notes.append(f"{scene}: the residual estimate computed by the script against sirays refine's at "
                     f"the base: Spearman {check:.6f}")
        for budget in BUDGETS:
            for passes in (1, 2):
                t = time.perf_counter()
                have = np.full(ntiles, BASE)
                est = e0
                for q in range(passes):
                    step = BASE + (budget - BASE) * (q + 1) / passes
                    have = allocate(est, have, step, s.P, tile_pixels)
                    counts = have[s.tile_of_pixel]
                    k = s.project(counts)
                    if q + 1 < passes:
                        est = s.residual(counts, k)
                seconds = time.perf_counter() - t
                label = ("adaptive residual, per-tile rays" if passes == 1 else
                         "adaptive residual, per-tile rays, two passes") + " (simulated)"
                rows.append(dict(scene=scene, rays=float(counts.sum()) / s.P, method=label,
                                 l2=s.truth.l2_error(k), displayed=s.displayed(k.resample()),
                                 displayed_pixel=s.displayed(k.resample(display="pixel")),
                                 tiles=int((have > BASE).sum()), budget=budget,
                                 refined=f"{int(have.max())} most", seconds=seconds))
        # The hexagonal lattice (hex quartic, the fit): the estimators, made
        # on the Cartesian cubic as sirays refine makes them, against its own
        # oracle, and its L2 error with uniform rays and with the residual
        # estimator's tiles (the tool's rays).
        hex_uniform = {}
        for n in HEX_UNIFORM:
            t = time.perf_counter()
            k = s.project(np.full(s.P, n, dtype=np.int64), hex_lattice=True)
            hex_uniform[n] = k
            rows.append(dict(scene=scene, rays=float(n), method=HEX + "uniform sobol",
                             l2=s.truth.l2_error(k), displayed=s.displayed(k.resample()),
                             displayed_pixel=math.nan, tiles=0, seconds=time.perf_counter() - t))
        hex_true = s.tile_errors(hex_uniform[BASE])
        for e in ESTIMATORS:
            top = np.argsort(-choices[e][0], kind="stable")[: max(1, len(hex_true) // 5)]
            est_rows.append(dict(scene=scene, estimator=e + " (hex quartic's error)",
                                 spearman_true=spearmanr(choices[e][0], hex_true)[0],
                                 spearman_reducible=math.nan,
                                 top20_true_share=hex_true[top].sum() / hex_true.sum(),
                                 top20_reducible_share=math.nan, seconds=0.0))
        for budget in HEX_BUDGETS:
            t = time.perf_counter()
            tiles, rays, _, _ = sirays_refine(a, s, budget, "residual", work, None)
            counts = s.counts_for(tiles, rays)
            k = s.project(counts, hex_lattice=True)
            rows.append(dict(scene=scene, rays=float(counts.sum()) / s.P,
                             method=HEX + "adaptive residual, the tool's rays", l2=s.truth.l2_error(k),
                             displayed=s.displayed(k.resample()), displayed_pixel=math.nan,
                             tiles=len(tiles), budget=budget, refined=rays,
                             seconds=time.perf_counter() - t))
        for am, threshold, depth in POVRAY_AA:
            path, st, _ = make_render(os.path.join(a.work, "pov-aa", aa_name(am, threshold, depth)),
                                      scene, a.res, 1, povopts=[f"+A{threshold:g}", f"+AM{am}", f"+R{depth}", "-J"],
                                      zp_nyquist=a.zp_nyquist, build=a.build, quiet=True)
            k = siproject.coefficients(path, factor=1, generator="box", method="conventional")
            # POV-Ray's statistics: the pixels it traced (a few more than the
            # frame's with antialiasing on) and its supersamples beyond them
            rays = (float(st["pixels"]) + float(st.get("samples", 0))) / s.P
            rows.append(dict(scene=scene, rays=rays,
                             method=aa_label(am, threshold, depth), l2=s.truth.l2_error(k),
                             displayed=s.displayed(siproject.read_image(path)), displayed_pixel=math.nan, tiles=0,
                             seconds=float(st.get("wall_s", math.nan))))
        print(f"compare_adaptive.py: {scene} done", file=sys.stderr)
    return rows, est_rows, notes


def write(a, rows, est_rows, notes, pipeline):
    os.makedirs(a.report, exist_ok=True)
    with open(os.path.join(a.report, "adaptive.csv"), "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=["scene", "method", "budget", "rays", "tiles", "refined", "l2",
                                          "displayed", "displayed_pixel", "seconds", "note"],
                           extrasaction="ignore")
        w.writeheader()
        w.writerows(rows)
    with open(os.path.join(a.report, "estimators.csv"), "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(est_rows[0]))
        w.writeheader()
        w.writerows(est_rows)
    L = [f"# Adaptive rays ({a.res}^2, min-error cubic, reference factor {a.ref_factor}, sobol seed "
         f"{a.seed}, tiles of {a.tile}, base {BASE} rays per pixel, refined tiles {FINE}, border "
         f"{a.border})", ""]
    L += ["Every sample set is a subset of the sobol render of 64 rays per pixel (see the script's "
          "docstring). " + " ".join(notes), ""]
    goal = {"edges": 24}
    for scene in a.scenes.split():
        sr = [r for r in rows if r["scene"] == scene]
        u = {r["rays"]: r["l2"] for r in sr if r["method"] == "uniform sobol"}
        u64 = u[64.0]
        L += [f"## {scene}", "", "### Estimators against the oracle (per tile, base 4 rays per pixel)", "",
              "| estimator | Spearman vs true error | vs reducible error | true error in its worst 20 % "
              "| reducible error in its worst 20 % | seconds (sirays refine) |",
              "| --- | --- | --- | --- | --- | --- |"]
        for r in [r for r in est_rows if r["scene"] == scene and "hex" not in r["estimator"]]:
            L.append(f"| {r['estimator']} | {r['spearman_true']:.3f} | {r['spearman_reducible']:.3f} | "
                     f"{r['top20_true_share']:.3f} | {r['top20_reducible_share']:.3f} | {r['seconds']:.2f} |")
        L += ["", "### L2 error against rays per pixel", "",
              f"Uniform sobol at 64 rays per pixel: L2 {u64:.6f} (the goal: within 2 %, "
              f"{1.02 * u64:.6f}).", "",
              "The excess left: (L2 - L2 of uniform 64) / (L2 of uniform 4 - L2 of uniform 64), the "
              "share of what rays can remove from the base's error that is left.", "",
              "| method | budget | rays per pixel | tiles refined | to rays per pixel | L2 | / uniform 64 | excess left |",
              "| --- | --- | --- | --- | --- | --- | --- | --- |"]
        for r in sr:
            if r["method"].startswith(("POV-Ray", HEX)):
                continue
            method = r["method"] + (f" ({r['note']})" if r.get("note") else "")
            L.append(f"| {method} | {r.get('budget', '')} | {r['rays']:.3f} | {r['tiles']} | {r.get('refined', '')} | "
                     f"{r['l2']:.6f} | {r['l2'] / u64:.4f} | {(r['l2'] - u64) / (u[4.0] - u64):.3f} |")
        hx = [r for r in sr if r["method"].startswith(HEX)]
        if hx:
            h64 = next(r["l2"] for r in hx if r["method"] == HEX + "uniform sobol" and r["rays"] == 64.0)
            L += ["", "### The hexagonal lattice (hex quartic, the fit)", "",
                  "The estimators as sirays refine makes them (on the Cartesian cubic) against the hex "
                  "quartic's own per-tile error at the base:", "",
                  "| estimator | Spearman vs hex quartic's true error | its true error in the worst 20 % |",
                  "| --- | --- | --- |"]
            for r in [r for r in est_rows if r["scene"] == scene and "hex" in r["estimator"]]:
                L.append(f"| {r['estimator']} | {r['spearman_true']:.3f} | {r['top20_true_share']:.3f} |")
            L += ["", "| method | budget | rays per pixel | tiles refined | to rays per pixel | L2 | "
                  "/ hex uniform 64 |", "| --- | --- | --- | --- | --- | --- | --- |"]
            for r in hx:
                L.append(f"| {r['method']} | {r.get('budget', '')} | {r['rays']:.3f} | {r['tiles']} | "
                         f"{r.get('refined', '')} | {r['l2']:.6f} | {r['l2'] / h64:.4f} |")
        L += ["", "### Against POV-Ray's adaptive antialiasing", "",
              "Each POV-Ray setting (its rays per pixel from its statistics; its L2 error as a box image, "
              "its displayed error its pixels') against min-error cubic at equal rays: uniform sobol rays' L2 "
              "error at exactly those rays per pixel by the fit and by the variational rule (each "
              "interpolated between its measured densities, linearly in log rays and log error; the "
              "lower of the two, its rule named), and the lowest L2 error measured at no more rays per "
              "pixel (uniform sobol by either rule, or adaptive with the tool's rays) with that row's "
              "displayed errors: its 2x2 display (siproject's default) and its pixel display (the exact "
              "pixel averages of f_app).", "",
              "| POV-Ray | rays per pixel | L2 | displayed | min-error uniform at those rays: L2 | rule | "
              "lower | lowest measured at <= those rays | its rays | L2 | displayed (2x2) | "
              "displayed (pixel) |",
              "| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |"]
        mine = [r for r in sr if r["method"] in ("uniform sobol", VARIATIONAL)
                or r["method"].endswith("the tool's rays")]
        curves = {rule: sorted((r["rays"], r["l2"]) for r in sr if r["method"] == m)
                  for rule, m in (("fit", "uniform sobol"), ("variational", VARIATIONAL))}
        curves = {rule: c for rule, c in curves.items() if c}
        wins = []
        for r in [r for r in sr if r["method"].startswith("POV-Ray")]:
            # beyond a curve's densest point: its error there, at fewer rays
            at, rule = min((math.exp(np.interp(math.log(r["rays"]), [math.log(x) for x, _ in c],
                                               [math.log(y) for _, y in c])), rule)
                           for rule, c in curves.items())
            wins.append(at < r["l2"])
            top = curves[rule][-1][0]
            shown_at = f"{at:.6f}" + (f" (at {top:g})" if r["rays"] > top else "")
            best = min((m for m in mine if m["rays"] <= r["rays"] + 1e-9), key=lambda m: m["l2"], default=None)
            tail = (f"{best['method']} | {best['rays']:.3f} | {best['l2']:.6f} | {best['displayed']:.6f} | "
                    f"{best['displayed_pixel']:.6f}" if best else "none (fewer rays than any) | | | |")
            L.append(f"| {r['method']} | {r['rays']:.3f} | {r['l2']:.6f} | {r['displayed']:.6f} | "
                     f"{shown_at} | {rule} | {'yes' if wins[-1] else 'no'} | {tail} |")
        L.append(f"- min-error cubic's L2 error at equal rays is lower than POV-Ray's in {sum(wins)} of "
                 f"{len(wins)} settings")
        limit = goal.get(scene, 16)
        for m in sorted({r["method"] for r in sr if not r["method"].startswith(("POV-Ray", HEX))}):
            met = [r for r in sr if r["method"] == m and r["rays"] <= limit + 1e-9 and r["l2"] <= 1.02 * u64]
            best = min((r for r in sr if r["method"] == m and r["rays"] <= limit + 1e-9),
                       key=lambda r: r["l2"], default=None)
            if best:
                L.append(f"- {m}: best at <= {limit} rays per pixel {best['l2']:.6f} "
                         f"({best['l2'] / u64:.4f} x uniform 64) at {best['rays']:.3f}: goal "
                         f"{'met' if met else 'not met'}")
        L.append("")
    if pipeline:
        L += ["## make SAMPLES=adaptive (the real second pass)", ""] + pipeline + [""]
    with open(os.path.join(a.report, "adaptive.md"), "w") as f:
        f.write("\n".join(L))
    chart(a, rows)
    print("\n".join(L))


def chart(a, rows):
    """adaptive.png: the continuous L2 error (top) and the displayed error
    (bottom) against rays per pixel, a column per scene: uniform sobol,
    adaptive (residual, the tool's rays) and POV-Ray's settings."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    scenes = a.scenes.split()
    fig, axes = plt.subplots(2, len(scenes), figsize=(4.2 * len(scenes), 6.6), squeeze=False)
    for col, scene in enumerate(scenes):
        sr = [r for r in rows if r["scene"] == scene]
        for row, key in enumerate(("l2", "displayed")):
            ax = axes[row][col]
            for label, pick, style in (
                    ("uniform sobol (min-error cubic)", lambda r: r["method"] == "uniform sobol", "o-"),
                    ("uniform sobol, variational rule", lambda r: r["method"] == VARIATIONAL, "D-"),
                    ("adaptive (min-error cubic)",
                     lambda r: r["method"] == "adaptive residual, the tool's rays", "s-"),
                    ("POV-Ray +AM (its pixels)", lambda r: r["method"].startswith("POV-Ray"), "^")):
                pts = sorted((r["rays"], r[key]) for r in sr if pick(r))
                if pts:
                    ax.plot(*zip(*pts), style, label=label, markersize=4)
            if key == "displayed":
                pts = sorted((r["rays"], r["displayed_pixel"]) for r in sr
                             if r["method"] == "uniform sobol")
                ax.plot(*zip(*pts), "o--", color="C0", alpha=0.6, markersize=3,
                        label="uniform sobol, pixel display")
                ax.legend(fontsize=7) if col == 0 else None
            ax.set_xscale("log", base=2)
            ax.set_yscale("log")
            ax.grid(True, which="both", alpha=0.3)
            if row == 0:
                ax.set_title(scene)
            else:
                ax.set_xlabel("rays per pixel")
    axes[0][0].set_ylabel("continuous L2 error")
    axes[1][0].set_ylabel("displayed error (pixel averages)")
    axes[0][0].legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(os.path.join(a.report, "adaptive.png"), dpi=80)
    plt.close(fig)


def stats(path):
    out = {}
    if os.path.isfile(path):
        for line in open(path):
            w = line.split()
            if len(w) >= 2:
                out[w[0]] = float(w[1])
    return out


def pipeline_rows(a):
    """make SAMPLES=adaptive RAYS=16's own passes (the real second pass
    traced by POV-Ray), projected by siproject --refined, against the
    reference; and the POV-Ray wall times beside the uniform render of 16
    rays per pixel (make SAMPLES=sobol FACTOR=4)."""
    out = []
    for scene in a.scenes.split():
        name = os.path.join(a.work, "render", f"{scene}-{a.res}-adaptive-r16-s{a.seed}")
        base = render_path(a.work, scene, a.res, "2", "sobol", a.seed)
        if not os.path.isfile(name + ".exr"):
            continue
        with tempfile.TemporaryDirectory() as t:
            subprocess.run([a.siproject, base, "--refined", name + ".exr", "--size", f"{a.res}x{a.res}",
                            "--generator", "cubic", "--method", "min-error", "--coeffs",
                            os.path.join(t, "k.exr"), "-o", os.path.join(t, "o.exr"), "-q"], check=True)
            k = siproject.load(os.path.join(t, "k.exr"))
        if scene == "zoneplate":
            truth = ZonePlateTruth(zoneplate_k(a), a.border)
        else:
            truth = siproject.Reference(
                siproject.read_image(render_path(a.work, scene, a.res, a.ref_factor, "regular", 0)),
                border=a.border)
        l2 = truth.l2_error(k)
        words = open(name + ".refine.txt").read().split()
        rays, tiles = int(words[words.index("rays") + 1]), int(words[words.index("tiles") + 1])
        b = stats(render_path(a.work, scene, a.res, "2", "sobol", a.seed).replace(".exr", ".stats"))
        x = stats(name + ".stats")
        u = stats(render_path(a.work, scene, a.res, "4", "sobol", a.seed).replace(".exr", ".stats"))
        total = (b.get("wall_s", 0) + b.get("mesh_s", 0) + x.get("refine_s", 0) + x.get("wall_s", 0))
        out.append(f"- {scene}: {tiles} tiles refined to {rays} rays per pixel, L2 {l2:.6f} "
                   f"(coefficients in float, as the coefficient file keeps them); first pass "
                   f"{b.get('wall_s', 0):.2f} s of POV-Ray and {b.get('mesh_s', 0):.2f} s of sirays mesh, "
                   f"sirays refine {x.get('refine_s', 0):.2f} s, second pass {x.get('wall_s', 0):.2f} s "
                   f"({int(x.get('extra_rays', 0))} rays, one POV-Ray process): {total:.2f} s in all, "
                   f"against {u.get('wall_s', 0) + u.get('mesh_s', 0):.2f} s for the uniform render of 16 "
                   f"rays per pixel")
    return out


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--work", required=True)
    p.add_argument("--report", required=True)
    p.add_argument("--scenes", default="objects edges")
    p.add_argument("--res", type=int, default=128)
    p.add_argument("--ref-factor", default="16")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--tile", type=int, default=8)
    p.add_argument("--border", type=float, default=2.0)
    p.add_argument("--sirays", default="build/tools/sirays")
    p.add_argument("--siproject", default="build/tools/siproject")
    p.add_argument("--zp-nyquist", type=float, default=0.7)
    a = p.parse_args()
    a.build = os.path.dirname(os.path.dirname(os.path.abspath(a.siproject)))
    rows, est_rows, notes = measure(a)
    write(a, rows, est_rows, notes, pipeline_rows(a))


if __name__ == "__main__":
    main()
