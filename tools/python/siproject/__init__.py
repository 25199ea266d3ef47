"""Rendering in shift-invariant spaces, from Python.

The engine of the ``siproject`` tool: a supersampled render (a file any
OpenImageIO build reads, or a NumPy array of samples) is approximated in the
space of shifted B-splines (or box splines on a hexagonal lattice) with the
least L2 error, and the final image is sampled from that approximation.

Coordinates are output pixels: pixel (i, j) covers [i, i+1) x [j, j+1) and
its centre is (i + 1/2, j + 1/2); input sample (k, l) of a W_in x H_in grid
sits at ((k + 1/2) W / W_in, (l + 1/2) H / H_in) for an output of W x H.
Arrays are (height, width, channels), rows top to bottom, as in the file.

Every keyword means what siproject's option of the same name means
(``siproject --help``), with the same defaults and messages. Errors raise
ValueError (a bad option or array), OSError (a file) or RuntimeError.

Example::

    import numpy as np, siproject
    samples = np.random.default_rng(1).random((400, 400, 3), dtype=np.float32)
    image = siproject.project(samples, factor=4)            # (100, 100, 3) float32
    k = siproject.coefficients(samples, factor=4)
    k.evaluate([50.5], [50.5])                              # f_app at a point
"""

from __future__ import annotations

import os
import warnings as _warnings
from typing import Optional, Sequence, Tuple, Union

import numpy as np

from . import _core

__all__ = [
    "project",
    "coefficients",
    "load",
    "Coefficients",
    "highpass_share",
    "rms_difference",
    "psnr",
    "l2_error",
    "Reference",
    "overshoot",
    "luminance",
    "srgb8",
    "read_image",
    "write_image",
]

Size = Union[int, Tuple[int, int], str]
Input = Union[str, "os.PathLike[str]", np.ndarray]


def _size(size: Optional[Size]) -> str:
    if size is None:
        return ""
    if isinstance(size, str):
        return size
    if isinstance(size, (int, np.integer)):
        return f"{int(size)}x{int(size)}"
    try:
        w, h = size
    except (TypeError, ValueError):
        raise ValueError(f"--size {size!r}: expected N, (W, H) or 'WxH'") from None
    return f"{int(w)}x{int(h)}"


def _samples(input: Input):
    """A path as a str, an array as C-contiguous float32, float16, uint8 or uint16 (H, W, C)."""
    if isinstance(input, (str, os.PathLike)):
        return os.fspath(input)
    a = np.asarray(input)
    if a.ndim == 2:
        a = a[:, :, np.newaxis]
    if a.ndim != 3:
        raise ValueError(f"array: expected (height, width) or (height, width, channels), "
                         f"not shape {a.shape}")
    if a.dtype not in (np.float32, np.float16, np.uint8, np.uint16):
        if not np.issubdtype(a.dtype, np.floating):
            raise ValueError(f"array: samples of type {a.dtype} (expected float, linear; or uint8 "
                             f"or uint16, display-encoded and scaled to [0, 1] as in image files)")
        a = a.astype(np.float32)
    return np.ascontiguousarray(a)


def _form(input, size, factor, generator, method, display, boundary, lattice, density,
          nonfinite, prefilter, clamp, highlight_compress, threads, coefficients_only,
          input_transfer="auto"):
    result = _core._form(
        _samples(input), _size(size),
        None if factor is None else float(factor), "" if factor is None else str(factor),
        generator, method, display or "", boundary, lattice,
        None if density is None else float(density), "" if density is None else str(density),
        nonfinite, prefilter, clamp, bool(highlight_compress), int(threads),
        coefficients_only, str(input_transfer))
    for w in result[2]:
        _warnings.warn(w, RuntimeWarning, stacklevel=3)
    return result


def project(input: Input, *, size: Optional[Size] = None, factor: Optional[float] = None,
            generator: Optional[str] = None, method: Optional[str] = None,
            display: Optional[str] = None, boundary: str = "mirror",
            lattice: str = "cartesian", density: Optional[float] = None,
            nonfinite: str = "error",
            prefilter: str = "fft", clamp: str = "none", highlight_compress: bool = False,
            threads: int = 0, input_transfer: str = "auto") -> np.ndarray:
    """The final image of a render, as siproject forms it.

    input: a file path (any image OpenImageIO reads, streamed in bands as
        siproject reads it; a coefficient file is evaluated instead), or an
        array of samples (height, width[, channels]); float32 C-contiguous
        arrays are read where they are, float16, uint8 and uint16 too,
        other float types converted to float32 first. Float samples are
        linear light; uint8 and uint16 mean what they mean in image files
        and scikit-image (scaled to [0, 1], sRGB-encoded: decoded first).
    size: output size N, (W, H) or "WxH"; or factor: output = input / factor.
    generator: box, tent, quadratic, cubic, bspline:N, mitchell, gaussian,
        catmull-rom, lanczos3; hex-hat or hex-quartic with lattice="hex".
        None: cubic (hex-quartic on the hexagonal lattice).
    method: "min-error" or "conventional". None: min-error for B-spline
        generators, conventional for the other filters.
    display: "centred", "2x2", "pixel" or "offsets:DX,DY;...". None: 2x2 for
        min-error, centred for conventional.
    boundary: "mirror" or "periodic".
    lattice: "cartesian" or "hex"; density (hex: lattice points per output
        pixel, None: 1).
    nonfinite: "error" or "zero" (NaN/Inf samples replaced by 0, with a
        RuntimeWarning).
    prefilter: "fft" or "recursive". clamp: "none", "zero" or "local".
    highlight_compress: compress the samples' range before projecting.
    threads: worker threads, 0 for every core; the result is the same for any.
    input_transfer: "auto" (integer samples sRGB unless a file is tagged
        otherwise, float linear), "srgb", "linear" or "gammaG", as
        siproject's --input-transfer.

    Returns a float32 array (height, width, channels): the linear result
    siproject writes to a float EXR, bit for bit.
    """
    image, _, _ = _form(input, size, factor, generator, method, display, boundary, lattice,
                        density, nonfinite, prefilter, clamp, highlight_compress,
                        threads, False, input_transfer)
    return image


def coefficients(input: Input, *, size: Optional[Size] = None, factor: Optional[float] = None,
                 generator: Optional[str] = None, method: Optional[str] = None,
                 boundary: str = "mirror", lattice: str = "cartesian",
                 density: Optional[float] = None,
                 nonfinite: str = "error", prefilter: str = "fft",
                 highlight_compress: bool = False, threads: int = 0,
                 input_transfer: str = "auto") -> "Coefficients":
    """The coefficients of the approximation, with their space.

    The keywords are project()'s (there is no display or clamp: those apply
    when the coefficients are resampled). The coefficients are kept in float,
    as a coefficient file stores them, so that resample() gives project()'s
    image exactly.
    """
    _, k, _ = _form(input, size, factor, generator, method, None, boundary, lattice, density,
                    nonfinite, prefilter, "none", highlight_compress, threads, True,
                    input_transfer)
    return Coefficients(k)


def load(path: Union[str, "os.PathLike[str]"], *, nonfinite: str = "error",
         threads: int = 0) -> "Coefficients":
    """A coefficient file (siproject --coeffs, or Coefficients.save)."""
    if nonfinite not in ("error", "zero"):
        raise ValueError(f"--nonfinite '{nonfinite}': expected error or zero")
    return Coefficients(_core._load(os.fspath(path), nonfinite == "zero", int(threads)))


class Coefficients:
    """An approximation f_app(x) = sum_n c[n] phi(x - x_n) in its space.

    lattice ("cartesian" or "hexagonal"), generator, method, boundary, frame
    (width, height in output pixels), channel_names and array (the
    coefficient grid, (rows, columns, channels) float64, a copy) describe it.
    """

    def __init__(self, core: "_core.Coefficients"):
        self._k = core

    lattice = property(lambda self: self._k.lattice)
    generator = property(lambda self: self._k.generator)
    method = property(lambda self: self._k.method)
    boundary = property(lambda self: self._k.boundary)
    frame = property(lambda self: tuple(self._k.frame))
    channel_names = property(lambda self: list(self._k.channel_names))
    array = property(lambda self: self._k.array)

    def __repr__(self) -> str:
        w, h = self.frame
        return (f"<siproject.Coefficients {self.method} {self.generator} on a {self.lattice} "
                f"lattice, frame {w} x {h}, {len(self.channel_names)} channels>")

    def evaluate(self, x, y) -> np.ndarray:
        """f_app at the points (x, y) in output pixels (arrays, broadcast).

        Returns an array of shape broadcast(x, y).shape + (channels,).
        """
        bx, by = np.broadcast_arrays(np.asarray(x, dtype=np.float64),
                                     np.asarray(y, dtype=np.float64))
        out = self._k._evaluate(np.ascontiguousarray(bx).ravel(), np.ascontiguousarray(by).ravel())
        return out.reshape(bx.shape + (out.shape[1],))

    def resample(self, size: Optional[Size] = None, display: Optional[str] = None,
                 clamp: str = "none") -> np.ndarray:
        """The final image at size (None: the frame's), sampled by display
        (None: 2x2 for min-error, centred for conventional), as float32
        (height, width, channels)."""
        w = h = 0
        if size is not None:
            spelled = _size(size)
            try:
                w, h = (int(v) for v in spelled.lower().split("x"))
            except ValueError:
                raise ValueError(f"--size '{spelled}': expected WxH with positive whole numbers, "
                                 f"e.g. 1000x750") from None
            if w < 1 or h < 1:
                raise ValueError(f"--size '{spelled}': expected WxH with positive whole numbers, "
                                 f"e.g. 1000x750")
        return self._k._resample(w, h, display or "", clamp)

    def save(self, path: Union[str, "os.PathLike[str]"]) -> None:
        """Writes a coefficient file (float EXR with the space in its
        metadata), as siproject --coeffs does."""
        self._k._save(os.fspath(path))


def highpass_share(image: np.ndarray, cutoff: Union[float, Sequence[float]] = 0.25):
    """Share of the luminance's DFT energy (mean removed) above `cutoff`
    cycles per pixel (one number, or a list for a list of cutoffs)."""
    a = _samples(image)
    single = np.ndim(cutoff) == 0
    shares = _core._highpass_shares(a, [float(cutoff)] if single else [float(c) for c in cutoff])
    return shares[0] if single else list(shares)


def rms_difference(a: np.ndarray, b: np.ndarray, *, border: int = 0) -> float:
    """RMS over every channel of a - b, leaving out `border` pixels along
    each edge (images of one size)."""
    return _core._rms_difference(_samples(a), _samples(b), int(border))


def psnr(a: np.ndarray, b: np.ndarray, *, peak: float = 1.0, border: int = 0) -> float:
    """20 log10(peak / rms_difference(a, b)) in dB (infinite when equal)."""
    return _core._psnr(_samples(a), _samples(b), float(peak), int(border))


class Reference:
    """A reference render kept for the continuous L2 error of many
    approximations of its frame: Reference(array, border=4).l2_error(k).

    The array (H, W, C), float32 or float16, is read where it is when it is
    C-contiguous float32 (otherwise a float32 copy is kept). Each Cartesian
    space met (generator, lattice, boundary, frame) acquires the reference
    once; every further error in it costs a pass over the coefficients. The
    values are those of l2_error(k, array, border=border), bit for bit.
    """

    def __init__(self, truth: np.ndarray, *, border: float = 0.0, threads: int = 0):
        self._r = _core.L2Reference(_samples(truth), float(border), int(threads))

    border = property(lambda self: self._r.border)
    array = property(lambda self: self._r.array)

    def l2_error(self, k: Coefficients) -> float:
        """Continuous L2 error of k's approximation against this reference."""
        return self._r._l2_error(k._k)

    def __repr__(self) -> str:
        h, w, c = self._r.array.shape
        return f"<siproject.Reference {w} x {h} x {c}, border {self.border:g}>"


def l2_error(k: Coefficients, truth: Optional[Union[np.ndarray, Reference]] = None, *,
             zoneplate: Optional[float] = None, samples_per_pixel: int = 8,
             border: Optional[float] = None) -> float:
    """Continuous L2 error of k's approximation against a truth: a render of
    the same frame at a much higher factor (an array, or a Reference made
    from one, whose border then applies), or the closed-form zone plate of
    scenes/zoneplate.pov with ZP_K = zoneplate (sampled at
    samples_per_pixel^2 points per output pixel). border: output pixels left
    out along each edge (None: 0, or the Reference's)."""
    if (truth is None) == (zoneplate is None):
        raise ValueError("l2_error(): give exactly one truth: an array or zoneplate=K")
    if isinstance(truth, Reference):
        if border is not None and float(border) != truth.border:
            raise ValueError(f"l2_error(): border {border:g} given with a Reference made with "
                             f"border {truth.border:g}")
        return truth.l2_error(k)
    return _core._l2_error(k._k, None if truth is None else _samples(truth),
                           None if zoneplate is None else float(zoneplate),
                           int(samples_per_pixel), 0.0 if border is None else float(border))


def overshoot(output: np.ndarray, input: np.ndarray, *, neighbourhood: float = 1.0,
              tolerance: float = 1e-6, border: int = 0) -> dict:
    """How far `output` leaves the range of the input samples under each of
    its pixels (the same frame, any ratio): a dict of max_overshoot,
    max_undershoot, pixels, pixels_out_of_range, negative_pixels,
    negative_energy, min and max."""
    return _core._overshoot(_samples(output), _samples(input), float(neighbourhood),
                            float(tolerance), int(border))


def luminance(image: np.ndarray) -> np.ndarray:
    """Rec. 709 luminance of linear RGB (channel 0 for one or two channels)."""
    return _core._luminance(_samples(image))


def srgb8(image: np.ndarray) -> np.ndarray:
    """Linear values as the 8-bit sRGB an 8-bit output file holds (every
    channel encoded and clamped to [0, 1]), uint8 of the same shape."""
    return _core._srgb8(_samples(image))


def read_image(path: Union[str, "os.PathLike[str]"]) -> np.ndarray:
    """An image file as float32 (height, width, channels), read by
    OpenImageIO as siproject reads it (integer sRGB files decoded to linear)."""
    return _core._read_image(os.fspath(path))


def write_image(path: Union[str, "os.PathLike[str]"], image: np.ndarray, *,
                channel_names: Sequence[str] = (), alpha: int = -1, half: bool = False) -> None:
    """Writes an image as siproject writes its outputs: EXR (and other float
    formats) in float, or half; 8-bit formats (PNG, JPEG...) sRGB-encoded and
    clamped to [0, 1]. The file replaces an existing one only once written
    whole."""
    _core._write_image(os.fspath(path), _samples(image), list(channel_names), int(alpha),
                       bool(half))
