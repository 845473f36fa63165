"""The runs' time histories in ``.npz`` files: written a task at a time, read back a run at a time.

A campaign's histories can outgrow memory long before its table does (600
samples of ten series per run are 48 kB, 48 MB per thousand runs, where the
run's row is 0.3 kB). With an output directory, :func:`attitude.montecarlo.campaign.run_campaign`
therefore writes the histories of each task as it finishes into one file of
the checkpoint (``checkpoint_histories/runs_NNNNNN.npz``, NNNNNN its first
run: :class:`attitude.montecarlo.executors.Checkpoint`) and, unless asked to
keep them in memory (``histories_on_disk=False``), lets them go:
:class:`StoredHistories` reads a run's series back when it is asked for.

Layout, the same in every file (a task's file and ``histories.npz``): one
array per member ``run000012/error_angle`` (:func:`history_member`), saved
without pickle. A checkpoint written before this module kept one file per
run, ``run_000012.npz``, its series as bare members: :class:`StoredHistories`
reads those too.

Files are written to a temporary name and renamed (:func:`write_histories`),
so a crash leaves either the whole file or none, and a reader holding the old
file keeps reading it whole.
"""

from __future__ import annotations

import os
import zipfile
from collections.abc import Iterable, Iterator, Mapping
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

__all__ = ["StoredHistories", "history_member", "write_histories"]

#: Digits of the run index in a member's name (``run000012/t``); more runs widen it, still parsed back.
_RUN_DIGITS = 6


def history_member(run: int, name: str) -> str:
    """The member of a histories file holding run ``run``'s series ``name`` (``run000012/error_angle``).

    Parameters
    ----------
    run : int
        Run index, >= 0.
    name : str
        Name of the series (``"t"``, ``"error_angle"`` ...).
    """
    return f"run{run:0{_RUN_DIGITS}d}/{name}"


def write_histories(
    path: str | Path, histories: Iterable[tuple[int, Mapping[str, Any]]], *, compress: bool = False
) -> Path:
    """Write the histories of some runs into one ``.npz`` file, one array at a time; return its path.

    Memory stays at one array whatever the number of runs (``numpy.savez``
    needs every array named in one mapping first); the file is what
    ``numpy.savez`` (``compress=False``) or ``numpy.savez_compressed`` writes,
    members named by :func:`history_member`, and replaces ``path`` only once
    it is complete.

    Parameters
    ----------
    path : str or Path
        Destination file (its folder must exist).
    histories : iterable of (int, mapping of str to array_like)
        Run index and its series; a lazy iterable (:class:`StoredHistories`'
        ``items()``) is read one run at a time.
    compress : bool, optional
        Deflate the members (slower to write and read, smaller).

    Raises
    ------
    ValueError
        A series that is not an array of numbers, booleans or strings (it
        would need pickle), named with its run.
    """
    path = Path(path)
    temporary = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    mode = zipfile.ZIP_DEFLATED if compress else zipfile.ZIP_STORED
    try:
        with zipfile.ZipFile(temporary, mode="w", compression=mode, allowZip64=True) as archive:
            for run, series in histories:
                for name, values in series.items():
                    array = np.asanyarray(values)
                    if array.dtype.hasobject:
                        raise ValueError(
                            f"histories: run {run}'s series {name!r} must be an array of numbers, booleans or "
                            f"strings (stored without pickle), got dtype {array.dtype}"
                        )
                    with archive.open(history_member(run, name) + ".npy", "w", force_zip64=True) as member:
                        np.lib.format.write_array(member, array, allow_pickle=False)
        os.replace(temporary, path)
    finally:
        temporary.unlink(missing_ok=True)
    return path


class StoredHistories(Mapping[int, dict[str, NDArray[Any]]]):
    """Runs' time histories in ``.npz`` files, read when asked for: ``stored[12]`` is run 12's series.

    A read mapping like the dict of histories a campaign keeps in memory
    (``len``, ``in``, iteration in run order, ``items()``), holding only where
    each run is: ``stored[run]`` reads that run's series from its file (a new
    dict of arrays each time; keep what you need). The last file read stays
    open, so reading the runs in order opens each file once.

    Parameters
    ----------
    files : mapping of int to path
        Run index -> the file holding its series (members ``run000012/<name>``,
        or bare ``<name>`` members in a checkpoint's older one-run files
        ``run_000012.npz``).
    """

    def __init__(self, files: Mapping[int, str | Path]) -> None:
        self._files = {int(run): Path(path) for run, path in sorted(files.items())}
        self._open: tuple[Path, Any] | None = None
        self._members: dict[Path, dict[int, list[str]]] = {}

    @classmethod
    def from_file(cls, path: str | Path) -> StoredHistories:
        """Every run in one file (``histories.npz`` of a saved campaign).

        Parameters
        ----------
        path : str or Path
            A file written by :func:`write_histories`.
        """
        path = Path(path)
        with zipfile.ZipFile(path) as archive:
            names = archive.namelist()
        members = _members_by_run(names)
        stored = cls(dict.fromkeys(members, path))
        stored._members[path] = members
        return stored

    @property
    def files(self) -> dict[int, Path]:
        """Run index -> the file holding its series."""
        return dict(self._files)

    def __len__(self) -> int:
        return len(self._files)

    def __iter__(self) -> Iterator[int]:
        return iter(self._files)

    def __contains__(self, run: object) -> bool:
        return run in self._files

    def __getitem__(self, run: int) -> dict[str, NDArray[Any]]:
        path = self._files[run]  # KeyError for a run without history, as a dict
        data = self._data(path)
        members = self._members.get(path)
        if members is None:
            members = self._members[path] = _members_by_run(name + ".npy" for name in data.files)
        if not members:  # a one-run file of an older checkpoint: the series are the bare members
            return {name: data[name] for name in data.files}
        names = members.get(run)
        if names is None:
            raise KeyError(f"{path} holds no history of run {run}")
        prefix = len(history_member(run, ""))
        return {name[prefix:]: data[name] for name in names}

    def _data(self, path: Path) -> Any:
        if self._open is not None and self._open[0] == path:
            return self._open[1]
        self.close()
        data = np.load(path, allow_pickle=False)
        self._open = (path, data)
        return data

    def close(self) -> None:
        """Close the file kept open (the next read opens it again)."""
        if self._open is not None:
            self._open[1].close()
            self._open = None

    def __getstate__(self) -> dict[str, Any]:
        return {"_files": self._files, "_open": None, "_members": self._members}

    def __repr__(self) -> str:
        folders = sorted({str(p.parent) for p in self._files.values()})
        return f"StoredHistories({len(self)} runs in {', '.join(folders) or 'no file'})"


def _members_by_run(names: Iterable[str]) -> dict[int, list[str]]:
    """Member names (without ``.npy``) grouped by run, from a file's list of members."""
    members: dict[int, list[str]] = {}
    for name in names:
        head, _, rest = name.partition("/")
        if not rest or not head.startswith("run") or not head[3:].isdigit():
            continue
        members.setdefault(int(head[3:]), []).append(name.removesuffix(".npy"))
    return members
