#!/usr/bin/env python3
"""Sub-frame times of an animation (make anim; docs/pipeline.md "Animations").

    anim_times.py --frames F --subframes K --fps R [--jitter SEED] [--pairs]
    anim_times.py ... --average-ok ANGLE[:PHASE] --out-fps R2

Prints one time per line, in seconds, for sub-frames n = 0 .. F K - 1 (with
--pairs one line of NNNN:TIME words, n with four digits or more, for make):
sub-frame j of rendered frame i (n = i K + j) is at

    t = (i + (j + 1/2 + d_n) / K) / R,

the centre of its own K-th of the frame interval [i / R, (i + 1) / R), with
d_n = 0, or with --jitter a uniform offset in [-1/2, 1/2) drawn from
Python's random.Random seeded with "SEED:n" (each sub-frame's time depends
on the seed and its own index only, so more frames keep the earlier times).
Times are printed with 12 significant digits. --average-ok prints 1 when
every frame siproject --fps would form at R2 (each whole frame whose
shutter lies inside the sub-frames' span, with siproject's slack) holds a
sub-frame in its half-open shutter, as the average needs, and nothing
otherwise; the times are the printed ones.
"""
import argparse
import math
import random
import sys


def times(frames, subframes, fps, jitter=None):
    out = []
    for n in range(frames * subframes):
        i, j = divmod(n, subframes)
        d = 0.0 if jitter is None else random.Random(f"{jitter}:{n}").random() - 0.5
        out.append((i + (j + 0.5 + d) / subframes) / fps)
    return out


def average_ok(ts, shutter, fps):
    """Whether every default frame's shutter [o, c) holds a sub-frame."""
    angle, _, phase = shutter.partition(":")
    angle, phase = float(angle), float(phase or 0)
    if len(ts) < 2:
        return False
    lo = ts[0] - 0.5 * (ts[1] - ts[0])
    hi = ts[-1] + 0.5 * (ts[-1] - ts[-2])
    f0 = math.ceil(lo * fps - phase / 360 - 1e-9)
    f1 = math.floor(hi * fps - (phase + angle) / 360 + 1e-9)
    for f in range(f0, f1 + 1):
        o = f / fps + phase / 360 / fps
        c = f / fps + (phase + angle) / 360 / fps
        if not any(o <= t < c for t in ts):
            return False
    return True


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--frames", type=int, required=True)
    p.add_argument("--subframes", type=int, required=True)
    p.add_argument("--fps", type=float, required=True)
    p.add_argument("--jitter", type=int, default=None)
    p.add_argument("--pairs", action="store_true")
    p.add_argument("--average-ok", metavar="ANGLE[:PHASE]")
    p.add_argument("--out-fps", type=float)
    a = p.parse_args(argv)
    if a.frames < 1:
        p.error(f"--frames {a.frames}: expected a positive whole number")
    if a.subframes < 1:
        p.error(f"--subframes {a.subframes}: expected a positive whole number")
    if not a.fps > 0:
        p.error(f"--fps {a.fps}: expected a positive number")
    if a.jitter is not None and a.jitter < 0:
        p.error(f"--jitter {a.jitter}: expected a whole number >= 0")
    ts = times(a.frames, a.subframes, a.fps, a.jitter)
    if a.average_ok is not None:
        if average_ok([float(f"{t:.12g}") for t in ts], a.average_ok, a.out_fps or a.fps):
            print(1)
        return 0
    if a.pairs:
        print(" ".join(f"{n:04d}:{t:.12g}" for n, t in enumerate(ts)))
    else:
        for t in ts:
            print(f"{t:.12g}")


if __name__ == "__main__":
    sys.exit(main())
