"""Absurd or huge inputs run in bounded memory, or are refused at once (issue 37).

200,000 two-point strokes (4 MB of JSON) ran `fluidnb animate` out of memory after
56 s: every stroke gave two tangent samples however far the spacing grew, and the
RBF fit over 400,000 samples needs O(m^2) memory. A 182 KiB PNG of 8000 x 8000 black
pixels ran flicker for 79 s and died of memory under a 4 GiB cap. Each case runs in
a subprocess whose address space is capped, so a regression fails here instead of
taking the machine down.
"""

from __future__ import annotations

import json
import subprocess
import sys
import textwrap

import numpy as np
import pytest

pytestmark = pytest.mark.skipif(sys.platform != "linux", reason="RLIMIT_AS as on Linux")

CAPPED = """
import resource, sys
cap = {cap} << 30
resource.setrlimit(resource.RLIMIT_AS, (cap, cap))
sys.argv = ["fluidnb", *{argv!r}]
"""


def _run_capped(code, cap_gib, cwd):
    return subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, check=False, cwd=cwd
    )


def _strokes_file(path, n, shape=(480, 640), seed=0):
    """``n`` strokes of two points, 3 px long, rightwards in the top half, left below."""
    h, w = shape
    gen = np.random.default_rng(seed)
    starts = gen.uniform([0, 0], [h, w - 4], (n, 2)).round(2)
    step = np.where(starts[:, :1] < h / 2, 3.0, -3.0) * np.array([[0.0, 1.0]])
    strokes = np.stack([starts, starts + step], axis=1).clip(0, [h - 1, w - 1])
    data = {"format": "fluidnb.strokes", "version": 1, "shape": [h, w], "strokes": strokes}
    path.write_text(json.dumps({**data, "strokes": strokes.tolist()}))
    return path


def test_200000_short_strokes_make_a_direction_field_in_bounded_memory(tmp_path):
    path = _strokes_file(tmp_path / "many.json", 200_000)
    assert path.stat().st_size > 4e6
    code = CAPPED.format(cap=3, argv=[]) + textwrap.dedent(
        f"""
        import numpy as np
        from fluidnb.sketch import direction_field, load_strokes
        strokes, shape = load_strokes({str(path)!r})
        field = direction_field(strokes, shape)
        top, bottom = field[40:200, :, 1], field[280:440, :, 1]
        print(float(np.median(top)), float(np.median(bottom)), float((top > 0.9).mean()))
        """
    )
    run = _run_capped(code, 3, tmp_path)
    assert run.returncode == 0, run.stderr[-2000:]
    top, bottom, share = (float(x) for x in run.stdout.split())
    assert top > 0.99
    assert bottom < -0.99
    assert share > 0.99
