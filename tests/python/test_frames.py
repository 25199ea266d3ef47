"""siproject.frame_weights and siproject --fps: the weights of the
sub-frames in a frame of a space-time projection. They sum to 1; the
conventional ones are the plain average within the shutter; the cubic model
integrates cubics in time exactly over any shutter, where the hold does so
only to O(h^2); and the frames siproject --fps writes are those weights
applied to each sub-frame's own still projection."""

import os
import subprocess

import numpy as np
import pytest

import siproject

SIPROJECT = os.environ.get("SIPROJECT", "siproject")


def regular(frames, k, fps):
    return np.array([(i + (j + 0.5) / k) / fps for i in range(frames) for j in range(k)])


def test_weights_sum_to_one_and_the_average_is_the_plain_one():
    t = regular(12, 4, 24)
    for model in ("hold", "linear", "cubic"):
        for degree in range(4):
            w = siproject.frame_weights(t, fps=24, time=5 / 24, degree=degree, model=model)
            assert w.shape == t.shape and w.dtype == np.float64
            assert abs(w.sum() - 1) < 1e-12, (model, degree)
    # 180 degrees at 24 fps, frame 5: open on [5/24, 5.5/24), sub-frames 20 and 21
    w = siproject.frame_weights(t, fps=24, time=5 / 24, method="conventional")
    want = np.zeros_like(t)
    want[20:22] = 0.5
    assert np.array_equal(w, want)


@pytest.mark.parametrize("shutter", ["180", "360", "90:45", "270:-135"])
def test_the_cubic_model_integrates_cubics_in_time_exactly(shutter):
    # uneven times (each inside its own quarter of the frame interval); the
    # first frame, the middle one and the last: the model's projection is on
    # the span itself, exact for cubics at its ends too (rounding of sums of
    # ~80 terms of size ~5: 1e-10)
    fps, k = 24.0, 4
    rng = np.random.default_rng(3)
    t = regular(20, k, fps) + (rng.random(20 * k) - 0.5) * 0.6 / (k * fps)
    angle, _, phase = shutter.partition(":")
    p = np.polynomial.Polynomial([0.3, -1.2, 2.5, -4.0])  # a cubic in t (seconds)
    P = p.integ()
    lo = t[0] - (t[1] - t[0]) / 2
    hi = t[-1] + (t[-1] - t[-2]) / 2
    frames = [f for f in range(-2, 22) if lo <= (f + float(phase or 0) / 360) / fps
              and (f + (float(phase or 0) + float(angle)) / 360) / fps <= hi]
    assert len(frames) >= 18
    for f in (frames[0], 10, frames[-1]):
        T = f / fps
        o = T + float(phase or 0) / 360 / fps
        c = o + float(angle) / 360 / fps
        exact = (P(c) - P(o)) / (c - o)
        cubic = siproject.frame_weights(t, fps=fps, time=T, shutter=shutter)
        assert abs(cubic @ p(t) - exact) < 1e-10, f
    T = 10 / fps
    o = T + float(phase or 0) / 360 / fps
    c = o + float(angle) / 360 / fps
    exact = (P(c) - P(o)) / (c - o)
    # the hold and the plain average are not exact for it
    hold = siproject.frame_weights(t, fps=fps, time=T, shutter=shutter, model="hold")
    average = siproject.frame_weights(t, fps=fps, time=T, shutter=shutter, method="conventional")
    assert abs(hold @ p(t) - exact) > 1e-6
    assert abs(average @ p(t) - exact) > 1e-6


def test_bad_requests_name_the_argument():
    t = regular(4, 2, 24)
    with pytest.raises(ValueError, match="^model: 'spline' is not a model"):
        siproject.frame_weights(t, fps=24, time=1 / 24, model="spline")
    with pytest.raises(ValueError, match="^model: "):
        siproject.frame_weights(t, fps=24, time=1 / 24, model="spline", method="conventional")
    with pytest.raises(ValueError, match="^shutter: angle 400 outside"):
        siproject.frame_weights(t, fps=24, time=1 / 24, shutter="400")
    with pytest.raises(ValueError, match="the hold model needs the sub-frames' span"):
        siproject.frame_weights(t[:2], fps=24, time=0.0, model="hold", degree=3, shutter="1")
    with pytest.raises(ValueError, match="at most 1e7"):
        siproject.frame_weights(t, fps=24, time=1 / 24, step=1e-12)
    with pytest.raises(ValueError, match="before the previous one"):
        siproject.frame_weights(t[::-1], fps=24, time=1 / 24)
    with pytest.raises(ValueError, match="the same time"):
        siproject.frame_weights([0.1, 0.1, 0.2], fps=24, time=0.1)
    with pytest.raises(ValueError, match="outside the sub-frames' span"):
        siproject.frame_weights(t, fps=24, time=10.0)
    with pytest.raises(ValueError, match="fps"):
        siproject.frame_weights(t, fps=0, time=0.0)
    with pytest.raises(ValueError, match="method"):
        siproject.frame_weights(t, fps=24, time=1 / 24, method="average")
    with pytest.raises(ValueError, match="degree"):
        siproject.frame_weights(t, fps=24, time=1 / 24, degree=4)
    with pytest.raises(ValueError, match="outside the sub-frames' span"):
        siproject.frame_weights(t, fps=24, time=float("nan"))
    with pytest.raises(ValueError, match="at least two"):
        siproject.frame_weights([0.1], fps=24, time=0.1)


def test_siprojects_frames_are_the_weights_applied_to_the_stills(tmp_path):
    # sub-frames written by numpy through the module, their times added by
    # oiiotool as a user would (a string attribute: a float one keeps 7 digits)
    fps, k, n = 24.0, 3, 6
    t = regular(n, k, fps)
    rng = np.random.default_rng(11)
    subs = []
    for i, ti in enumerate(t):
        raw = tmp_path / f"raw.{i:04d}.exr"
        siproject.write_image(str(raw), rng.random((16, 20, 3)).astype(np.float32))
        sub = tmp_path / f"sub.{i:04d}.exr"
        subprocess.run(["oiiotool", str(raw), "--attrib:type=string", "sis:time", repr(float(ti)),
                        "-o", str(sub)], check=True)
        subs.append(sub)
    out = tmp_path / "out"
    out.mkdir()
    run = subprocess.run([SIPROJECT, *map(str, subs), "--fps", "24", "--factor", "2", "-d", "float",
                          "-q", "-o", str(out / "f.#.exr")], capture_output=True, text=True)
    assert run.returncode == 0, run.stderr
    stills = [siproject.project(str(s), factor=2) for s in subs]
    frames = sorted(out.iterdir())
    assert len(frames) == n  # 180 degrees, phase 0: frames 0 .. n-1 inside the span
    for f, path in enumerate(frames):
        w = siproject.frame_weights(t, fps=fps, time=f / fps)
        want = sum(wk * s.astype(np.float64) for wk, s in zip(w, stills))
        got = siproject.read_image(str(path))
        # the tool sums coefficients in float and displays once; the sum of
        # displayed stills differs by float rounding only (values ~1, |w|
        # summing to < 2: a few 1e-7)
        assert np.max(np.abs(got - want)) < 2e-6, path
    md = subprocess.run(["oiiotool", "--info", "-v", str(frames[0])], capture_output=True,
                        text=True).stdout
    assert 'sis:time_model: "cubic"' in md
    assert 'sis:time_degree: "3"' in md
    # the still image's keys too (docs/siproject.md, Range report)
    for key in ("sis:input_transfer", "sis:highlight_compress", "sis:negative_before_clamp",
                "sis:out_of_range_before_clamp", "sis:output_min", "sis:clamp"):
        assert key + ":" in md, key
    assert 'sis:input_transfer: "linear"' in md


@pytest.mark.parametrize("model", ["hold", "linear", "cubic"])
def test_weights_stay_bounded_at_every_frame(model):
    # sum |w| is the factor by which a frame can amplify its sub-frames'
    # noise; on regular times every frame, the ends included, for every
    # degree and for steps from 0.37 of the frame interval to two frame
    # intervals: the orthogonal projection onto splines has a bounded norm
    # whatever the step (its dual functions' negative lobes), measured here at
    # most 1.60 (hold), 1.70 (linear), 1.71 (cubic), all at D = 3 and a
    # step of 2/fps; 2 bounds them. (The interpolating models once
    # extrapolated a whole step beyond the span's ends, where frame 0 reached
    # sum |w| = 68.)
    fps, k = 24.0, 8
    t = regular(12, k, fps)
    for degree in range(4):
        for step in (None, 1 / fps, 0.37 / fps, 2 / fps):
            for f in range(12):
                w = siproject.frame_weights(t, fps=fps, time=f / fps, degree=degree, step=step,
                                            model=model)
                assert np.abs(w).sum() < 2, (degree, step, f, np.abs(w).sum())
