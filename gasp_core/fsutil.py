"""Filesystem safety: every atomic write and every output folder goes through here.

Rules (docs/reliability.md, "Reliability"):

- A file is written to a temporary file beside it, flushed, fsynced and ``os.replace``-d onto its
  name (:func:`atomic_write`); on any error the temporary file is removed and the target is
  untouched. New files get the usual ``0666 & ~umask`` mode, not ``mkstemp``'s 0600.
- An output folder is **claimed** when a run starts (:class:`OutputClaim`): created exclusively
  (``os.mkdir``), or, with ``overwrite``, locked by a claim file created with ``O_EXCL``. Two
  runs to one folder: exactly one gets it; the other fails at once, naming the folder.
- Results are written into a hidden sibling ``.<name>.partial-<token>/`` and committed only at the
  end, and only if the claim is still ours and the folder holds nothing the run did not expect.
  With ``overwrite`` the old folder is replaced only if it is a GASP output holding nothing but
  what its run wrote, unchanged, at every depth (:mod:`gasp_core.fsmarker`); ``overwrite`` refuses
  a folder that is, contains or lies above an input file, the scene file or the working directory.
"""
from __future__ import annotations

import json
import os
import secrets
import shutil
import tempfile
from pathlib import Path
from contextlib import contextmanager
from typing import Callable, Iterable, Iterator

from gasp_core.errors import GaspError
from gasp_core.fsnames import alive, check_folder, check_output_name, is_within, refuse_link, temp_prefix
from gasp_core.fsmarker import CLAIM, MARKER, NO_LIST, foreign_entries, unexpected_entries, write_marker

PARTIAL_INFIX = ".partial-"
#: The claim file's third word once its run stopped on a signal and kept its partial output.
STOPPED = "stopped"


class OutputConflict(GaspError):
    """The output folder changed under a run; the finished results are kept in the partial folder it names."""


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


def atomic_write(path: str | os.PathLike, write: Callable, *, binary: bool = True, overwrite: bool = True) -> Path:
    """Write ``path`` atomically: ``write(f)`` fills a temporary file that then replaces ``path``.

    Parameters
    ----------
    path : path-like
        Destination; its folder must exist.
    write : callable
        ``write(file_object)``.
    binary : bool
        Open the temporary file in binary mode.
    overwrite : bool
        If False, refuse when ``path`` exists (also if it appeared while writing).

    Raises
    ------
    FileExistsError
        ``path`` exists and ``overwrite`` is False.
    FileNotFoundError
        The folder of ``path`` does not exist (the message names ``path`` and the folder, not a temporary file).
    OSError
        From the filesystem (disk full, permission); the temporary file is removed.
    """
    path = Path(path)
    if not overwrite and path.exists():
        raise FileExistsError(f"{path}: file exists; pass overwrite=True to replace it")
    check_folder(path)
    fd, tmp = tempfile.mkstemp(prefix=temp_prefix(path.name), suffix=".tmp", dir=path.parent)
    try:
        os.fchmod(fd, 0o666 & ~_umask())
        with os.fdopen(fd, "wb" if binary else "w") as f:
            write(f)
            f.flush()
            os.fsync(f.fileno())
        if not overwrite and path.exists():
            raise FileExistsError(f"{path}: file exists; pass overwrite=True to replace it")
        os.replace(tmp, path)
    except BaseException:
        try:
            os.unlink(tmp)
        except FileNotFoundError:
            pass
        raise
    return path


def atomic_json(path: str | os.PathLike, obj) -> Path:
    """:func:`atomic_write` of ``obj`` as indented JSON (non-JSON values through ``str``)."""
    return atomic_write(path, lambda f: json.dump(obj, f, indent=2, default=str), binary=False)


def make_partial_dir(outdir: Path) -> Path:
    """A new hidden sibling folder ``.<name>.partial-<token>`` with the umask's usual mode."""
    tmp = Path(tempfile.mkdtemp(dir=outdir.parent, prefix=f".{outdir.name}{PARTIAL_INFIX}"))
    os.chmod(tmp, 0o777 & ~_umask())
    (tmp / ".gasp-pid").write_text(str(os.getpid()))
    return tmp


def leftover_partials(outdir: Path) -> list[Path]:
    """Partial folders of earlier runs to ``outdir`` whose process is gone (killed, crashed)."""
    out = []
    for p in sorted(outdir.parent.glob(f".{outdir.name}{PARTIAL_INFIX}*")):
        try:
            pid = int((p / ".gasp-pid").read_text())
        except (OSError, ValueError):
            pid = -1
        if pid > 0 and alive(pid):
            continue
        out.append(p)
    return out


def discard_partials(outdir: Path, option: str = "--discard", dry_run: bool = False) -> None:
    """Remove the partial folders of stopped or killed runs to ``outdir`` (not finished results kept after
    an :class:`OutputConflict`, which hold :data:`MARKER`).

    Raises
    ------
    GaspError
        A partial folder holds a file gasp did not write (:func:`foreign_entries`): nothing is removed, and the
        line names the folder, the files and ``option``. ``dry_run``: the check alone, nothing removed.
    """
    doomed = [p for p in leftover_partials(outdir) if not (p / MARKER).exists()]
    for p in doomed:
        extra = foreign_entries(p)
        if extra:
            shown = ", ".join(extra[:3]) + (f" and {len(extra) - 3} more" if len(extra) > 3 else "")
            raise GaspError(f"{option} refuses to delete the stopped run's folder '{p}': it holds files gasp did not "
                            f"write ({shown}); move them out, then run again")
    for p in doomed:
        shutil.rmtree(p, ignore_errors=True)


def _check_parent(outdir: Path) -> None:
    """Refuse (:class:`GaspError`) an output path below something that is not a folder (``/dev/full/x``)."""
    for parent in outdir.absolute().parents:
        if parent.exists():
            if not parent.is_dir():
                raise GaspError(f"cannot create output folder '{outdir}': '{parent}' is not a folder")
            return


class OutputClaim:
    """An output folder claimed for one run (see the module docstring).

    Parameters
    ----------
    outdir : path-like
        The folder the run will produce.
    overwrite : bool
        Allow replacing an existing GASP output folder at commit time.
    protected : iterable of path-like
        Input files and the scene file: ``outdir`` must not be, contain or lie above any of them,
        nor the working directory.
    resume : bool
        Take over the claim of a stopped or killed run (``--resume``).
    discard : bool
        Throw away a stopped or killed run's partial output and claim (``--discard``; ``overwrite`` too).

    Raises
    ------
    GaspError
        The folder is unsafe to replace, not a GASP output, a file, a symbolic link, or not writable.
    FileExistsError
        It exists (without ``overwrite``) or another run holds it.
    """

    def __init__(self, outdir: str | os.PathLike, overwrite: bool = False, protected: Iterable = (),
                 resume: bool = False, discard: bool = False):
        self.outdir = Path(outdir)
        self.overwrite = overwrite
        self.token = secrets.token_hex(8)
        self.created = False
        refuse_link(self.outdir)   # before anything resolves through it
        out = self.outdir.resolve()
        for p in [Path.cwd(), *map(Path, protected)]:
            p = p.resolve()
            if is_within(p, out):
                what = "the working directory" if p == Path.cwd().resolve() else f"'{p}'"
                raise GaspError(f"output folder '{self.outdir}' is, contains or lies above {what}; "
                                f"choose a new folder for the results")
        if overwrite or discard:   # before anything is claimed: a user's file in a stopped run's folder is refused
            discard_partials(self.outdir, "--overwrite" if overwrite else "--discard", dry_run=True)
        if self.outdir.exists() and not self.outdir.is_dir():
            raise GaspError(f"output '{self.outdir}' exists and is not a folder; choose a folder name")
        _check_parent(self.outdir)
        check_output_name(self.outdir)
        try:
            self.outdir.parent.mkdir(parents=True, exist_ok=True)
            os.mkdir(self.outdir)
            self.created = True
        except FileExistsError:
            if resume and self._take_over_stale_claim():
                return
            self._existing(overwrite, discard)
        except PermissionError as e:
            raise GaspError(f"cannot create output folder '{self.outdir}': permission denied ({e.strerror})") from None
        try:
            fd = os.open(self.outdir / CLAIM, os.O_CREAT | os.O_EXCL | os.O_WRONLY, 0o644)
        except FileExistsError:
            raise FileExistsError(f"output folder '{self.outdir}' is being written by another gasp run "
                                  f"(claim file {self.outdir / CLAIM}); wait for it or choose another folder") from None
        except PermissionError as e:
            self._undo_mkdir()
            raise GaspError(f"cannot write to output folder '{self.outdir}': permission denied ({e.strerror})") from None
        with os.fdopen(fd, "w") as f:
            f.write(f"{self.token} {os.getpid()}\n")
        if overwrite or discard:   # also partials whose folder was removed by hand
            discard_partials(self.outdir, "--overwrite" if overwrite else "--discard")

    def _existing(self, overwrite: bool, discard: bool) -> None:
        """``outdir`` exists: refuse it, or (``overwrite``, ``discard``) make it ready to be claimed."""
        stale = self._stale_claim_pid()
        only_claim = stale and all(p.name == CLAIM for p in self.outdir.iterdir())
        if stale and (overwrite or (discard and only_claim)):
            # a stopped or killed run's: --discard or --overwrite throws its partial output away
            discard_partials(self.outdir, "--overwrite" if overwrite else "--discard")
            (self.outdir / CLAIM).unlink(missing_ok=True)
            self.created = only_claim
            if not only_claim:
                self._check_replaceable()
            return
        if stale and discard:   # --discard given, but the folder holds more than the stopped run's claim
            others = sorted(p.name for p in self.outdir.iterdir() if p.name != CLAIM)
            shown = ", ".join(others[:3]) + (f" and {len(others) - 3} more" if len(others) > 3 else "")
            raise FileExistsError(
                f"--discard refuses '{self.outdir}': besides the stopped run's claim it holds {shown}, which gasp "
                f"did not write there; move them out, or pass --overwrite to replace a gasp output") from None
        if stale:
            raise FileExistsError(
                f"output folder '{self.outdir}' belongs to a run that was stopped or killed (pid {stale}); pass "
                f"--resume to continue it, or --discard to start again") from None
        if not overwrite:
            raise FileExistsError(f"output folder '{self.outdir}' exists; pass --overwrite to replace it "
                                  f"(only a folder written by gasp is replaced)") from None
        self._check_replaceable()

    def _stale_claim_pid(self) -> int:
        """The pid of a stopped or dead run that still holds the claim file, else 0."""
        try:
            words = (self.outdir / CLAIM).read_text().split()
            pid = int(words[1])
        except (OSError, IndexError, ValueError):
            return 0
        return pid if STOPPED in words[2:] or not alive(pid) else 0

    def _take_over_stale_claim(self) -> bool:
        """For ``--resume``: take the claim of a killed run (True), or leave a live one alone (False)."""
        if not self._stale_claim_pid():
            return False
        self.created = all(p.name == CLAIM for p in self.outdir.iterdir())
        (self.outdir / CLAIM).write_text(f"{self.token} {os.getpid()}\n")
        return True

    def _check_replaceable(self) -> None:
        if (self.outdir / CLAIM).exists():
            raise FileExistsError(f"output folder '{self.outdir}' is being written by another gasp run "
                                  f"(claim file {self.outdir / CLAIM}); wait for it or choose another folder")
        extra = unexpected_entries(self.outdir)
        if extra == [NO_LIST]:
            raise GaspError(f"--overwrite refuses '{self.outdir}': it is not a gasp output folder ({NO_LIST}); "
                            f"nothing was deleted; choose another folder")
        if extra:
            named = ", ".join(extra[:5]) + (", ..." if len(extra) > 5 else "")
            raise GaspError(f"--overwrite refuses '{self.outdir}': not a gasp output as gasp left it, it holds "
                            f"what gasp did not write there ({named}); nothing was deleted; move those away or "
                            f"choose another folder")

    def _undo_mkdir(self) -> None:
        if self.created:
            try:
                os.rmdir(self.outdir)
            except OSError:
                pass

    def still_ours(self) -> bool:
        try:
            return (self.outdir / CLAIM).read_text().split()[0] == self.token
        except (OSError, IndexError):
            return False

    def keep_for_resume(self, tmp: Path) -> None:
        """A stopped run: mark the claim and the partial folder ``tmp`` as no longer running, for ``--resume``."""
        (tmp / ".gasp-pid").unlink(missing_ok=True)
        if self.still_ours():
            (self.outdir / CLAIM).write_text(f"{self.token} {os.getpid()} {STOPPED}\n")

    def partial_dir(self) -> Path:
        """A fresh partial folder to write the results into."""
        return make_partial_dir(self.outdir)

    def commit(self, tmp: Path) -> None:
        """Move the finished ``tmp`` folder into place, if the claim is still ours.

        Raises
        ------
        GaspError
            The claim was taken or the folder gained entries the run did not make; ``tmp`` is kept
            and named in the message.
        """
        (tmp / ".gasp-pid").unlink(missing_ok=True)
        write_marker(tmp)
        if not self.still_ours():
            raise OutputConflict(f"output folder '{self.outdir}' was changed by someone else during the run; "
                            f"the results are kept in '{tmp}'")
        if self.created:
            extra = [p.name for p in self.outdir.iterdir() if p.name != CLAIM]
        else:
            extra = unexpected_entries(self.outdir)
        if extra:
            raise OutputConflict(f"output folder '{self.outdir}' gained entries during the run ({sorted(extra)[:5]}); "
                            f"nothing was replaced; the results are kept in '{tmp}'")
        if self.created:
            (self.outdir / CLAIM).unlink()
            os.rmdir(self.outdir)
            os.replace(tmp, self.outdir)
            return
        trash = Path(tempfile.mkdtemp(dir=self.outdir.parent, prefix=f".{self.outdir.name}.old-"))
        os.replace(self.outdir, trash / "old")
        os.replace(tmp, self.outdir)
        shutil.rmtree(trash, ignore_errors=True)

    def abandon(self, tmp: Path | None, error: BaseException) -> None:
        """After a failed run: give the claim back and remove ``tmp``, unless ``error`` is an
        :class:`OutputConflict` (the finished results in ``tmp`` are then kept and named)."""
        self.release()
        if tmp is not None and not isinstance(error, OutputConflict):
            shutil.rmtree(tmp, ignore_errors=True)

    def release(self) -> None:
        """Give the folder back after a failed run: remove our claim (and the folder if we made it)."""
        if self.still_ours():
            (self.outdir / CLAIM).unlink(missing_ok=True)
        self._undo_mkdir()



@contextmanager
def output_folder(outdir: str | os.PathLike, overwrite: bool = False, protected: Iterable = ()) -> Iterator[Path]:
    """Claim ``outdir``, yield a partial folder to fill, commit it when the block ends without error.

    On an error (or Ctrl-C) the partial folder is removed and the claim given back; nothing the
    run did not make is touched. See :class:`OutputClaim` for the rules and the errors raised.
    """
    claim = OutputClaim(outdir, overwrite=overwrite, protected=protected)
    tmp = None
    try:
        tmp = claim.partial_dir()
        yield tmp
        claim.commit(tmp)
    except BaseException as e:
        claim.abandon(tmp, e)
        raise


@contextmanager
def atomic_path(path: str | os.PathLike, overwrite: bool = False) -> Iterator[Path]:
    """Yield a temporary path beside ``path`` (same suffix) for a writer that needs a file name
    (a video encoder); it replaces ``path`` when the block ends without error, else is removed.

    Raises
    ------
    FileExistsError
        ``path`` exists and ``overwrite`` is False.
    FileNotFoundError
        The folder of ``path`` does not exist (naming ``path`` and the folder).
    """
    path = Path(path)
    if not overwrite and path.exists():
        raise FileExistsError(f"{path}: file exists; pass --overwrite to replace it")
    check_folder(path)
    fd, tmp = tempfile.mkstemp(prefix=temp_prefix(path.stem), suffix=path.suffix, dir=path.parent)
    os.fchmod(fd, 0o666 & ~_umask())
    os.close(fd)
    try:
        yield Path(tmp)
        os.replace(tmp, path)
    finally:
        Path(tmp).unlink(missing_ok=True)
