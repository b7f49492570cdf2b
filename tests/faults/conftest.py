"""Fixtures of the fault tests."""

import os
import subprocess

import pytest


@pytest.fixture
def small_disk(tmp_path):
    """``small_disk(size)``: a tmpfs of ``size`` ("64k") in the test's folder, unmounted after.

    Skips the test where this process may not mount one (root may).
    """
    mounted = []

    def make(size, name="disk"):
        folder = tmp_path / name
        folder.mkdir()
        mount = subprocess.run(
            ["mount", "-t", "tmpfs", "-o", f"size={size}", "tmpfs", str(folder)],
            capture_output=True,
            check=False,
        )
        if mount.returncode != 0:
            pytest.skip(f"cannot mount a tmpfs here: {mount.stderr.decode().strip()}")
        mounted.append(folder)
        return folder

    yield make
    for folder in mounted:
        subprocess.run(["umount", str(folder)], check=False)


@pytest.fixture
def tiny_disk(small_disk):
    """A 64 KiB tmpfs: a full disk for anything but the smallest files."""
    return small_disk("64k", "tiny")


@pytest.fixture
def umask_002():
    """The umask 002 while the test runs (a shared group's), the old one after."""
    old = os.umask(0o002)
    try:
        yield
    finally:
        os.umask(old)
