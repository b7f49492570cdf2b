"""Sample images for the methods: licensed photographs and procedural pictures."""

from ._samples import catalogue, data_dir, names, path, region, sample

__all__ = ["catalogue", "data_dir", "names", "path", "region", "sample"]
