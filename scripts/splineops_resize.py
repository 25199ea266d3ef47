#!/usr/bin/env python3
"""splineops_resize.py: the splineops competitor of the benchmark (scripts/bench.py).

    splineops_resize.py IN.exr -o OUT.exr --size WxH [--degree D] [--preset NAME]

Reads an OpenEXR image (every channel, half or float) with the OpenEXR Python
bindings, resizes each channel with splineops' least-squares spline resize
and writes an EXR (ZIP) of the input's sample type (half stays half, as
oiiotool and siproject do), to a temporary name in OUT's folder renamed on
success: never a partial file.

Least-squares resize (Munoz, Barrientos, Unser 2001): orthogonal projection
of the degree-D interpolating spline of the input onto the splines of degree
D at the output spacing, splineops.resize.resize_degrees(interp_degree=D,
analy_degree=D, synthe_degree=D). --preset NAME uses splineops.resize.resize
(method=NAME) instead, e.g. cubic-antialiasing, the oblique (3, 1, 3)
projection splineops recommends for downsampling. splineops maps the first
and last samples of a line onto the first and last output samples (scale
(M - 1) / (N - 1)), not pixel centres as siproject does: the geometry differs
by up to half an output pixel at the borders, the work does not.

splineops' native extension uses every core. Exit status: 0 success,
2 usage, 3 input, 4 output.
"""
import argparse
import os
import sys
import tempfile

import numpy as np


def fail(code, message):
    print(f"splineops_resize: {message}", file=sys.stderr)
    sys.exit(code)


def parse_size(text):
    try:
        w, h = (int(v) for v in text.lower().split("x"))
    except ValueError:
        fail(2, f"--size {text!r}: expected WxH, positive integers")
    if w <= 0 or h <= 0:
        fail(2, f"--size {text!r}: expected WxH, positive integers")
    return w, h


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("input", metavar="IN", help="input OpenEXR image")
    ap.add_argument("-o", "--output", required=True, help="output OpenEXR image (float)")
    ap.add_argument("--size", required=True, help="output size WxH")
    ap.add_argument("--degree", type=int, default=3, choices=[0, 1, 2, 3],
                    help="spline degree of the least-squares resize (default 3)")
    ap.add_argument("--preset", default=None,
                    help="use splineops.resize.resize(method=PRESET) instead")
    args = ap.parse_args()
    width, height = parse_size(args.size)
    if not args.output.endswith(".exr"):
        fail(2, f"output must end in .exr: {args.output!r}")

    try:
        import OpenEXR
        from splineops.resize import resize, resize_degrees
    except ImportError as e:
        fail(2, f"missing Python package ({e}); run scripts/setup.sh")

    if not os.path.isfile(args.input):
        fail(3, f"cannot read {args.input!r}: no such file")
    try:
        infile = OpenEXR.File(args.input, separate_channels=True)
        channels = {name: ch.pixels for name, ch in infile.channels().items()}
        stored = {name: plane.dtype for name, plane in channels.items()}
    except Exception as e:  # the bindings raise plain exceptions
        fail(3, f"cannot read {args.input!r}: {e}")
    del infile

    def resize_channel(plane):
        plane = np.ascontiguousarray(plane, dtype=np.float32)
        if args.preset:
            return resize(plane, output_size=(height, width), method=args.preset)
        return resize_degrees(plane, output_size=(height, width), interp_degree=args.degree,
                              analy_degree=args.degree, synthe_degree=args.degree)

    result = {}
    for name in sorted(channels):
        out_type = np.float16 if stored[name] == np.float16 else np.float32
        result[name] = np.asarray(resize_channel(channels.pop(name)), dtype=np.float32).astype(out_type)

    out_dir = os.path.dirname(os.path.abspath(args.output))
    if not os.path.isdir(out_dir):
        fail(4, f"cannot write {args.output!r}: no folder {out_dir!r}")
    fd, tmp = tempfile.mkstemp(prefix=".splineops.", suffix=".exr", dir=out_dir)
    os.close(fd)
    try:
        header = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage}
        OpenEXR.File(header, result).write(tmp)
        umask = os.umask(0)
        os.umask(umask)
        os.chmod(tmp, 0o666 & ~umask)  # mkstemp makes 0600
        os.replace(tmp, args.output)
    except Exception as e:
        os.unlink(tmp)
        fail(4, f"cannot write {args.output!r}: {e}")


if __name__ == "__main__":
    main()
