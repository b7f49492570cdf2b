"""A scene's layer: one method, its region on the photo, its own parameters and inputs."""

from __future__ import annotations

import hashlib
import json
from dataclasses import dataclass, field, replace

import numpy as np

from .._params import Params
from .._validation import check_array

__all__ = ["KINDS", "Layer"]

#: The layers a scene can hold: kind -> (the method that animates it, how it is
#: composited over the layers under it, whether its clip loops).
#:
#: - ``water``, ``clouds``: the video database (Okabe et al. 2011) with the water or
#:   the smoke starter database; the result replaces the photo inside the region.
#: - ``flicker``: flicker (Yamamoto & Sakamoto), replaces inside the region.
#: - ``fire``: fire synthesised from an exemplar (Furukawa et al. 2013), added as
#:   light: it brightens what lies under it, and glows a little beyond its region.
#: - ``frost``: frost growing from start points (Amano et al.), covers what lies
#:   under it; it grows once and then holds.
KINDS = {
    "water": ("videodb", "replace", True),
    "clouds": ("videodb", "replace", True),
    "flicker": ("flicker", "replace", True),
    "fire": ("fire", "light", True),
    "frost": ("frost", "cover", False),
}


@dataclass(frozen=True, eq=False)
class Layer:
    """One animated region of a :class:`Scene`.

    Parameters
    ----------
    kind : str
        One of :data:`KINDS`.
    region : ndarray, shape (H, W)
        Where the layer acts: a painted mask (bool) or a soft matte in [0, 1], the
        photo's size.
    params : Params, optional
        The method's own parameter object (:class:`fluidnb.videodb.AnimateParams`,
        :class:`fluidnb.flicker.FlickerParams`, :class:`fluidnb.fire.FireParams`,
        :class:`fluidnb.frost.FrostParams`); None: the scene's defaults for the kind
        (:func:`fluidnb.scene.default_params`).
    strokes : list of ndarray (n, 2), optional
        Flow strokes, (row, col) photo pixels (water, clouds: the flow's direction).
    speed : ndarray, shape (H, W), optional
        Painted speed in px/frame, 0 = not painted (water, clouds).
    starts : ndarray, shape (n, 2), optional
        Frost's start points, (row, col); default the region's innermost point.
    exemplar : str, optional
        Fire's exemplar: the name of a bundled sample (``"fire"``, ``"flame"``).
    name : str
        What the layer is called in lists and messages (default its kind).
    visible : bool
        Hidden layers are kept in the scene but not rendered.
    seed : int
        The method's random seed.
    """

    kind: str
    region: np.ndarray
    params: Params | None = None
    strokes: tuple = field(default=())
    speed: np.ndarray | None = None
    starts: np.ndarray | None = None
    exemplar: str = "fire"
    name: str = ""
    visible: bool = True
    seed: int = 0

    def __post_init__(self):
        if self.kind not in KINDS:
            raise ValueError(f"kind must be one of {sorted(KINDS)}, got {self.kind!r}")
        where = f"layer {self.name or self.kind!r}"
        region = check_array(f"{where}: region", self.region, ndim=2, dtype_kinds="buif")
        region = region.astype(np.float32)
        if region.min() < 0 or region.max() > 1:
            raise ValueError(f"{where}: region must lie in [0, 1] (a mask or a matte)")
        if not (region > 0.5).any():
            raise ValueError(f"{where}: region is empty: paint where the layer acts")
        object.__setattr__(self, "region", region)
        object.__setattr__(self, "name", self.name or self.kind)
        strokes = tuple(
            check_array(f"{where}: stroke", s, ndim=2, dtype_kinds="iuf").astype(np.float32)
            for s in self.strokes
        )
        for s in strokes:
            if s.shape[1] != 2 or len(s) < 2:
                raise ValueError(f"{where}: each stroke must be (n >= 2, 2) (row, col) points")
        object.__setattr__(self, "strokes", strokes)
        if self.speed is not None:
            speed = check_array(f"{where}: speed", self.speed, ndim=2, dtype_kinds="iuf")
            if speed.shape != region.shape:
                raise ValueError(f"{where}: speed must have the region's shape {region.shape}")
            if speed.min() < 0:
                raise ValueError(f"{where}: speed must be >= 0 px/frame (0 = not painted)")
            object.__setattr__(self, "speed", speed.astype(np.float32))
        if self.starts is not None:
            starts = check_array(f"{where}: starts", self.starts, ndim=2, dtype_kinds="iuf")
            if starts.shape[1] != 2 or not len(starts):
                raise ValueError(f"{where}: starts must be (n >= 1, 2) (row, col) points")
            object.__setattr__(self, "starts", starts.astype(np.float64))
        if self.params is not None and not isinstance(self.params, Params):
            raise ValueError(f"{where}: params must be a parameter object, got {self.params!r}")

    @property
    def method(self):
        """The method that animates the layer (``"videodb"``, ``"flicker"``, ...)."""
        return KINDS[self.kind][0]

    @property
    def blend(self):
        """How it is composited: ``"replace"``, ``"light"`` or ``"cover"``."""
        return KINDS[self.kind][1]

    @property
    def loops(self):
        """Whether its clip repeats (False: it plays once and holds its last frame)."""
        return KINDS[self.kind][2]

    def replace(self, **changes):
        """A copy with some fields changed (validated again)."""
        return replace(self, **changes)

    def key(self, photo_key, size):
        """A digest of everything the layer's clip depends on (its cache key)."""
        h = hashlib.sha256()
        h.update(photo_key.encode())
        h.update(json.dumps([self.kind, size, self.exemplar, self.seed]).encode())
        h.update(b"" if self.params is None else self.params.to_json().encode())
        for arr in (self.region, self.speed, self.starts, *self.strokes):
            h.update(b"-" if arr is None else np.ascontiguousarray(arr).tobytes())
            h.update(b"|")
        return h.hexdigest()[:20]
