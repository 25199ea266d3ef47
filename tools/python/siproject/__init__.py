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
TypeError (a keyword given a value of the wrong type), ValueError (a bad
option or array), OSError (a file) or RuntimeError; Ctrl-C during a
projection raises KeyboardInterrupt at once.

Example::

    import numpy as np, siproject
    samples = np.random.default_rng(1).random((400, 400, 3), dtype=np.float32)
    image = siproject.project(samples, factor=4)            # (100, 100, 3) float32
    k = siproject.coefficients(samples, factor=4)
    k.evaluate([50.5], [50.5])                              # f_app at a point
"""

from __future__ import annotations

import math
import numbers
import os
import warnings as _warnings
from typing import Optional, Sequence, Tuple, Union

import numpy as np

from . import _core

__version__ = _core.__version__

__all__ = [
    "project",
    "coefficients",
    "pyramid",
    "load",
    "partial",
    "merge",
    "band_cuts",
    "sample_positions",
    "refine",
    "frame_weights",
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


def __dir__():
    return sorted(__all__ + ["__version__"])


Size = Union[int, Tuple[int, int], str]
Input = Union[str, "os.PathLike[str]", np.ndarray]

# ---- keywords: each checked for its type here (a TypeError of one line
# naming the keyword and what it takes), its value by the engine (siproject's
# ValueError messages).

# What the string keywords take, for the messages.
_TAKES = {
    "generator": '"box", "tent", "quadratic", "cubic", "bspline:N", "mitchell", "gaussian", '
                 '"catmull-rom", "lanczos3", "hex-hat" or "hex-quartic"',
    "method": '"min-error" or "conventional"',
    "display": '"centred", "2x2", "pixel" or "offsets:DX,DY;..."',
    "boundary": '"mirror" or "periodic"',
    "lattice": '"cartesian" or "hex"',
    "nonfinite": '"error" or "zero"',
    "prefilter": '"fft" or "recursive"',
    "clamp": '"none", "zero" or "local"',
    "rule": '"fit", "normalised" or "plain"',
    "pattern": '"regular", "jitter" or "sobol"',
}
_INT_RANGE = (-2 ** 31, 2 ** 31 - 1)  # the engine's int
_LONG_RANGE = (-2 ** 63, 2 ** 63 - 1)


def _shown(value) -> str:
    """A value as a message shows it: its repr, or its type where that is long."""
    r = repr(value)
    if len(r) <= 40:
        return r
    shape = getattr(value, "shape", None)
    return f"<{type(value).__name__}{f' of shape {shape}' if shape is not None else ''}>"


def _wrong(name: str, value, takes: str):
    return TypeError(f"{name}={_shown(value)}: expected {takes}, not {type(value).__name__}")


def _is_bool(value) -> bool:
    return isinstance(value, (bool, np.bool_))


def _text(name: str, value, optional: bool = False):
    """A string keyword (None too where optional)."""
    if value is None and optional:
        return None
    if not isinstance(value, str):
        raise _wrong(name, value, _TAKES[name] + (" or None" if optional else ""))
    return value


def _flag(name: str, value) -> bool:
    if not _is_bool(value):
        raise _wrong(name, value, "True or False")
    return bool(value)


def _whole(name: str, value, limits=_INT_RANGE) -> int:
    """A whole number (not a bool), within the C type the engine takes."""
    if _is_bool(value) or not isinstance(value, numbers.Integral):
        raise _wrong(name, value, "a whole number (int)")
    v = int(value)
    if not limits[0] <= v <= limits[1]:
        raise ValueError(f"{name}={v}: out of range ({limits[0]} to {limits[1]})")
    return v


def _lambda(value) -> Optional[str]:
    """The variational rule's lambda_: None, "gcv" or a finite real >= 0, as --lambda spells it."""
    if value is None:
        return None
    if isinstance(value, str):
        if value == "gcv":
            return value
        raise ValueError(f"lambda_={value!r}: expected 'gcv' or a finite number >= 0")
    if _is_bool(value) or not isinstance(value, numbers.Real):
        raise _wrong("lambda_", value, "'gcv' or a finite number >= 0")
    v = float(value)
    if not (math.isfinite(v) and v >= 0):
        raise ValueError(f"lambda_={v}: expected 'gcv' or a finite number >= 0")
    return repr(v)


def _number(name: str, value, optional: bool = False) -> Optional[float]:
    """A real number (not a bool); None too where optional."""
    if value is None and optional:
        return None
    if _is_bool(value) or not isinstance(value, numbers.Real):
        raise _wrong(name, value, "a number" + (" or None" if optional else ""))
    return float(value)


def _pair(name: str, value, what: str) -> Tuple[int, int]:
    """Two whole numbers (a tuple, list or array of two)."""
    try:
        a, b = value
    except (TypeError, ValueError):
        raise _wrong(name, value, what) from None
    if any(_is_bool(v) or not isinstance(v, numbers.Integral) for v in (a, b)):
        raise _wrong(name, value, what + " of whole numbers")
    return int(a), int(b)


def _size(size: Optional[Size], output_shape=None, factor=None) -> str:
    """size (N, (width, height) or "WxH") or output_shape ((rows, cols), as
    scikit-image names it) as siproject's --size, "" for neither."""
    if output_shape is not None:
        if size is not None:
            raise ValueError("give size=(width, height) or output_shape=(rows, cols), not both")
        if factor is not None:
            raise ValueError("give factor or output_shape, not both")
        rows, cols = _pair("output_shape", output_shape, "(rows, cols)")
        return f"{cols}x{rows}"
    if size is None:
        return ""
    if isinstance(size, str):
        return size
    what = 'N, (width, height) or "WxH"'
    if _is_bool(size):
        raise _wrong("size", size, what)
    if isinstance(size, numbers.Integral):
        return f"{int(size)}x{int(size)}"
    w, h = _pair("size", size, what)
    return f"{w}x{h}"


def _samples(input: Input):
    """A path as a str, an array as C-contiguous float32, float16, uint8 or uint16 (H, W, C)."""
    if isinstance(input, (str, os.PathLike)):
        return _path("input", input)
    a = np.asarray(input)
    if a.ndim == 2:
        a = a[:, :, np.newaxis]
    if a.ndim != 3:
        raise ValueError(f"array: expected (height, width) or (height, width, channels), "
                         f"not shape {a.shape}")
    if a.shape[2] > _INT_RANGE[1]:  # before any copy
        raise ValueError(f"array: {a.shape[2]} channels: at most {_INT_RANGE[1]}")
    return _values_dtype(a, "array")


def _values_dtype(a: np.ndarray, what: str) -> np.ndarray:
    """float32, float16, uint8 and uint16 as they are, other floats as float32."""
    if a.dtype not in (np.float32, np.float16, np.uint8, np.uint16):
        if not np.issubdtype(a.dtype, np.floating):
            raise ValueError(f"{what}: samples of type {a.dtype} (expected float, linear; or uint8 "
                             f"or uint16, display-encoded and scaled to [0, 1] as in image files)")
        a = a.astype(np.float32)
    return np.ascontiguousarray(a)


def _coordinates(name: str, value, shape_text: str) -> np.ndarray:
    """An array of real numbers as C-contiguous float64."""
    a = np.asarray(value)
    if a.dtype == np.bool_ or not (np.issubdtype(a.dtype, np.floating) or
                                   np.issubdtype(a.dtype, np.integer)):
        raise ValueError(f"{name}: of type {a.dtype} (expected real numbers, {shape_text})")
    return np.ascontiguousarray(a, dtype=np.float64)


def _scattered(values, positions, weights):
    """Values (N, C) as _samples' types, positions (N, 2) and weights (N,) as float64."""
    if isinstance(values, (str, os.PathLike)):
        raise ValueError("positions=: the values are an array (N,) or (N, channels), not a path "
                         "(a file holds its positions in channels pFilm.x, pFilm.y)")
    v = np.asarray(values)
    if v.ndim == 1:
        v = v[:, np.newaxis]
    if v.ndim != 2:
        raise ValueError(f"values: with positions=, expected (N,) or (N, channels), not shape "
                         f"{v.shape}")
    if v.shape[1] > _INT_RANGE[1]:
        raise ValueError(f"values: {v.shape[1]} channels: at most {_INT_RANGE[1]}")
    if v.shape[0] == 0 or v.shape[1] == 0:
        raise ValueError(f"values: no sample (shape {v.shape})")
    p = np.asarray(positions)
    if p.ndim != 2 or p.shape[1] != 2:
        raise ValueError(f"positions: expected (N, 2), a row (x, y) in output pixels per sample, "
                         f"not shape {p.shape}")
    p = _coordinates("positions", p, "(N, 2)")
    if p.shape[0] != v.shape[0]:
        raise ValueError(f"positions: {p.shape[0]} rows for {v.shape[0]} samples of values: one "
                         f"(x, y) per sample")
    w = None
    if weights is not None:
        w = np.asarray(weights)
        if w.ndim != 1:
            raise ValueError(f"weights: expected (N,), the area each sample stands for, not shape "
                             f"{w.shape}")
        w = _coordinates("weights", w, "(N,)")
        if w.shape[0] != v.shape[0]:
            raise ValueError(f"weights: {w.shape[0]} for {v.shape[0]} samples: one per sample")
    return _values_dtype(v, "values"), p, w


def _image(image):
    """An image for the measures and write_image: float32 or float16 as it
    is, uint8 and uint16 in linear light (scaled to [0, 1] and decoded from
    sRGB, as the same samples read from a file)."""
    a = _samples(image)
    if a.dtype in (np.uint8, np.uint16):
        a = _core._to_linear(a)
    return a


def _threads(threads) -> int:
    return _whole("threads", threads)


def _grey(input, positions=None) -> bool:
    """An array of two dimensions (of one with positions): the result has two as well."""
    if isinstance(input, (str, os.PathLike)):
        return False
    return np.ndim(input) == (1 if positions is not None else 2)


def _form(input, coefficients_only, *, size, output_shape, factor, generator, method, display,
          boundary, lattice, density, nonfinite, prefilter, clamp, highlight_compress, threads,
          input_transfer, positions=None, weights=None, rule=None, iterations=None,
          lambda_=None, smoothness=None, pyramid=False, refined=None):
    factor_spelling = "" if factor is None else str(factor)  # as given, for messages
    density_spelling = "" if density is None else str(density)
    factor = _number("factor", factor, optional=True)
    density = _number("density", density, optional=True)
    rule = _text("rule", rule, optional=True)
    iterations = None if iterations is None else _whole("iterations", iterations)
    lambda_ = _lambda(lambda_)
    smoothness = None if smoothness is None else _whole("smoothness", smoothness)
    if positions is None:
        if weights is not None:
            raise ValueError("weights= goes with positions= (the area each scattered sample "
                             "stands for)")
        samples, p, w = _samples(input), None, None
    else:
        if factor is not None:
            raise ValueError("factor=: scattered samples have no grid to divide; give the frame "
                             "as size=(width, height) in output pixels, the positions' coordinates")
        if size is None and output_shape is None:
            raise ValueError("size=: scattered samples need the frame, size=(width, height) (or "
                             "output_shape=(rows, cols)) in output pixels, the positions' "
                             "coordinates")
        samples, p, w = _scattered(input, positions, weights)
    result = _core._form(
        samples,
        size=_size(size, output_shape, factor),
        factor=factor, factor_spelling=factor_spelling,
        generator=_text("generator", generator, optional=True),
        method=_text("method", method, optional=True),
        display=_text("display", display, optional=True) or "",
        boundary=_text("boundary", boundary),
        lattice=_text("lattice", lattice),
        density=density, density_spelling=density_spelling,
        nonfinite=_text("nonfinite", nonfinite),
        prefilter=_text("prefilter", prefilter),
        clamp=_text("clamp", clamp),
        highlight_compress=_flag("highlight_compress", highlight_compress),
        threads=_threads(threads),
        coefficients_only=coefficients_only,
        input_transfer=_text("input_transfer", input_transfer),
        positions=p, weights=w, rule=rule, iterations=iterations, lambda_=lambda_,
        smoothness=smoothness, pyramid=pyramid,
        refined="" if refined is None else _path("refined", refined))
    for w in result[2]:
        _warnings.warn(w, RuntimeWarning, stacklevel=3)
    return result


def project(input: Input, *, size: Optional[Size] = None,
            output_shape: Optional[Tuple[int, int]] = None, factor: Optional[float] = None,
            generator: Optional[str] = None, method: Optional[str] = None,
            display: Optional[str] = None, boundary: str = "mirror",
            lattice: str = "cartesian", density: Optional[float] = None,
            nonfinite: str = "error",
            prefilter: str = "fft", clamp: str = "none", highlight_compress: bool = False,
            threads: int = 0, input_transfer: str = "auto", positions=None, weights=None,
            rule: Optional[str] = None, iterations: Optional[int] = None,
            lambda_=None, smoothness: Optional[int] = None, refined=None) -> np.ndarray:
    """The final image of a render, as siproject forms it.

    input: a file path (any image OpenImageIO reads, streamed in bands as
        siproject reads it; a coefficient file is evaluated instead), or an
        array of samples (height, width[, channels]); float32 C-contiguous
        arrays are read where they are, float16, uint8 and uint16 too,
        other float types converted to float32 first. Float samples are
        linear light; uint8 and uint16 mean what they mean in image files
        and scikit-image (scaled to [0, 1], sRGB-encoded: decoded first).
    size: output size N, (width, height) or "WxH" (siproject's --size); or
        output_shape: (rows, cols), as scikit-image's output_shape and
        a.shape[:2] spell it; or factor: output = input / factor.
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
    positions: scattered samples. input is then their values, (N,) or (N,
        channels) (the types of an array input, by the same rule), and
        positions an (N, 2) array of (x, y) in frame coordinates (output
        pixels: pixel (i, j) covers [i, i+1) x [j, j+1)); the frame is size
        (or output_shape), required; factor is refused. Either lattice:
        lattice="hex" projects onto the hexagonal box-spline space.
        weights: (N,), the area in output pixels^2 each sample stands for
        (None: the frame's area / N each). rule: "fit" (weighted least
        squares, None's default), "normalised" or "plain", as siproject's
        --rule, or "variational" (the smoothing spline); iterations: the
        fit's (None: 5), --iterations; lambda_: the variational rule's
        smoothness weight, a number >= 0 or "gcv" (None's default), --lambda;
        smoothness: its functional's order, 1 or 2 (None: 2). A file with
        position channels (pFilm.x, pFilm.y) is projected so without
        positions=.
    refined: an adaptive render's second pass (a path: the extra rays'
        render, sirays assemble --refinement), projected with input, the
        sobol render it refines (siproject's --refined; see refine()).

    Returns a float32 array (height, width, channels): the linear result
    siproject writes to a float EXR, bit for bit; (height, width) for an
    array of two dimensions (values of one dimension with positions).
    """
    image, _, _ = _form(input, False, size=size, output_shape=output_shape, factor=factor,
                        generator=generator, method=method, display=display,
                        boundary=boundary, lattice=lattice, density=density,
                        nonfinite=nonfinite, prefilter=prefilter, clamp=clamp,
                        highlight_compress=highlight_compress, threads=threads,
                        input_transfer=input_transfer, positions=positions, weights=weights,
                        rule=rule, iterations=iterations, lambda_=lambda_,
                        smoothness=smoothness, refined=refined)
    return image[:, :, 0] if _grey(input, positions) else image


def pyramid(input: Input, *, size: Optional[Size] = None,
            output_shape: Optional[Tuple[int, int]] = None, factor: Optional[float] = None,
            generator: Optional[str] = None, method: Optional[str] = None,
            display: Optional[str] = None, boundary: str = "mirror",
            nonfinite: str = "error", prefilter: str = "fft", clamp: str = "none",
            highlight_compress: bool = False, threads: int = 0,
            input_transfer: str = "auto") -> list:
    """Every level of a min-error pyramid, as siproject --mip forms them.

    Level 0 is project()'s image for the same keywords; level j is
    max(1, floor(W / 2^j)) x max(1, floor(H / 2^j)) (maketx's sizes), down
    to 1 x 1, each the projection of the samples themselves onto the space
    at that level's frame (not a filtered copy of the level above), all
    from one reading of the input. input: as project()'s (a path or an
    array), or a pyramid's coefficient file (siproject --mip --coeffs),
    whose levels are evaluated. The Cartesian lattice only; no positions=.

    Returns a list of float32 arrays, level 0 first: (height, width,
    channels), or (height, width) for an array of two dimensions.
    """
    try:
        levels, _, _ = _form(input, False, size=size, output_shape=output_shape, factor=factor,
                             generator=generator, method=method, display=display,
                             boundary=boundary, lattice="cartesian", density=None,
                             nonfinite=nonfinite, prefilter=prefilter, clamp=clamp,
                             highlight_compress=highlight_compress, threads=threads,
                             input_transfer=input_transfer, pyramid=True)
    except ValueError as e:  # the engine names siproject's option
        text = str(e)
        if not text.startswith("--mip: "):
            raise
        raise ValueError("pyramid(): " + text[len("--mip: "):]) from None
    return [a[:, :, 0] for a in levels] if _grey(input) else levels


def coefficients(input: Input, *, size: Optional[Size] = None,
                 output_shape: Optional[Tuple[int, int]] = None, factor: Optional[float] = None,
                 generator: Optional[str] = None, method: Optional[str] = None,
                 boundary: str = "mirror", lattice: str = "cartesian",
                 density: Optional[float] = None,
                 nonfinite: str = "error", prefilter: str = "fft",
                 highlight_compress: bool = False, threads: int = 0,
                 input_transfer: str = "auto", positions=None, weights=None,
                 rule: Optional[str] = None, iterations: Optional[int] = None,
                 lambda_=None, smoothness: Optional[int] = None, refined=None) -> "Coefficients":
    """The coefficients of the approximation, with their space.

    The keywords are project()'s (there is no display or clamp: those apply
    when the coefficients are resampled). The coefficients are kept in float,
    as a coefficient file stores them, so that resample() gives project()'s
    image exactly (of two dimensions for an array of two). Of scattered
    samples (positions=, or a file with position channels) the result's
    report says what the rule did.
    """
    _, k, _ = _form(input, True, size=size, output_shape=output_shape, factor=factor,
                    generator=generator, method=method, display=None, boundary=boundary,
                    lattice=lattice, density=density, nonfinite=nonfinite,
                    prefilter=prefilter, clamp="none", highlight_compress=highlight_compress,
                    threads=threads, input_transfer=input_transfer, positions=positions,
                    weights=weights, rule=rule, iterations=iterations, lambda_=lambda_,
                    smoothness=smoothness, refined=refined)
    return Coefficients(k, grey=_grey(input, positions))


def load(path: Union[str, "os.PathLike[str]"], *, nonfinite: str = "error",
         threads: int = 0) -> "Coefficients":
    """A coefficient file (siproject --coeffs, or Coefficients.save)."""
    if _text("nonfinite", nonfinite) not in ("error", "zero"):
        raise ValueError(f"--nonfinite '{nonfinite}': expected error or zero")
    return Coefficients(_core._load(_path("path", path), nonfinite == "zero", _threads(threads)))


def partial(input: Input, out: Union[str, "os.PathLike[str]"], *,
            bands: Optional[Tuple[int, int]] = None, rows: Optional[Tuple[int, int]] = None,
            grid_rows: Optional[int] = None, size: Optional[Size] = None,
            output_shape: Optional[Tuple[int, int]] = None, factor: Optional[float] = None,
            generator: Optional[str] = None, method: Optional[str] = None,
            boundary: str = "mirror", lattice: str = "cartesian",
            density: Optional[float] = None, nonfinite: str = "error", prefilter: str = "fft",
            highlight_compress: bool = False, threads: int = 0,
            input_transfer: str = "auto") -> None:
    """Writes to `out` (.exr) the partial acquisition of some row bands of a
    grid, as siproject --partial does, for merge() (or siproject --merge).

    input: a file (a band render: the rows its data window holds within its
        display window, as siproject --partial reads it) or an array (height,
        width[, channels]), the whole grid.
    bands=(first, count): the grid's bands of band_rows (256) rows to take,
        or rows=(first, count) the same in rows (whole bands: first a
        multiple of 256, the end one or the grid's end; band_cuts() says
        where); from a file, those rows are read into memory first (the
        file must hold them). None: all the input holds.
    grid_rows: the array holds only the rows of bands= or rows=, of a grid
        of grid_rows rows.
    The other keywords are project()'s, as siproject --partial's options:
    every partial of one merge is made with the same (they are recorded
    in the file, and merge() refuses partials of different ones).
    """
    factor_spelling = "" if factor is None else str(factor)
    density_spelling = "" if density is None else str(density)
    if bands is not None and rows is not None:
        raise ValueError("give bands=(first, count) or rows=(first, count), not both")
    b = None if bands is None else _pair("bands", bands, "(first, count)")
    r = None if rows is None else _pair("rows", rows, "(first, count)")
    g = None if grid_rows is None else _whole("grid_rows", grid_rows, _LONG_RANGE)
    warnings = _core._partial(
        _samples(input), _path("out", out), bands=b, rows=r, grid_rows=g,
        size=_size(size, output_shape, factor),
        factor=_number("factor", factor, optional=True), factor_spelling=factor_spelling,
        generator=_text("generator", generator, optional=True),
        method=_text("method", method, optional=True),
        boundary=_text("boundary", boundary), lattice=_text("lattice", lattice),
        density=_number("density", density, optional=True), density_spelling=density_spelling,
        nonfinite=_text("nonfinite", nonfinite), prefilter=_text("prefilter", prefilter),
        highlight_compress=_flag("highlight_compress", highlight_compress),
        threads=_threads(threads), input_transfer=_text("input_transfer", input_transfer))
    for w in warnings:
        _warnings.warn(w, RuntimeWarning, stacklevel=2)


def merge(paths: Sequence[Union[str, "os.PathLike[str]"]], *, threads: int = 0) -> "Coefficients":
    """The partial files of every band of one grid (partial() or siproject
    --partial), in any order, added and prefiltered once: the single run's
    coefficients, bit for bit, as siproject --merge makes them. Their
    resample() is siproject --merge's image (--clamp local is siproject's
    only). Partials that overlap, leave a gap or were made with other
    options are a ValueError naming them."""
    if isinstance(paths, (str, os.PathLike)):
        raise _wrong("paths", paths, "a sequence of paths (the partial files)")
    names = [_path("paths", p) for p in paths]
    if not names:
        raise ValueError("merge(): no partial file")
    k, warnings = _core._merge(names, _threads(threads))
    for w in warnings:
        _warnings.warn(w, RuntimeWarning, stacklevel=2)
    return Coefficients(k)


def band_cuts(rows: int, parts: int) -> list:
    """Where to cut a grid of `rows` rows into `parts` runs of whole bands
    (siproject --band-cuts): the parts' first rows, then `rows`."""
    return list(_core._band_cuts(_whole("rows", rows, _LONG_RANGE), _whole("parts", parts, _LONG_RANGE)))


def sample_positions(pattern: str = "regular", *, seed: int = 0, size: Size,
                     rays_per_pixel: float, threads: int = 0) -> np.ndarray:
    """The positions of a sample pattern's rays, as the pipeline traces them
    (make SAMPLES=...) and siproject reads them from a render's metadata: an
    (N, 2) float64 array of (x, y) in output pixels, row by row of the
    pattern's grid (sample l * gw + i is pixel (i, l) of the render).

    pattern: "regular" (the pixel centres of the supersampled render),
    "jitter" (one uniform sample in each cell of its grid) or "sobol"
    (Owen-scrambled Sobol' points over the frame); seed: which scramble or
    jitter (the regular grid has none); size: the frame, N, (width, height)
    or "WxH"; rays_per_pixel: any positive number; the grid is
    floor(W f + 1/2) x floor(H f + 1/2) for f = sqrt(rays_per_pixel).
    """
    name = _text("pattern", pattern)
    s = _whole("seed", seed, (0, 2**64 - 1))
    text = _size(size)
    if not text:
        raise ValueError("size: the frame is needed, N, (width, height) or \"WxH\"")
    try:
        w, h = (int(v) for v in text.split("x"))
    except ValueError:
        raise ValueError(f"size={size!r}: expected N, (width, height) or \"WxH\"") from None
    r = _number("rays_per_pixel", rays_per_pixel)
    if not r > 0 or r != r or r == float("inf"):
        raise ValueError(f"rays_per_pixel={r}: not a positive number")
    return _core._sample_positions(name, s, w, h, float(np.sqrt(r)), _threads(threads))


def refine(input: Union[str, "os.PathLike[str]"], *, rays: float, refine_rays: Optional[int] = None,
           share: Optional[float] = None, tile: int = 8, estimator: str = "residual",
           threads: int = 0) -> dict:
    """Where an adaptive render's second pass puts its rays (sirays refine;
    docs/design.md section 17).

    input: the first pass, a sobol render of the same whole number of rays
    in every pixel (make SAMPLES=sobol with a whole FACTOR), projected
    min-error cubic by the fit; each tile of tile x tile output pixels gets
    the estimator's estimate of its error ("residual", "halves", "contrast"
    or "highpass"), and the tiles of the largest estimates are refined while
    both passes' rays fit rays per output pixel over the frame. refine_rays:
    a refined pixel's rays, or share: the fraction of the frame's pixels
    refined (0, 1], or neither: the tool's choice (the count up to max(64,
    rays) that leaves the least estimate, a tile's error taken to fall as 1 /
    its rays).

    Returns a dict: text (the refinement, as sirays refine writes it: give it
    to sirays mesh/assemble --refinement), tiles (the refined tiles' indices,
    row-major), tile, rays (a refined pixel's), base_rays, extra_rays (the
    second pass's), rays_per_pixel (both passes' over the frame) and
    estimates (a float64 array, tile rows x tile columns).
    """
    path = _path("input", input)
    r = _number("rays", rays)
    if not r > 0 or r != r or r == float("inf"):
        raise ValueError(f"rays={r}: expected the rays per output pixel over the frame, a number > 0")
    rr = None if refine_rays is None else _whole("refine_rays", refine_rays)
    sh = _number("share", share, optional=True)
    return _core._refine(path, r, rr, sh, _whole("tile", tile), _text("estimator", estimator),
                         _threads(threads))


def frame_weights(times: Sequence[float], *, fps: float, time: float, shutter: str = "180:0",
                  shutter_curve: str = "box", degree: int = 3, step: Optional[float] = None,
                  model: str = "cubic", method: str = "min-error") -> np.ndarray:
    """The weights of the sub-frames at `times` (seconds, increasing) in the
    frame at `time` seconds of a space-time projection (siproject --fps;
    docs/design.md section 16): the frame is sum_k w[k] times sub-frame k's
    spatial coefficients (or, the display being linear, its image), so
    frames from the same sub-frames differ by their weights alone.

    fps: the output rate (it sets the shutter's length); shutter: "ANGLE[:PHASE]"
    in degrees (siproject --shutter); shutter_curve: "box", "tent", "cubic" or a
    table file; degree: the temporal B-spline's, 0..3; step: the temporal
    lattice step in seconds (None: the sub-frames' mean spacing, as siproject's
    default); model: how the sub-frames stand
    for the scene between their times, "hold", "linear" or "cubic"
    (siproject --time-model); method: "min-error", or "conventional" for the
    average of the sub-frames within the shutter, weighted by the curve.
    A float64 array of len(times), summing to 1.
    """
    t = [float(x) for x in np.asarray(times, dtype=np.float64).ravel()]
    r = _number("fps", fps)
    T = _number("time", time)
    s = _number("step", step, optional=True)
    m = _text("method", method)
    if m not in ("min-error", "conventional"):
        raise ValueError(f"method={method!r}: expected \"min-error\" or \"conventional\"")
    if not (r > 0 and math.isfinite(r)):
        raise ValueError(f"fps={fps!r}: not a positive number")
    if s is not None and not (s > 0 and math.isfinite(s)):
        raise ValueError(f"step={step!r}: not a positive number of seconds")
    try:
        w = _core._frame_weights(t, r, T, _text("shutter", shutter),
                                 _text("shutter_curve", shutter_curve),
                                 _whole("degree", degree, (0, 3)), 0.0 if s is None else s,
                                 _text("model", model), m == "conventional")
    except ValueError as e:
        # the engine's messages name siproject's options; here the keywords
        text = str(e)
        for option, keyword in (("--time-model", "model"), ("--shutter-curve", "shutter_curve"),
                                ("--time-step", "step"), ("--shutter", "shutter")):
            text = text.replace(option + ": " + option[2:] + ": ", keyword + ": ")
            text = text.replace(option, keyword)
        raise ValueError(text) from None
    return np.asarray(w, dtype=np.float64)



def _path(name: str, path) -> str:
    if not isinstance(path, (str, os.PathLike)):
        raise _wrong(name, path, "a path (str or os.PathLike)")
    p = os.fspath(path)
    if not isinstance(p, str):
        raise _wrong(name, path, "a path (str or os.PathLike of str)")
    return p


class Coefficients:
    """An approximation f_app(x) = sum_n c[n] phi(x - x_n) in its space.

    lattice ("cartesian" or "hexagonal"), generator, method, boundary, frame
    (width, height in output pixels), channel_names and array (the
    coefficient grid, (rows, columns, channels) float64, a copy) describe it.
    report: of scattered samples, a dict of what the rule did: rule,
    iterations (the fit's conjugate-gradient iterations run), residual (per
    channel, ||b - G c|| / ||b|| at the end), passes (over the samples) and
    bytes (the rule's working grids); None otherwise.
    """

    def __init__(self, core: "_core.Coefficients", *, grey: bool = False):
        self._k = core
        self._grey = grey  # from an array of two dimensions: resample() gives two

    lattice = property(lambda self: self._k.lattice)
    generator = property(lambda self: self._k.generator)
    method = property(lambda self: self._k.method)
    boundary = property(lambda self: self._k.boundary)
    frame = property(lambda self: tuple(self._k.frame))
    channel_names = property(lambda self: list(self._k.channel_names))
    array = property(lambda self: self._k.array)
    report = property(lambda self: self._k.report)

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
                 clamp: str = "none", *,
                 output_shape: Optional[Tuple[int, int]] = None) -> np.ndarray:
        """The final image at size (N, (width, height), or a string as
        siproject's --size spells it against the frame: "960", "0x540",
        "50%"; or output_shape (rows, cols); None: the frame's), sampled by display (None: 2x2 for
        min-error, centred for conventional), as float32 (height, width,
        channels), or (height, width) for coefficients of an array of two
        dimensions."""
        image = self._k._resample(_size(size, output_shape),
                                  _text("display", display, optional=True) or "",
                                  _text("clamp", clamp))
        return image[:, :, 0] if self._grey else image

    def save(self, path: Union[str, "os.PathLike[str]"]) -> None:
        """Writes a coefficient file (float EXR with the space in its
        metadata), as siproject --coeffs does."""
        self._k._save(_path("path", path))


def highpass_share(image: np.ndarray, cutoff: Union[float, Sequence[float]] = 0.25):
    """Share of the luminance's DFT energy (mean removed) above `cutoff`
    cycles per pixel (one number, or a list for a list of cutoffs)."""
    a = _image(image)
    single = np.ndim(cutoff) == 0
    cutoffs = [cutoff] if single else list(cutoff)
    shares = _core._highpass_shares(a, [_number("cutoff", c) for c in cutoffs])
    return shares[0] if single else list(shares)


def rms_difference(a: np.ndarray, b: np.ndarray, *, border: int = 0) -> float:
    """RMS over every channel of a - b, leaving out `border` pixels along
    each edge (images of one size)."""
    return _core._rms_difference(_image(a), _image(b), _whole("border", border, _LONG_RANGE))


def psnr(a: np.ndarray, b: np.ndarray, *, peak: float = 1.0, border: int = 0) -> float:
    """20 log10(peak / rms_difference(a, b)) in dB (infinite when equal)."""
    return _core._psnr(_image(a), _image(b), _number("peak", peak),
                       _whole("border", border, _LONG_RANGE))


def _coefficients(k) -> "_core.Coefficients":
    if not isinstance(k, Coefficients):
        raise _wrong("k", k, "a Coefficients (siproject.coefficients() or load())")
    return k._k


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
        self._r = _core.L2Reference(_image(truth), _number("border", border), _threads(threads))

    border = property(lambda self: self._r.border)
    array = property(lambda self: self._r.array)

    def l2_error(self, k: Coefficients) -> float:
        """Continuous L2 error of k's approximation against this reference."""
        return self._r._l2_error(_coefficients(k))

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
    border = _number("border", border, optional=True)
    if isinstance(truth, Reference):
        if border is not None and border != truth.border:
            raise ValueError(f"l2_error(): border {border:g} given with a Reference made with "
                             f"border {truth.border:g}")
        return truth.l2_error(k)
    return _core._l2_error(_coefficients(k), None if truth is None else _image(truth),
                           _number("zoneplate", zoneplate, optional=True),
                           _whole("samples_per_pixel", samples_per_pixel),
                           0.0 if border is None else border)


def overshoot(output: np.ndarray, input: np.ndarray, *, neighbourhood: float = 1.0,
              tolerance: float = 1e-6, border: int = 0) -> dict:
    """How far `output` leaves the range of the input samples under each of
    its pixels (the same frame, any ratio): a dict of max_overshoot,
    max_undershoot, pixels, pixels_out_of_range, negative_pixels,
    negative_energy, min and max."""
    return _core._overshoot(_image(output), _image(input),
                            _number("neighbourhood", neighbourhood),
                            _number("tolerance", tolerance), _whole("border", border, _LONG_RANGE))


def luminance(image: np.ndarray) -> np.ndarray:
    """Rec. 709 luminance of linear RGB (channel 0 for one or two channels)."""
    return _core._luminance(_image(image))


def srgb8(image: np.ndarray) -> np.ndarray:
    """Linear values as the 8-bit sRGB an 8-bit output file holds (every
    channel encoded and clamped to [0, 1]), uint8 of the same shape."""
    encoded = _core._srgb8(_image(image))
    return encoded[:, :, 0] if _grey(image) else encoded


def read_image(path: Union[str, "os.PathLike[str]"]) -> np.ndarray:
    """An image file as float32 (height, width, channels), read by
    OpenImageIO as siproject reads it (integer sRGB files decoded to linear)."""
    return _core._read_image(_path("path", path))


_DTYPES = {"uint8": "uint8", "uint16": "uint16", "half": "half", "float": "float",
           np.dtype(np.uint8): "uint8", np.dtype(np.uint16): "uint16",
           np.dtype(np.float16): "half", np.dtype(np.float32): "float"}


def _dtype(dtype, half: bool) -> str:
    """write_image's sample type: "" for the format's default."""
    if dtype is None:
        return "half" if half else ""
    if isinstance(dtype, str):
        if dtype not in _DTYPES:
            raise ValueError(f'dtype={dtype!r}: expected "uint8", "uint16", "half" or "float"')
        name = dtype
    else:
        try:
            name = _DTYPES.get(np.dtype(dtype))
        except TypeError:
            name = None
        if name is None:
            raise _wrong("dtype", dtype, '"uint8", "uint16", "half", "float" (or numpy\'s uint8, '
                                         'uint16, float16, float32) or None')
    if half and name != "half":
        raise ValueError(f"half=True and dtype={dtype!r}: give one")
    return name


def write_image(path: Union[str, "os.PathLike[str]"], image: np.ndarray, *,
                channel_names: Sequence[str] = (), alpha: int = -1, half: bool = False,
                dtype=None, compression: Optional[str] = None,
                quality: Optional[int] = None) -> None:
    """Writes an image as siproject writes its outputs. `dtype` is the
    file's sample type, as siproject's -d: "uint8" or "uint16" (or numpy's
    uint8, uint16), sRGB-encoded and clamped to [0, 1]; "half" or "float"
    (float16, float32), linear. None: the format's default, float for EXR
    (and the other float formats), uint8 for PNG, JPEG, TIFF... `half=True`
    is dtype="half": magnitudes past half's largest value, 65504, are
    clamped there with a RuntimeWarning, as siproject -d half does.
    `compression` ("zip", "piz", "dwaa:45", "lzw", "jpeg:90"...) and
    `quality` (1 to 100) as siproject's --compression and --quality; a type
    the format does not hold, or a compression its writer does not take, is
    a ValueError. The file replaces an existing one only once written whole;
    a signal that ends the process meanwhile (SIGTERM, SIGHUP...) removes the
    partial file."""
    if isinstance(channel_names, str) or not all(isinstance(n, str) for n in channel_names):
        raise _wrong("channel_names", channel_names, "a sequence of strings")
    half = _flag("half", half)
    kind = _dtype(dtype, half)
    if compression is not None and not isinstance(compression, str):
        raise _wrong("compression", compression, 'a string ("zip", "piz", "lzw", "jpeg:90"...) or None')
    if quality is not None and (_is_bool(quality) or not isinstance(quality, numbers.Integral)):
        raise _wrong("quality", quality, "a whole number 1 to 100 (int) or None")
    if quality is not None and not 1 <= quality <= 100:
        raise ValueError(f"quality={quality!r}: expected 1 to 100")
    try:
        clamped = _core._write_image(_path("path", path), _image(image), list(channel_names),
                                     _whole("alpha", alpha), kind, compression or "",
                                     int(quality or 0))
    except ValueError as e:  # half=True asked for the type: named as the caller spelt it
        if dtype is None and str(e).startswith("dtype='half': "):
            raise ValueError("half=True: " + str(e)[len("dtype='half': "):]) from None
        raise
    if clamped:
        _warnings.warn(f"write_image(): half=True: {clamped} samples beyond +-65504 clamped there",
                       RuntimeWarning, stacklevel=2)
