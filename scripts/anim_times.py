#!/usr/bin/env python3
"""Sub-frame times of an animation (make anim; docs/pipeline.md "Animations").

    anim_times.py --frames F --subframes K --fps R [--jitter SEED] [--pairs]

Prints one time per line, in seconds, for sub-frames n = 0 .. F K - 1 (with
--pairs one line of NNNN:TIME words, n with four digits or more, for make):
sub-frame j of rendered frame i (n = i K + j) is at

    t = (i + (j + 1/2 + d_n) / K) / R,

the centre of its own K-th of the frame interval [i / R, (i + 1) / R), with
d_n = 0, or with --jitter a uniform offset in [-1/2, 1/2) drawn from
Python's random.Random seeded with "SEED:n" (each sub-frame's time depends
on the seed and its own index only, so more frames keep the earlier times).
Times are printed with 12 significant digits.
"""
import argparse
import random
import sys


def times(frames, subframes, fps, jitter=None):
    out = []
    for n in range(frames * subframes):
        i, j = divmod(n, subframes)
        d = 0.0 if jitter is None else random.Random(f"{jitter}:{n}").random() - 0.5
        out.append((i + (j + 0.5 + d) / subframes) / fps)
    return out


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--frames", type=int, required=True)
    p.add_argument("--subframes", type=int, required=True)
    p.add_argument("--fps", type=float, required=True)
    p.add_argument("--jitter", type=int, default=None)
    p.add_argument("--pairs", action="store_true")
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
    if a.pairs:
        print(" ".join(f"{n:04d}:{t:.12g}" for n, t in enumerate(ts)))
    else:
        for t in ts:
            print(f"{t:.12g}")


if __name__ == "__main__":
    sys.exit(main())
