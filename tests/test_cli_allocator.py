"""The allocator settings ``fluidnb animate`` and ``fluidnb scene`` give their own process.

Issue 39: a 1920-px render frees and allocates 5-30 MB arrays every frame; glibc's
defaults gave each back and faulted fresh pages in (animate: 30 s of system time;
scene: 2.82 GB peak, 2.46 with the settings). Only the command's own process is
tuned: a notebook, or a test calling ``main(argv)``, keeps its allocator.
"""

import ctypes
import platform

import numpy as np
import pytest
from PIL import Image

from fluidnb import data
from fluidnb.cli import _common, _main, _scene, main


class _Libc:
    """Stands in for ``ctypes.CDLL(None)``: records ``mallopt(param, value)``."""

    def __init__(self):
        self.calls = []

    def mallopt(self, param, value):
        self.calls.append((param, value))
        return 1


@pytest.fixture
def libc(monkeypatch):
    fake = _Libc()
    monkeypatch.setattr(ctypes, "CDLL", lambda name: fake)
    return fake


def test_a_notebook_or_main_argv_keeps_its_allocator(libc, monkeypatch):
    monkeypatch.setattr(_main, "AS_PROCESS", False)
    _common.reuse_freed_memory()
    assert libc.calls == []


@pytest.mark.skipif(platform.libc_ver()[0] != "glibc", reason="glibc's mallopt")
def test_the_command_as_the_process_keeps_blocks_up_to_32_mb_in_one_arena(libc, monkeypatch):
    monkeypatch.setattr(_main, "AS_PROCESS", True)
    _common.reuse_freed_memory()
    # malloc.h: M_MMAP_THRESHOLD -3, M_TRIM_THRESHOLD -1, M_ARENA_MAX -8
    assert sorted(libc.calls) == sorted([(-3, 32 * 2**20), (-1, 2**31 - 1), (-8, 1)])


def test_the_scene_command_asks_for_it(tmp_path, monkeypatch, capsys):
    called = []
    monkeypatch.setattr(_scene, "reuse_freed_memory", lambda: called.append(True))
    photo = data.sample("lake", size=64)
    Image.fromarray((photo * 255).round().astype(np.uint8)).save(tmp_path / "lake.png")
    region = np.zeros(photo.shape[:2], np.uint8)
    region[: photo.shape[0] // 2, : photo.shape[1] // 3] = 255
    Image.fromarray(region).save(tmp_path / "frost.png")
    argv = ["scene", str(tmp_path / "lake.png"), "--frost", str(tmp_path / "frost.png")]
    assert main([*argv, "--size", "0", "-o", str(tmp_path / "s.npz")]) == 0
    assert called == [True]
    assert (tmp_path / "s.npz").exists()
