#!/usr/bin/env python3
"""The page of an animation (make anim): the space-time frames and the
sub-frame average side by side as animated WebPs, with their MP4s and the
options each was made with.

    anim_page.py --dir D --fps R --render-fps R0 --scene S --subframes N
        --spacetime OPTS [--average OPTS] -o D/index-Rfps.html
"""
import argparse
import html
import os
import sys

import atomic


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--dir", required=True)
    p.add_argument("--fps", required=True)
    p.add_argument("--scene", required=True)
    p.add_argument("--spacetime", required=True)
    p.add_argument("--average", help="the average's options (frames at the rendered rate only)")
    p.add_argument("--render-fps", required=True)
    p.add_argument("--subframes", type=int, required=True, help="the sub-frames the frames were formed from")
    p.add_argument("-o", "--output", required=True)
    a = p.parse_args(argv)
    cells = []
    kinds = [("spacetime", a.spacetime, "space-time min-error projection")]
    if a.average is not None:
        kinds.append(("average", a.average, "sub-frame average within the shutter (conventional box)"))
    for kind, opts, what in kinds:
        name = f"{kind}-{a.fps}fps"
        frames = len([f for f in os.listdir(os.path.join(a.dir, name)) if f.endswith(".png")])
        cells.append(
            f'<figure><img src="{name}.webp" alt="{html.escape(what)}">'
            f"<figcaption><b>{html.escape(what)}</b>: {frames} frames at {html.escape(a.fps)} fps "
            f'(<a href="{name}.mp4">MP4</a>, <a href="{name}/">PNG frames</a>)<br>'
            f"<code>siproject sub.*.exr {html.escape(opts)}</code></figcaption></figure>"
        )
    note = (" two ways" if a.average is not None else
            " by the space-time projection alone: at another rate than the rendered one, or with a "
            "shutter shorter than a sub-frame's cell, a frame's shutter may hold no sub-frame to average")
    page = f"""<!doctype html>
<html><head><meta charset="utf-8"><title>{html.escape(a.scene)}: animation at {html.escape(a.fps)} fps</title>
<style>body {{ font-family: sans-serif; margin: 1.5em; }} figure {{ display: inline-block; margin: 0 1.5em 1em 0; vertical-align: top; max-width: 46%; }}
img {{ image-rendering: pixelated; width: 100%; }} code {{ font-size: 0.85em; }}</style></head>
<body><h1>{html.escape(a.scene)}: animation at {html.escape(a.fps)} fps</h1>
<p>{a.subframes} sub-frames rendered by POV-Ray (<code>sub.0000.exr</code> ...,
each with its time in <code>sis:time</code>) for {html.escape(a.render_fps)} fps, formed into frames by <code>siproject --fps</code>{note}.
docs/design.md section 16 says what the space-time projection computes.</p>
{''.join(cells)}
</body></html>
"""
    atomic.write_atomic(a.output, page)
    return 0


if __name__ == "__main__":
    sys.exit(main())
