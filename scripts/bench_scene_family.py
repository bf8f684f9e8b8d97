"""How fast an explorable page switches among its family, measured in the browser.

Opens each page in headless Chromium (the driver of tests/scenes/chromium.py) and moves the
first axis slider ``--switches`` times, each move made inside a requestAnimationFrame
callback (as a person's input lands between two frames). For each move it records the time
the input event took (the whole switch: the member's frames, trace, membrane, readouts,
chart and the WebGL draw happen inside it), the time to the next frame, and whether that
next frame already shows the new member (#scene-state). Prints per page: its size, the
members, and the median, minimum and maximum of both times.

Usage: .venv/bin/python scripts/bench_scene_family.py [PAGE ...] [--switches 60]
(default pages: data/scenes/{en02,en02r,compare}/index.html, built by `snakemake scenes`)
"""

from __future__ import annotations

import argparse
import json
import platform
import statistics
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO / "tests" / "scenes"))

MEASURE = """new Promise((done) => {
  const s = document.querySelector('input[type=range][data-key]');
  const n = Number(s.max) + 1, out = [];
  let k = 0;
  const step = () => requestAnimationFrame((t0) => {
    const target = (k * 7 + 3) % n;
    const h0 = performance.now();
    s.value = String(target); s.dispatchEvent(new Event('input'));
    const h1 = performance.now();
    requestAnimationFrame((t1) => {
      const st = JSON.parse(document.getElementById('scene-state').textContent);
      out.push({ next: st.member === target, handler: h1 - h0, frame: t1 - t0 });
      if (++k < SWITCHES) step(); else done(out);
    });
  });
  step();
})"""


def _stats(values: list[float]) -> str:
    return (f"median {statistics.median(values):.1f} ms (min {min(values):.1f}, "
            f"max {max(values):.1f})")


def main(argv: list[str] | None = None) -> int:
    from chromium import Browser

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("pages", nargs="*", type=Path)
    ap.add_argument("--switches", type=int, default=60)
    args = ap.parse_args(argv)
    pages = args.pages or [REPO / "data" / "scenes" / s / "index.html"
                           for s in ("en02", "en02r", "compare")]
    print(f"# {platform.node()}, {platform.processor() or platform.machine()}, headless "
          "Chromium (SwiftShader WebGL)")
    with Browser(width=1400, height=900) as b:
        for page in pages:
            b.open(page.resolve().as_uri() + "#t=60", settle=1.0)
            members = b.evaluate("JSON.parse(document.getElementById('scene-data')"
                                 ".textContent).family.size")
            rows = b.evaluate(MEASURE.replace("SWITCHES", str(args.switches)))
            errors = b.errors()
            nxt = sum(r["next"] for r in rows)
            print(f"{page}: {page.stat().st_size / 2**20:.2f} MB, {members} members, "
                  f"{args.switches} switches: new member drawn by the next frame in "
                  f"{nxt}/{len(rows)}; input handler {_stats([r['handler'] for r in rows])}; "
                  f"to the next frame {_stats([r['frame'] for r in rows])}"
                  + (f"; ERRORS {json.dumps([str(e) for e in errors])}" if errors else ""))
    return 0


if __name__ == "__main__":
    sys.exit(main())
