"""Which options name files, and the one check that no output lands on an input.

Every subcommand declares its file options with :func:`add_input` and
:func:`add_output`; :func:`fluidnb.cli.main` calls :func:`check_paths` with the parsed
options before any work starts. An output is refused when it resolves (symlinks,
``./``, ``..``, letter case on a case-insensitive disk) to an input or to another
output of the same command, when it lies inside a folder the command reads (a video
database, a folder of frames), and when it is a folder that holds an input. So a
typo in ``-o`` can cost the user a retry, never their photo, simulation or database.
"""

from __future__ import annotations

import argparse
import os
import tempfile
from pathlib import Path

__all__ = ["PathOption", "add_input", "add_output", "check_paths", "path_options"]


class PathOption(argparse.Action):
    """An option (or positional) whose value is a path the command reads or writes.

    Parameters
    ----------
    role : {"input", "output"}
        Read, or written (a folder the command adds to, like ``videodb add DB``,
        is an output).
    kind : {"file", "clip", "folder"}
        What an output writes: exactly the file; a :meth:`fluidnb.Clip.save` path
        (a folder for a PNG sequence, an MP4 and its ``.json`` sidecar); a folder
        and everything in it, or only the names in ``writes``.
    writes : tuple of str, optional
        For ``kind="folder"``: the files written inside the folder.
    is_path : callable, optional
        ``is_path(value)`` is False for values that are not paths (``--db water``).
    """

    def __init__(
        self, option_strings, dest, *, role, kind="file", writes=None, is_path=None, **kwargs
    ):
        if role not in ("input", "output"):
            raise ValueError(f"role must be 'input' or 'output', got {role!r}")
        if kind not in ("file", "clip", "folder"):
            raise ValueError(f"kind must be 'file', 'clip' or 'folder', got {kind!r}")
        super().__init__(option_strings, dest, **kwargs)
        self.role = role
        self.kind = kind
        self.writes = None if writes is None else tuple(writes)
        self.is_path = is_path

    def __call__(self, parser, namespace, values, option_string=None):
        setattr(namespace, self.dest, values)

    @property
    def label(self):
        """How messages name the option: ``--output``, ``PHOTO``."""
        if self.option_strings:
            return max(self.option_strings, key=len)
        return self.metavar if isinstance(self.metavar, str) else self.dest.upper()

    def values(self, args):
        """The paths given for this option (none, one, or several for ``nargs``)."""
        value = getattr(args, self.dest, None)
        items = value if isinstance(value, (list, tuple)) else [value]
        return [
            str(v) for v in items if v is not None and (self.is_path is None or self.is_path(v))
        ]

    def footprint(self, value):
        """What this option's ``value`` covers on disk: a list of (Path, is_folder)."""
        path = Path(value)
        if self.role == "input":
            return [(path, path.is_dir())]
        if self.kind == "clip":
            from .._media import targets

            return targets(path)
        if self.kind == "folder":
            if self.writes is None:
                return [(path, True)]
            return [(path / name, False) for name in self.writes]
        return [(path, False)]


def add_input(parser, *flags, **kwargs):
    """``parser.add_argument`` for a path the command reads."""
    return parser.add_argument(*flags, action=PathOption, role="input", **kwargs)


def add_output(parser, *flags, kind="file", **kwargs):
    """``parser.add_argument`` for a path the command writes (see :class:`PathOption`)."""
    return parser.add_argument(*flags, action=PathOption, role="output", kind=kind, **kwargs)


def path_options(parser):
    """The :class:`PathOption` actions of one (sub)command's parser."""
    return [a for a in parser._actions if isinstance(a, PathOption)]


# ---------------------------------------------------------------------- the check


def check_paths(args, options):
    """Refuse outputs that would overwrite an input or each other; ValueError naming both.

    Parameters
    ----------
    args : argparse.Namespace
        The parsed command line.
    options : sequence of PathOption
        The command's path options (:func:`path_options`).

    Raises
    ------
    ValueError
        If an output is, or is inside, an input (or an input's folder is the output
        folder), if two outputs overlap, or if an output's folder cannot hold files
        (a file is in the way, or it is not writable).
    """
    given = [(opt, value) for opt in options for value in opt.values(args)]
    inputs = [(opt, value) for opt, value in given if opt.role == "input"]
    outputs = [(opt, value) for opt, value in given if opt.role == "output"]
    for k, (opt, value) in enumerate(outputs):
        for entry in opt.footprint(value):
            for other, other_value in inputs:
                for other_entry in other.footprint(other_value):
                    _refuse_overlap(opt, value, entry, other, other_value, other_entry)
            for other, other_value in outputs[k + 1 :]:
                for other_entry in other.footprint(other_value):
                    _refuse_overlap(opt, value, entry, other, other_value, other_entry)
    for opt, value in outputs:
        _check_writable(opt, value)


def _refuse_overlap(opt, value, entry, other, other_value, other_entry):
    path, folder = entry
    other_path, other_folder = other_entry
    if _same(path, other_path):
        relation = f"is the same {'folder' if folder or other_folder else 'file'} as"
    elif other_folder and _inside(path, other_path):
        relation = "is inside"
    elif folder and _inside(other_path, path):
        relation = "is a folder that holds"
    else:
        return
    what = f"{opt.label} {value!r}"
    if path != Path(value):
        what += f" (which writes {str(path)!r})"
    them = f"{other.label} {other_value!r}"
    if other_path != Path(other_value):
        them += f" (which writes {str(other_path)!r})"
    if other.role == "input":
        advice = "an output must not overwrite an input or go into a folder the command reads"
    else:
        advice = "two outputs of one command must not overwrite each other"
    raise ValueError(
        f"{what} {relation} {them}: {advice}. Nothing was written; choose another path"
    )


def _check_writable(opt, value):
    """Refuse early an output whose folder cannot exist or cannot be written.

    A clip saved as a PNG sequence must also go into a new or empty folder, or one
    fluidnb wrote (:func:`fluidnb._media.check_folder`): better said now than after
    the work.
    """
    if opt.kind == "clip":
        from .._media import EXTENSIONS, check_folder

        for entry, folder in opt.footprint(value):
            if folder:
                check_folder(entry, name=opt.label)
            elif entry == Path(value) and entry.suffix.lower() not in EXTENSIONS:
                raise ValueError(
                    f"{opt.label} must end in .gif, .mp4 or .npz, or be a folder (no "
                    f"extension) for a PNG sequence, got {value!r}"
                )
    path = Path(os.path.abspath(value))
    for folder in reversed(path.parents):
        if folder.exists() and not folder.is_dir():
            raise ValueError(
                f"{opt.label} {value!r} cannot be written: {str(folder)!r} is a file, not a folder"
            )
    folder = next(p for p in (path, *path.parents) if p.is_dir())
    # Try it: permissions, read-only disks and special folders (/proc) all show here,
    # and the file is gone again at once.
    try:
        with tempfile.TemporaryFile(dir=folder):
            pass
    except OSError as exc:
        reason = exc.strerror or str(exc)
        raise ValueError(
            f"{opt.label} {value!r} cannot be written: {reason} (in {str(folder)!r})"
        ) from None


def _real(path):
    return os.path.normcase(os.path.realpath(path))


def _same(a, b):
    """Whether two paths name one file or folder (symlinks, ``..``, case, hard links)."""
    try:
        return os.path.samefile(a, b)
    except OSError:  # one of them does not exist (yet)
        return _real(a) == _real(b)


def _inside(path, folder):
    """Whether ``path`` is (or would be created) somewhere below ``folder``."""
    if not os.path.isdir(folder):
        return False
    # Both the path resolved and the path through its resolved parent: writing follows
    # a symlink for some writers (open) and replaces it in its folder for others.
    candidates = {Path(_real(path)).parent, Path(_real(Path(path).parent))}
    for start in candidates:
        for ancestor in (start, *start.parents):
            if _same(ancestor, folder):
                return True
    return False
