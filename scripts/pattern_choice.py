#!/usr/bin/env python3
"""Which low-discrepancy pattern (docs/design.md section 13): the zone plate
of scenes/zoneplate.pov in closed form sampled at each pattern's positions,
projected by min-error cubic (the fit rule, siproject's default) and by
conventional tent, and the continuous L2 error against the closed form, the
mean and spread over seeds; against the regular grid, jitter, Owen-scrambled
Sobol' (the library's) and a randomly shifted rank-1 lattice (the
generator nearest n / phi, computed here only for this comparison). Also each
pattern's worst count of samples in a pixel against the mean.

    .venv/bin/python scripts/pattern_choice.py [--res 128] [--seeds 4]

Prints a Markdown table."""

import argparse
import math
import time

import numpy as np

import siproject


def golden_generator(n):
    """The rank-1 generator nearest n / phi coprime with n: the Fibonacci
    lattice's where n is a Fibonacci number, a good one at any n."""
    g = int(round(n / ((1 + math.sqrt(5)) / 2)))
    for d in range(n):
        for c in (g - d, g + d):
            if 0 < c < n and math.gcd(c, n) == 1:
                return c
    return 1


def rank1(seed, W, H, n):
    """n points (k / n, {k g / n}) of a rank-1 lattice, randomly shifted
    (a Cranley-Patterson rotation by the seed)."""
    g = golden_generator(n)
    k = np.arange(n)
    shift = np.random.default_rng(seed).random(2)
    u = (k / n + shift[0]) % 1.0
    v = (k * g % n / n + shift[1]) % 1.0
    return np.column_stack([u * W, v * H])


def zoneplate(xy, W, H, K):
    u, v = xy[:, 0] / W, xy[:, 1] / H
    return 0.5 + 0.5 * np.cos(K * ((u - 0.5) ** 2 + (v - 0.5) ** 2))


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--res", type=int, default=128)
    ap.add_argument("--seeds", type=int, default=4)
    ap.add_argument("--rays", default="4 16")
    a = ap.parse_args()
    W = H = a.res
    K = 0.7 * math.pi * W
    print(f"zone plate {W} x {H}, K = 0.7 pi {W}; L2 error against the closed form (mean, spread "
          f"max - min over {a.seeds} seeds); worst pixel count / mean\n")
    print("| rays/px | pattern | min-error cubic | spread | conventional tent | spread | worst pixel count / mean | positions (s) |")
    print("|---|---|---|---|---|---|---|---|")
    for r in (float(x) for x in a.rays.split()):
        for pattern in ("regular", "jitter", "sobol", "rank-1"):
            errors = {"me": [], "tent": []}
            worst = 0.0
            seconds = 0.0
            for seed in range(1 if pattern == "regular" else a.seeds):
                t = time.perf_counter()
                if pattern == "rank-1":
                    n = len(siproject.sample_positions("regular", size=(W, H), rays_per_pixel=r))
                    xy = rank1(seed, W, H, n)
                else:
                    xy = siproject.sample_positions(pattern, seed=seed, size=(W, H), rays_per_pixel=r)
                seconds += time.perf_counter() - t
                f = zoneplate(xy, W, H, K)[:, None]
                counts = np.bincount(np.floor(xy[:, 1]).astype(int) * W + np.floor(xy[:, 0]).astype(int),
                                     minlength=W * H)
                worst = max(worst, counts.max() / counts.mean(), counts.mean() / max(counts.min(), 0.5))
                for name, kw in (("me", {}), ("tent", {"generator": "tent", "method": "conventional"})):
                    k = siproject.coefficients(f, positions=xy, size=(W, H), **kw)
                    errors[name].append(siproject.l2_error(k, zoneplate=K))
            runs = len(errors["me"])
            me, tent = np.array(errors["me"]), np.array(errors["tent"])
            print(f"| {r:g} | {pattern} | {me.mean():.5f} | {me.max() - me.min():.5f} | {tent.mean():.5f} | "
                  f"{tent.max() - tent.min():.5f} | {worst:.2f} | {seconds / runs:.3f} |")


if __name__ == "__main__":
    main()
