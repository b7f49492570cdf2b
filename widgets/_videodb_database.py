"""The video-database app's database choice: a starter kind, a folder, or one given."""

from __future__ import annotations

import os

import ipywidgets as W

from fluidnb.videodb import (
    STARTER_KINDS,
    VideoDatabase,
    open_database,
    starter_database,
    starter_params,
    starter_path,
)

from ._common import Choice, plural, row

__all__ = ["DatabaseChoice"]


class DatabaseChoice(W.VBox):
    """Which video database a run uses, opened once and kept; its N and size shown.

    Parameters
    ----------
    db : str, path, VideoDatabase or None
        A starter kind (``"water"``, ``"smoke"``, ``"fire"``), a database folder, an
        opened database, or None for ``default``.
    default : str
        The starter kind chosen when ``db`` is None.
    quick : bool
        The small starter databases.
    """

    def __init__(self, db, *, default="water", quick=False):
        self.quick = bool(quick)
        self.given = None  #: An opened database given to the app (choice "given").
        self._opened = {}  # key -> VideoDatabase
        options = [(f"{k} (starter)", k) for k in STARTER_KINDS]
        options.append(("a database folder…", "folder"))
        if isinstance(db, VideoDatabase):
            self.given = db
            options.insert(0, self._given_label(db))
            choice, path = "given", ""
        elif db is None:
            choice, path = default, ""
        elif isinstance(db, str) and db in STARTER_KINDS:
            choice, path = db, ""
        else:
            choice, path = "folder", os.fspath(db)
        #: The drop-down (a Choice: new options never pick by themselves).
        self.pick = Choice(
            options=options,
            value=choice,
            description="database",
            style={"description_width": "64px"},
            layout=W.Layout(width="290px"),
        )
        #: The folder box (shown for "a database folder…").
        self.path = W.Text(
            value=path,
            placeholder="path/to/database",
            layout=W.Layout(width="290px", display="" if choice == "folder" else "none"),
        )
        #: N and the database's size, in words.
        self.label = W.HTML(layout=W.Layout(max_width="320px"))
        self.pick.add_class("fluidnb-vdb-db")
        self.path.add_class("fluidnb-vdb-db-path")
        self.label.add_class("fluidnb-vdb-N")
        self.pick.on_pick(lambda choice: self._picked(choice))
        self.path.observe(lambda _: self.show(), "value")
        super().__init__([row(self.pick, self.path), self.label])
        self.show()

    @staticmethod
    def _given_label(db):
        return (f"given: {db.kind}, {db.n_fragments} fragments", "given")

    def _picked(self, choice):
        self.path.layout.display = "" if choice == "folder" else "none"
        self.show()

    @property
    def kind(self):
        """The kind of fluid of the choice (a starter's, the given one's; water else)."""
        choice = self.pick.value
        if choice == "given":
            return self.given.kind
        return choice if choice in STARTER_KINDS else "water"

    @property
    def name(self):
        """The choice in words ("the water starter database", a folder...)."""
        key = self.key()
        if key[0] == "starter":
            return f"the {key[1]} starter database"
        if key[0] == "given":
            return f"the given {self.given.kind} database"
        return f"the database in {self.path.value.strip() or '(no folder typed)'}"

    def set(self, db):
        """Choose a starter kind, a folder, or an opened database."""
        if isinstance(db, VideoDatabase):
            self.given = db
            others = [o for o in self.pick.options if o[1] != "given"]
            self.pick.set_options([self._given_label(db), *others], "given")
        elif isinstance(db, str) and db in STARTER_KINDS:
            self.pick.value = db
        else:
            self.path.value = os.fspath(db)
            self.pick.value = "folder"
        self.show()

    def key(self):
        """What identifies the chosen database (opened once per key)."""
        choice = self.pick.value
        if choice == "given":
            return ("given",)
        if choice == "folder":
            return ("folder", os.path.abspath(os.path.expanduser(self.path.value.strip())))
        return ("starter", choice, self.quick)

    def known(self):
        """The chosen database if it is open already, else None."""
        key = self.key()
        return self.given if key[0] == "given" else self._opened.get(key)

    def opened(self, progress=None):
        """The chosen database, opened (a starter one is built on first use, cached)."""
        key = self.key()
        db = self.known()
        if db is None:
            if key[0] == "folder":
                if not self.path.value.strip():
                    raise ValueError("database folder is empty: type the path of a video database")
                if not os.path.isdir(key[1]):
                    raise ValueError(f"database folder {key[1]!r} does not exist")
                db = open_database(key[1], progress=progress)
            else:
                db = starter_database(key[1], quick=self.quick, progress=progress)
            self._opened[key] = db
        self.show(db)
        return db

    def ready(self):
        """Whether :meth:`opened` opens the chosen database without building it."""
        key = self.key()
        return (
            key[0] != "starter"
            or key in self._opened
            or starter_path(key[1], quick=self.quick).exists()
        )

    def show(self, db=None):
        """Say N (frames per fragment) and the database's size under the choice."""
        key = self.key()
        db = self.known() if db is None else db
        style = "font-size:12px;opacity:0.85;line-height:1.4;display:inline-block"
        if db is not None:
            text = (
                f"N = <b>{db.params.N}</b> frames per fragment (the database's) · "
                f"{plural(db.n_fragments, 'fragment')}, {plural(len(db.clips), 'clip')}"
            )
        elif key[0] == "starter":
            built = starter_path(key[1], quick=self.quick).exists()
            when = "cached" if built else "built on the first Run, then cached"
            size = "quick" if self.quick else "full"
            text = (
                f"N = <b>{starter_params().N}</b> frames per fragment (the database's) · "
                f"{size} starter database, {when}"
            )
        else:
            text = "N (frames per fragment): read from the database when it opens"
        self.label.value = f"<span style='{style}'>{text}</span>"
