"""Repository-wide pytest configuration (doctests of the library run with the tests)."""

import os

import pytest

# fluidnb/widgets is a symlink to widgets/ (collected there); __main__ would run the CLI.
collect_ignore = ["fluidnb/widgets", "fluidnb/__main__.py", "dev.py", "binder", "notebooks"]


@pytest.fixture(autouse=True, scope="session")
def _private_cache(tmp_path_factory):
    """Flows the library caches on disk (the turbulence sample) go to a test folder."""
    if "FLUIDNB_CACHE_DIR" in os.environ:
        yield
        return
    os.environ["FLUIDNB_CACHE_DIR"] = str(tmp_path_factory.mktemp("fluidnb-cache"))
    try:
        yield
    finally:
        os.environ.pop("FLUIDNB_CACHE_DIR", None)
