"""The photo an app works on: a menu of bundled photos and an upload button."""

from __future__ import annotations

import io

import ipywidgets as W
import numpy as np
from PIL import Image

from ._common import Choice

__all__ = ["PhotoInput", "load_photo"]


def load_photo(photo, matte=None, *, samples=(), size=None, sample_size=None, min_side=1):
    """An app's photo as float RGB and its matte (or None): a sample's name or an image.

    Parameters
    ----------
    photo : str, array_like, path or PIL image
        One of ``samples`` (a bundled photo, with its own matte if it has one), or an
        image (an RGBA cut-out's alpha is its matte).
    matte : array_like, optional
        A matte that replaces the photo's own (its size).
    samples : sequence of str
        The names that are bundled photos.
    size : int, optional
        Longest side kept: larger photos are shrunk (a sample is read at that size).
    sample_size : int, optional
        The size a sample is read at (default: ``size``, or its own).
    min_side : int
        The shortest side the app can work with (a ValueError below it).

    Returns
    -------
    (ndarray, ndarray or None)
        float32 (H, W, 3) in [0, 1]; float32 (H, W) matte or None.
    """
    from fluidnb import as_image, data
    from fluidnb.fields import resize

    if isinstance(photo, str) and photo in samples:
        image, alpha = data.sample(photo, size=sample_size, return_alpha=True)
        if size is not None and max(image.shape[:2]) > size:
            image, alpha = data.sample(photo, size=size, return_alpha=True)
    else:
        if size is not None and isinstance(photo, Image.Image) and max(photo.size) > size:
            photo = photo.copy()
            photo.thumbnail((size, size), Image.LANCZOS)
        image, alpha = as_image(photo, mode="rgb", name="photo", return_alpha=True)
        if size is not None and max(image.shape[:2]) > size:
            h, w = image.shape[:2]
            f = size / max(h, w)
            new = (max(1, round(h * f)), max(1, round(w * f)))
            image = resize(image, new)
            alpha = None if alpha is None else resize(alpha, new)
    if min(image.shape[:2]) < min_side:
        raise ValueError(
            f"photo must be at least {min_side} x {min_side} pixels, got "
            f"{image.shape[0]} x {image.shape[1]}"
        )
    if matte is not None:
        alpha = as_image(matte, mode="grey", name="matte")
        if alpha.shape != image.shape[:2]:
            raise ValueError(
                f"matte must have the photo's size {image.shape[:2]}, got {alpha.shape}"
            )
    return image.astype(np.float32, copy=False), alpha


class PhotoInput(W.HBox):
    """A menu of bundled photos ("upload" joins it while an upload is shown) and Upload.

    One photo input for every app that works on a photo: a pick from the menu calls
    ``on_photo(name)``, an upload ``on_photo(image)`` with the file read as a PIL
    image (a broken or foreign file is said with ``say`` and changes nothing). The
    app loads the photo and, once it is shown, calls :meth:`shown` so the menu
    follows.

    Parameters
    ----------
    samples : sequence of str
        The bundled photos offered.
    value : str
        The photo shown: one of ``samples``, or ``"upload"``.
    on_photo : callable
        ``on_photo(name_or_image)``.
    say : callable
        ``say(text, kind)``: the app's status line.
    width : str
        CSS width of the menu.

    Examples
    --------
    >>> got = []
    >>> p = PhotoInput(["fire", "flame"], "fire", on_photo=got.append, say=print)
    >>> p.menu.value = "flame"
    >>> got
    ['flame']
    >>> p.shown("upload")
    >>> p.menu.options
    ('fire', 'flame', 'upload')
    """

    def __init__(self, samples, value, *, on_photo, say, width="170px"):
        self.samples = tuple(samples)
        self._on_photo = on_photo
        self._say = say
        self._shown = value
        #: The photo menu (a :class:`Choice`: new options never pick a photo by themselves).
        self.menu = Choice(
            options=self._options(value),
            value=value,
            description="photo",
            style={"description_width": "44px"},
            layout=W.Layout(width=width),
        )
        #: The upload button (one image file).
        self.upload = W.FileUpload(
            accept="image/*", multiple=False, description="Upload", layout=W.Layout(width="110px")
        )
        self.menu.add_class("fluidnb-photo")
        self.upload.add_class("fluidnb-upload")
        self.menu.on_pick(self._picked)
        self.upload.observe(self._uploaded, "value")
        super().__init__(
            [self.menu, self.upload], layout=W.Layout(flex_flow="row wrap", align_items="center")
        )

    def _options(self, name):
        return [*self.samples, *(["upload"] if name == "upload" else [])]

    def shown(self, name):
        """The app now shows ``name`` (a sample or ``"upload"``): the menu follows."""
        self._shown = name
        self.menu.set_options(self._options(name), name)

    def _picked(self, name):
        if name != self._shown and name in self.samples:
            self._on_photo(name)
            if self._shown != name:  # refused: the menu shows the photo still shown
                self.menu.set_options(self._options(self._shown), self._shown)

    def _uploaded(self, change):
        files = change["new"]
        if not files:
            return
        try:
            image = Image.open(io.BytesIO(bytes(files[0]["content"])))
            image.load()
        except Exception as exc:  # a broken or foreign file: say so, keep the photo
            self._say(f"could not read the upload: {exc}", "error")
            return
        self._on_photo(image)

    @property
    def disabled(self):
        """Whether the menu and the button are off (while a run works on the photo)."""
        return self.menu.disabled

    @disabled.setter
    def disabled(self, value):
        self.menu.disabled = self.upload.disabled = bool(value)
