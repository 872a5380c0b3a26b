"""Virtual walls and tracks are drawn as separate segments, at every count (issue 34): each
segment and each of its end caps is a path of its own, so two or more lines never fill the
floor between them. Counted in the map canvas's own pixels."""

from __future__ import annotations

import math

from tests.web.conftest import Console

NODE = "/slamware_ros_sdk_server_node"
WALL = (0xFF, 0x17, 0x44)   # COLORS.wall
TRACK = (0x00, 0xB8, 0xD4)  # COLORS.track
LENGTH = 5.0                # metres, each line
WIDTH = 3                   # CSS px, LinesLayer's width for walls and tracks
USAGE = {"wall": 0, "track": 1}
TOPIC = {"wall": f"{NODE}/virtual_walls", "track": f"{NODE}/virtual_tracks"}

# how many canvas pixels near (x, y) metres have `rgb`, within `radius` canvas px; with
# `box` [x0, y0, x1, y1] metres instead, how many in that rectangle (plus `pad` px around)
# and, given `lines` and `away`, how many of those lie off every line
COUNT = """([rgb, tol, where]) => {
  const v = window.hitrobot.view;
  let x0, y0, x1, y1;
  if (where.box) {
    const a = v.rosToCanvas(where.box[0], where.box[1]);
    const b = v.rosToCanvas(where.box[2], where.box[3]);
    x0 = Math.min(a.x, b.x) - where.pad; x1 = Math.max(a.x, b.x) + where.pad;
    y0 = Math.min(a.y, b.y) - where.pad; y1 = Math.max(a.y, b.y) + where.pad;
  } else {
    const c = v.rosToCanvas(where.x, where.y);
    x0 = c.x - where.radius; x1 = c.x + where.radius;
    y0 = c.y - where.radius; y1 = c.y + where.radius;
  }
  x0 = Math.max(0, Math.floor(x0)); y0 = Math.max(0, Math.floor(y0));
  x1 = Math.min(v.canvas.width, Math.ceil(x1)); y1 = Math.min(v.canvas.height, Math.ceil(y1));
  if (x1 <= x0 || y1 <= y0) return 0;
  // read a copy, so the page's own canvas is never read back (Chromium warns when it is)
  const copy = document.createElement('canvas');
  copy.width = x1 - x0; copy.height = y1 - y0;
  const c2 = copy.getContext('2d', { willReadFrequently: true });
  c2.drawImage(v.canvas, x0, y0, x1 - x0, y1 - y0, 0, 0, x1 - x0, y1 - y0);
  const d = c2.getImageData(0, 0, x1 - x0, y1 - y0).data;
  // with `away`, only the pixels farther than `away` canvas px from every one of `lines`
  const segs = (where.lines || []).map(([a, b]) => [v.rosToCanvas(...a), v.rosToCanvas(...b)]);
  const far = (px, py) => segs.every(([a, b]) => {
    const dx = b.x - a.x, dy = b.y - a.y, len2 = dx * dx + dy * dy;
    const t = len2 ? Math.max(0, Math.min(1, ((px - a.x) * dx + (py - a.y) * dy) / len2)) : 0;
    return Math.hypot(px - a.x - t * dx, py - a.y - t * dy) > where.away;
  });
  let n = 0;
  for (let i = 0; i < d.length; i += 4) {
    if (Math.abs(d[i] - rgb[0]) <= tol && Math.abs(d[i + 1] - rgb[1]) <= tol &&
        Math.abs(d[i + 2] - rgb[2]) <= tol) {
      const j = i / 4, px = x0 + (j % (x1 - x0)) + 0.5, py = y0 + Math.floor(j / (x1 - x0)) + 0.5;
      if (!segs.length || far(px, py)) n++;
    }
  }
  return n;
}"""
TOLERANCE = 40


def layout(bounds: dict) -> list[tuple[tuple[float, float], tuple[float, float]]]:
    """Three 5 m lines inside the map: two parallel 4 m apart and one across their right ends,
    0.5 m away from them, so the point between the three is 2 m or more from every line."""
    x0 = bounds["x"] + bounds["w"] / 2 - 3.5
    y0 = bounds["y"] + bounds["h"] / 2 - 2.0
    return [((x0, y0), (x0 + LENGTH, y0)),
            ((x0, y0 + 4.0), (x0 + LENGTH, y0 + 4.0)),
            ((x0 + LENGTH + 2.0, y0 - 0.5), (x0 + LENGTH + 2.0, y0 + 4.5))]


async def add_lines(console: Console, watcher, kind: str, lines, total: int) -> None:
    await watcher.subscribe(TOPIC[kind], "slamware_ros_sdk/Line2DFlt32Array")
    for (ax, ay), (bx, by) in lines:
        await watcher.publish(f"{NODE}/add_line", {
            "usage": {"usage": USAGE[kind]},
            "line": {"id": 0, "start": {"x": ax, "y": ay}, "end": {"x": bx, "y": by}}},
            "slamware_ros_sdk/AddLineRequest")
    layer = "walls" if kind == "wall" else "tracks"
    await console.page.wait_for_function(
        "([layer, n]) => window.hitrobot.layers[layer].lines.length === n",
        arg=[layer, total], timeout=10_000)
    await console.frame()


async def count(console: Console, rgb, **where) -> int:
    return await console.page.evaluate(COUNT, [list(rgb), TOLERANCE, where])


async def check_segments(console: Console, watcher, kind: str) -> dict:
    page = console.page
    rgb = WALL if kind == "wall" else TRACK
    bounds = await page.evaluate("() => window.hitrobot.view.mapBounds")
    lines = layout(bounds)
    xs = [p[0] for line in lines for p in line]
    ys = [p[1] for line in lines for p in line]
    box = [min(xs), min(ys), max(xs), max(ys)]
    scale, dpr = await page.evaluate(
        "() => [window.hitrobot.view.scale, window.hitrobot.view.dpr]")
    before = await count(console, rgb, box=box, pad=12)
    off_before = await count(console, rgb, box=box, pad=12, lines=lines, away=WIDTH * dpr + 2)

    # one line alone: drawn along its length, nothing beside it
    await add_lines(console, watcher, kind, lines[:1], 1)
    (ax, ay), (bx, by) = lines[0]
    near = await count(console, rgb, x=(ax + bx) / 2, y=(ay + by) / 2, radius=8)
    assert near > 0, f"one {kind}: nothing drawn at its midpoint"

    # three lines: each drawn, nothing at the point between them, and about as many pixels
    # as three segments of that width cover, far below a filled shape across the floor
    await add_lines(console, watcher, kind, lines[1:], 3)
    for (ax, ay), (bx, by) in lines:
        mid = await count(console, rgb, x=(ax + bx) / 2, y=(ay + by) / 2, radius=8)
        assert mid > 0, f"three {kind}s: nothing drawn at the midpoint of {(ax, ay)}–{(bx, by)}"
    cx = sum((a[0] + b[0]) / 2 for a, b in lines) / 3
    cy = sum((a[1] + b[1]) / 2 for a, b in lines) / 3
    centre = await count(console, rgb, x=cx, y=cy, radius=6)
    total = await count(console, rgb, box=box, pad=12) - before
    # off the lines: farther from each than its cap's radius and a pixel of antialiasing
    off = await count(console, rgb, box=box, pad=12, lines=lines,
                      away=WIDTH * dpr + 2) - off_before
    width = WIDTH * dpr
    cap = math.pi * (0.9 * width) ** 2
    segments = 3 * (LENGTH * scale * width + 2 * cap)
    filled = (box[2] - box[0]) * (box[3] - box[1]) * scale ** 2
    figures = {"kind": kind, "pixels": total, "segments": round(segments),
               "box": round(filled), "scale": scale, "centre": centre, "off": off}
    print(figures)
    assert centre == 0 and off == 0, f"three {kind}s fill the floor between them: {figures}"
    assert 0 < total < 2 * segments, figures
    assert total < filled / 10, figures
    return figures


async def test_walls_are_separate_segments(console: Console, watcher):
    await check_segments(console, watcher, "wall")
    assert console.errors == []


async def test_tracks_are_separate_segments(console: Console, watcher):
    await check_segments(console, watcher, "track")
    assert console.errors == []
