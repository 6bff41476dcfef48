"""A command's output set, written whole or not at all.

Every command that writes (mesh, sdf, drape, grade) opens an :class:`OutputSet` before its
expensive work. Opening it checks, in this order, that no input would be replaced, that an
existing result is replaced only with ``--force``, and that the place is writable (by
creating the temporary folder beside the target). The command writes into that folder; on a
clean exit the set is moved into place by renames, on any exception (errors, Ctrl-C,
SIGTERM) the folder is removed and nothing at the target changes.

Two shapes: a folder replaced whole (``files=None``), or named files beside each other in
the target folder (``files=[...]``: sdf's ``x.npz`` and ``x.json``).
"""
from __future__ import annotations

import os
import shutil
import signal
import tempfile
from contextlib import contextmanager
from pathlib import Path
from typing import Iterable, Sequence

from .errors import SeamfitError

__all__ = ["OutputSet", "add_force_argument", "check_not_an_input"]

TMP_TAG = ".seamfit-tmp-"
OLD_TAG = ".seamfit-old-"
_SIGNALS = {signal.SIGINT, signal.SIGTERM}


class OutputSet:
    """``with OutputSet(out, inputs=..., force=...) as tmp:`` write into ``tmp``; see above."""

    def __init__(self, target, *, inputs: Iterable = (), force: bool = False,
                 files: Sequence[str] | None = None):
        # Work on the real folder a symlinked --out points to, so the link survives.
        self.given = Path(target)                # for messages: the path as the user wrote it
        self.target = Path(os.path.realpath(os.path.abspath(target)))
        self.inputs = [Path(p) for p in inputs if p is not None]
        self.force = force
        self.files = list(files) if files is not None else None
        self.tmp: Path | None = None
        self._made_parents: list[Path] = []

    # ------------------------------------------------------------------ checks
    def _outputs(self) -> list[tuple[Path, Path]]:
        """(real path, path as shown) of what this set replaces: the folder, or the named files."""
        if self.files is not None:
            return [(self.target / name, self.given / name) for name in self.files]
        return [(self.target, self.given)]

    def check_inputs(self) -> None:
        """Refuse when any input would be replaced or deleted by this set."""
        for out, shown in self._outputs():
            check_not_an_input(out, self.inputs, shown=shown, folder=self.files is None)

    def check_existing(self) -> None:
        t, shown = self.target, self.given
        if t.exists() and not t.is_dir():
            raise SeamfitError(f"{shown}: exists and is not a folder")
        if self.files is None:
            cwd = Path(os.path.realpath(os.getcwd()))
            if t == cwd or t in cwd.parents:     # replacing it would pull the floor away
                raise SeamfitError(f"{shown}: is the current folder or contains it; give a new folder "
                                   "for the results")
            if t.is_dir() and any(t.iterdir()) and not self.force:
                raise SeamfitError(f"{shown}: folder exists and is not empty; pass --force to replace it "
                                   "(the whole folder is replaced)")
            return
        for out, name in self._outputs():
            if out.is_dir():
                raise SeamfitError(f"{name}: is a folder; give a file name")
            if out.exists() and not self.force:
                raise SeamfitError(f"{name}: exists; pass --force to overwrite it")

    # ------------------------------------------------------------- lifecycle
    def open(self) -> Path:
        self.check_inputs()
        self.check_existing()
        parent = self.target.parent if self.files is None else self.target
        self._make_parents(parent)
        name = self.target.name if self.files is None else self.files[0]
        try:
            self.tmp = Path(tempfile.mkdtemp(prefix=f".{name}{TMP_TAG}", dir=parent))
            os.chmod(self.tmp, 0o777 & ~_umask())   # mkdtemp makes 0700; results get the usual mode
        except OSError as exc:
            self.discard()
            raise SeamfitError(f"{self.given}: cannot write the results in {parent}: "
                               f"{exc.strerror or exc}") from None
        except BaseException:                    # interrupted right here: leave nothing behind
            self.discard()
            raise
        return self.tmp

    def commit(self) -> None:
        """Move the finished set into place. Signals wait until it is done, so a set is
        either the old one or the new one, never a mix."""
        with _signals_blocked():
            if self.files is None:
                self._commit_folder()
            else:
                for name in self.files:          # sdf: the report last, as the set's marker
                    if (self.tmp / name).exists():
                        os.replace(self.tmp / name, self.target / name)
                os.rmdir(self.tmp)
        self.tmp = None

    def _commit_folder(self) -> None:
        t = self.target
        try:
            os.rename(self.tmp, t)               # absent or empty: replaced in one step
            return
        except OSError:
            if not (t.is_dir() and self.force):
                raise
        old = Path(tempfile.mkdtemp(prefix=f".{t.name}{OLD_TAG}", dir=t.parent))
        os.rename(t, old / t.name)
        try:
            os.rename(self.tmp, t)
        except BaseException:
            os.rename(old / t.name, t)           # put the old set back
            os.rmdir(old)
            raise
        shutil.rmtree(old, ignore_errors=True)

    def discard(self) -> None:
        with _signals_blocked():
            if self.tmp is not None:
                shutil.rmtree(self.tmp, ignore_errors=True)
                self.tmp = None
            self._remove_parents()

    def __enter__(self) -> Path:
        return self.open()

    def __exit__(self, exc_type, exc, tb) -> bool:
        if exc_type is None:
            try:
                self.commit()
            except OSError as err:
                self.discard()
                raise SeamfitError(f"{self.given}: could not move the results into place: "
                                   f"{err.strerror or err}") from None
        else:
            self.discard()
            if issubclass(exc_type, OSError):    # disk full, quota, a folder gone: name --out
                name = Path(exc.filename).name if getattr(exc, "filename", None) else None
                raise SeamfitError(f"{self.given}: could not write the results"
                                   + (f" ({name})" if name else "") + f": {exc.strerror or exc}; "
                                   "nothing was written") from exc
        return False

    # -------------------------------------------------------------- helpers
    def _make_parents(self, folder: Path) -> None:
        missing = []
        p = folder
        while not p.exists() and p != p.parent:
            missing.append(p)
            p = p.parent
        try:
            folder.mkdir(parents=True, exist_ok=True)
        except (FileExistsError, NotADirectoryError):
            raise SeamfitError(f"{self.given}: cannot create the output folder: {p} is a file, "
                               "not a folder") from None
        except OSError as exc:
            raise SeamfitError(f"{self.given}: cannot create the output folder: {exc.strerror or exc}") from None
        self._made_parents = missing             # deepest first: removed on failure

    def _remove_parents(self) -> None:
        for p in self._made_parents:
            try:
                p.rmdir()
            except OSError:
                break
        self._made_parents = []


def check_not_an_input(out, inputs: Iterable, *, shown=None, folder: bool = False) -> None:
    """Refuse an output path that is one of the inputs (by resolved path, symlink or hard
    link); with ``folder``, one that holds an input, since the whole folder is replaced."""
    shown = Path(out) if shown is None else shown
    out = Path(os.path.realpath(out))
    for inp in (Path(p) for p in inputs if p is not None):
        real = Path(os.path.realpath(inp))
        if real == out or (folder and out in real.parents) or _same_file(inp, out):
            raise SeamfitError(f"{shown}: would replace the input {inp}; inputs are never "
                               "modified, write the results elsewhere")
        if folder and out.is_dir():
            for f in _walk_files(out):           # hard links to an input inside the folder
                if _same_file(inp, f):
                    raise SeamfitError(f"{shown}: would replace {f}, which is the input {inp} "
                                       "(a hard link); write the results elsewhere")


@contextmanager
def _signals_blocked():
    """Hold SIGINT/SIGTERM back (in this thread) for a few renames; delivered afterwards."""
    try:
        old = signal.pthread_sigmask(signal.SIG_BLOCK, _SIGNALS)
    except (AttributeError, OSError, ValueError):
        yield
        return
    try:
        yield
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, old)


def _same_file(a: Path, b: Path) -> bool:
    try:
        return os.path.samefile(a, b)
    except OSError:                              # either is missing
        return False


def _walk_files(folder: Path, limit: int = 10_000):
    n = 0
    for root, _, names in os.walk(folder):
        for name in names:
            yield Path(root) / name
            n += 1
            if n >= limit:
                return


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


def add_force_argument(parser, what: str = "the --out folder") -> None:
    """The same --force for every command that writes."""
    parser.add_argument("--force", action="store_true",
                        help=f"replace {what} when it already holds results (without it, the command "
                             "stops before any work)")
