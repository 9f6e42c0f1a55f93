"""A run's result files written as one set: a folder holds one run's complete set, or the
previous run's, never a mix of the two nor a partial set.

Every command that writes results (``mechrel reliability``, ``sensitivity``, ``simulate``,
``accuracy``, ``draw``, ``animate``) writes them through :func:`result_set`:

1. **Stage.** The run writes its files into a hidden staging folder inside the output folder,
   ``.mechrel-stage-NAME-PID-XXXXXXXX`` (the same file system, so that a rename moves a file).
   Anything written into it is part of the set: a writer needs no list of names.
2. **Commit.** When every file is written, the set's manifest ``.mechrel-set-NAME.json`` (the
   run's id and time, and each file's name, size and SHA-256) is added, the staging folder is
   renamed to ``.mechrel-commit-NAME`` (the journal: from here on the set is committed), and
   its files are renamed into the output folder, over the previous set's; the previous set's
   files that this run did not write (listed in its manifest, or named by the command as
   files of the set) are removed. Ctrl-C and SIGTERM wait for these renames (milliseconds)
   and act right after them.
3. **Recovery.** A run killed outright (``kill -9``, power loss) while staging leaves a
   staging folder, which the next run on the folder removes (the previous set stands); killed
   during the renames of step 2, it leaves the journal, which the next run on the set rolls
   forward (the new set stands).

An interrupt or a failed write (full disk, read-only folder, a folder where a file goes) before
the commit removes the staging folder and leaves the previous set as it was. The files keep the
permissions a new file gets (the umask), or those of the file they replace.
"""

from __future__ import annotations

import contextlib
import hashlib
import json
import os
import shutil
import tempfile
import time
import uuid
from pathlib import Path

from .._signals import signals_held
from ..errors import OutputError

MANIFEST = ".mechrel-set-{name}.json"
"""The manifest of the set ``name`` in its output folder."""
_STAGE = ".mechrel-stage-{name}-"
_JOURNAL = ".mechrel-commit-{name}"
_MANIFEST_IN_STAGE = ".mechrel-set.json"
_WAIT = 30.0  # s: at most this long for another process's commit of the same set (ms each)


def _sha256(path: Path) -> str:
    digest = hashlib.sha256()
    with open(path, "rb") as fh:
        for block in iter(lambda: fh.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except OSError:  # exists, another user's
        return True
    return True


def _read_manifest(path: Path) -> dict:
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return {}
    return data if isinstance(data, dict) else {}


def _names(data: dict, key: str) -> list[str]:
    """File names from a manifest: plain names only (a manifest edited to name ``../x`` or a
    path elsewhere is not followed)."""
    items = data.get(key, [])
    names = [i.get("name") if isinstance(i, dict) else i for i in items] if isinstance(
        items, list) else []
    return [n for n in names if isinstance(n, str) and n and n == Path(n).name
            and n not in (".", "..")]


def _roll_forward(folder: Path, name: str, journal: Path) -> None:
    """Finish a commit whose process ended during its renames: move the journal's remaining
    files into ``folder``, remove the files it removes, then the journal."""
    data = _read_manifest(journal / _MANIFEST_IN_STAGE)
    if not data:  # the journal is renamed only with its manifest in it: not ours, or damaged
        shutil.rmtree(journal, ignore_errors=True)
        return
    for f in _names(data, "files"):
        if (journal / f).is_file():
            os.replace(journal / f, folder / f)
    for f in _names(data, "removes"):
        with contextlib.suppress(FileNotFoundError, IsADirectoryError):
            (folder / f).unlink()
    if data.get("manifest", True):
        os.replace(journal / _MANIFEST_IN_STAGE, folder / MANIFEST.format(name=name))
    shutil.rmtree(journal, ignore_errors=True)


def _recover(folder: Path, name: str) -> None:
    """Before a run stages the set ``name``: remove the staging folders of runs that were
    killed (their process is gone), and roll forward a commit a killed run left; wait for a
    commit another live process is making."""
    prefix = _STAGE.format(name=name)
    for stage in folder.iterdir():
        owner = stage.name[len(prefix):].split("-", 1)[0]
        if stage.name.startswith(prefix) and stage.is_dir() and owner.isdigit() \
                and not _alive(int(owner)):
            shutil.rmtree(stage, ignore_errors=True)
    journal = folder / _JOURNAL.format(name=name)
    deadline = time.monotonic() + _WAIT
    while journal.is_dir():
        pid = _read_manifest(journal / _MANIFEST_IN_STAGE).get("pid")
        if not (isinstance(pid, int) and pid != os.getpid() and _alive(pid)) \
                or time.monotonic() > deadline:
            _roll_forward(folder, name, journal)
            return
        time.sleep(0.05)


def _check_targets(folder: Path, files, what: str) -> None:
    for f in files:
        if (folder / f).is_dir():
            raise OutputError(f"{what} = {str(folder)!r}: {f} is a folder, where this run writes "
                              f"a file; allowed: a folder without a folder named {f} (remove "
                              "or rename it)")


def _commit(folder: Path, name: str, stage: Path, known, what: str, manifest: bool) -> list[str]:
    files = sorted(p.name for p in stage.iterdir() if p.is_file() and p.name != _MANIFEST_IN_STAGE)
    _check_targets(folder, files, what)
    previous = _names(_read_manifest(folder / MANIFEST.format(name=name)), "files") \
        + [k for k in known if k]
    removes = sorted({f for f in previous if f not in files and (folder / f).is_file()})
    data = {"set": name, "run": uuid.uuid4().hex, "pid": os.getpid(),
            "written": time.strftime("%Y-%m-%dT%H:%M:%S%z"),
            "files": [{"name": f, "bytes": (stage / f).stat().st_size,
                       "sha256": _sha256(stage / f)} for f in files],
            "removes": removes, "manifest": manifest}
    (stage / _MANIFEST_IN_STAGE).write_text(json.dumps(data, indent=2) + "\n", encoding="utf-8")
    for f in files:  # a replaced file keeps its permissions (a shared file stays shared)
        with contextlib.suppress(FileNotFoundError):
            os.chmod(stage / f, (folder / f).stat().st_mode & 0o7777)
    journal = folder / _JOURNAL.format(name=name)
    with signals_held():
        os.replace(stage, journal)  # committed: a run killed from here on is rolled forward
        _roll_forward(folder, name, journal)
    return files


@contextlib.contextmanager
def removed_if_left_empty(folder):
    """For the ``with`` block: the folders of ``folder``'s path that do not exist yet (it and
    any missing parents) are removed again at its end if the block left them empty (a run
    refused or interrupted before it wrote anything leaves no empty folder behind).

    Parameters
    ----------
    folder : str or os.PathLike or None
        The output folder (None: nothing to do).

    Examples
    --------
    >>> with tempfile.TemporaryDirectory() as base:
    ...     with removed_if_left_empty(Path(base) / "a" / "b") as _:
    ...         (Path(base) / "a" / "b").mkdir(parents=True)
    ...     os.listdir(base)
    []
    """
    missing = []
    if folder:
        path = Path(folder).absolute()
        while not path.exists() and path != path.parent:
            missing.append(path)
            path = path.parent
    try:
        yield
    finally:
        for path in missing:  # innermost first; rmdir refuses a folder that is not empty
            with contextlib.suppress(OSError):
                path.rmdir()


def check_folder(out, names=(), *, what: str = "out"):
    """``out`` as a created, writable output folder in which none of the files ``names`` is a
    folder (None when ``out`` is empty: no output); called before a run computes anything, so
    that a wrong folder fails at once, not after the run.

    Parameters
    ----------
    out : str or os.PathLike or None
        The output folder (created if missing).
    names : iterable of str, optional
        Files the run writes into it.
    what : str, default "out"
        What named the folder (the option or field), for messages.

    Returns
    -------
    pathlib.Path or None
        The folder.

    Raises
    ------
    mechrel.errors.OutputError
        ``out`` is a file, cannot be created or written, or one of ``names`` is a folder in it.

    Examples
    --------
    >>> with tempfile.TemporaryDirectory() as folder:
    ...     (Path(folder) / "a.csv").mkdir()
    ...     check_folder(folder, ["a.csv"])
    Traceback (most recent call last):
    ...
    mechrel.errors.OutputError: out = '...': a.csv is a folder, where this run writes a file; ...
    """
    if not out:
        return None
    out = Path(out)
    if out.exists() and not out.is_dir():
        raise OutputError(f"{what} = {str(out)!r}: an existing file, not a folder; allowed: a "
                          "folder (created if missing)")
    _check_targets(out, names, what)
    try:
        out.mkdir(parents=True, exist_ok=True)
        fd, probe = tempfile.mkstemp(prefix=".mechrel-probe-", dir=out)
        os.close(fd)
        os.unlink(probe)
    except OSError as exc:
        raise OutputError(f"{what} = {str(out)!r}: cannot create the folder or a file in it "
                          f"({exc.strerror or exc}); allowed: a writable folder (created if "
                          "missing)") from None
    return out


@contextlib.contextmanager
def result_set(folder, name: str, *, known=(), what: str = "out", manifest: bool = True):
    """Write a run's result files as one set into ``folder`` (see the module docstring).

    Parameters
    ----------
    folder : str or os.PathLike
        The output folder (created if missing).
    name : str
        The set's name, unique among the sets a folder holds (``"reliability"``,
        ``"sensitivity"``, ``"accuracy"``; a file's name for ``simulate``, ``draw`` and
        ``animate``).
    known : iterable of str, optional
        Files the set may hold besides those the previous run's manifest lists (a folder
        written by a version without manifests): removed when this run does not write them.
    what : str, default "out"
        What named the folder (the option or field), for messages.
    manifest : bool, default True
        Leave the set's manifest in the folder (False for a set of one file, a picture: the
        rename of that file is the whole commit, and the user's folder gets no hidden file).

    Yields
    ------
    pathlib.Path
        The staging folder: write the set's files into it.

    Raises
    ------
    mechrel.errors.OutputError
        The folder cannot be created or written, or a file of the set is a folder there (the
        previous set is then unchanged).

    Examples
    --------
    >>> with tempfile.TemporaryDirectory() as folder:
    ...     with result_set(folder, "demo") as stage:
    ...         _ = (stage / "a.csv").write_text("x\\n1\\n")
    ...         _ = (stage / "b.txt").write_text("one run")
    ...     sorted(p.name for p in Path(folder).iterdir())
    ['.mechrel-set-demo.json', 'a.csv', 'b.txt']
    """
    folder = Path(folder)
    try:
        folder.mkdir(parents=True, exist_ok=True)
        _recover(folder, name)
        stage = Path(tempfile.mkdtemp(prefix=f"{_STAGE.format(name=name)}{os.getpid()}-",
                                      dir=folder))
    except OSError as exc:
        raise OutputError(f"{what} = {str(folder)!r}: cannot create the folder or a file in it "
                          f"({exc.strerror or exc}); allowed: a writable folder (created if "
                          "missing)") from None
    try:
        yield stage
        try:
            _commit(folder, name, stage, tuple(known), what, manifest)
        except OSError as exc:
            then = ("the next run on the folder finishes moving them"
                    if (folder / _JOURNAL.format(name=name)).is_dir() else
                    "the previous results, if any, are unchanged")
            raise OutputError(f"{what} = {str(folder)!r}: cannot move this run's results into "
                              f"place ({exc.strerror or exc}); {then}; allowed: a writable "
                              "folder on a disk with free space") from None
    finally:
        shutil.rmtree(stage, ignore_errors=True)
