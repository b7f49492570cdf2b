"""Files a user keeps are created as every other file is: mode 0666 (folders 0777) less the umask.

``tempfile.mkstemp`` creates 0600: the turbulence sample cache written through it could
not be read by the other users of a shared cache folder (issue 37; the video database's
manifest is the same case, fixed with the videodb split).
"""

from __future__ import annotations

import stat
from pathlib import Path

import numpy as np

from fluidnb import Clip


def _mode(path):
    return stat.S_IMODE(path.stat().st_mode)


def test_every_file_we_write_respects_the_umask(tmp_path, umask_002, monkeypatch, capsys):
    from fluidnb.cli import main
    from fluidnb.sketch import save_strokes
    from fluidnb.turbulence import Flow
    from fluidnb.turbulence._flows import _write_pair

    clip = Clip(np.zeros((2, 8, 8), np.float32), fps=5)
    written = [clip.save(tmp_path / f"c{ext}") for ext in (".npz", ".gif", ".mp4")]
    written.append(tmp_path / "c.mp4.json")
    folder = clip.save(tmp_path / "frames")
    written += sorted(folder.iterdir())
    written.append(save_strokes(tmp_path / "s.json", [[[1, 1], [5, 5]]], (8, 8)))
    flow = Flow(np.zeros((2, 4, 4, 2), np.float32), np.zeros((2, 4, 4), np.float32), 1.0)
    written.append(flow.save(tmp_path / "flow.npz"))
    cache = tmp_path / "cache" / "pair.npz"
    _write_pair(cache, (flow, flow))
    written.append(cache)
    assert main(["sample", "ripples", "--size", "16", "-o", str(tmp_path / "ripples.png")]) == 0
    written.append(tmp_path / "ripples.png")
    modes = {Path(p).name: oct(_mode(Path(p))) for p in written}
    assert modes == dict.fromkeys(modes, oct(0o664))
    assert oct(_mode(folder)) == oct(0o775)
    assert oct(_mode(cache.parent)) == oct(0o775)
    assert not list(tmp_path.rglob("*partial*"))
