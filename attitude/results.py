"""Saving and loading result dataclasses (``save(path)`` / ``load(path)``).

Results are dataclasses of numpy arrays. They are stored as a compressed
``.npz`` archive: every array field (and every array inside a dict field,
under ``"field.key"``) is one entry, and the remaining plain values (strings,
numbers, booleans, None, dicts of those) go into a JSON entry ``__meta__``.
No pickle is involved, so a file cannot execute code when loaded.
"""

from __future__ import annotations

import dataclasses
import json
import platform
from datetime import UTC, datetime
from importlib import metadata
from pathlib import Path
from typing import Any, TypeVar

import numpy as np

__all__ = ["PROVENANCE_PACKAGES", "ResultIO", "provenance"]

#: The distributions whose versions a report or a campaign records (those installed).
PROVENANCE_PACKAGES = (
    "attitude-toolkit", "numpy", "scipy", "control", "slycot", "casadi", "filterpy", "matplotlib", "sgp4",
    "ppigrf", "pymap3d", "allantools", "dask", "distributed",
)  # fmt: skip


def provenance(source: str | None = None, sha256: str | None = None) -> dict[str, Any]:
    """What a result was made with: the toolkit and package versions, the date, and the input's hash.

    Parameters
    ----------
    source : str, optional
        The input the result was made from (e.g. the spacecraft file's name).
    sha256 : str, optional
        SHA-256 of that input as it was read (``SpacecraftConfig.source_sha256``,
        taken when the file was parsed, so a file edited since is not mistaken
        for the one used).

    Returns
    -------
    dict
        ``toolkit_version``, ``created_utc`` (ISO 8601, seconds), ``python``,
        ``platform``, ``packages`` (name -> version, the installed ones of
        :data:`PROVENANCE_PACKAGES`) and, with ``source``, ``input``
        (``source``, ``sha256``).
    """
    packages = {}
    for name in PROVENANCE_PACKAGES:
        try:
            packages[name] = metadata.version(name)
        except metadata.PackageNotFoundError:
            continue
    out: dict[str, Any] = {
        "toolkit_version": packages.get("attitude-toolkit", "unknown"),
        "created_utc": datetime.now(UTC).isoformat(timespec="seconds"),
        "python": platform.python_version(),
        "platform": platform.platform(),
        "packages": packages,
    }
    if source is not None:
        out["input"] = {"source": source, "sha256": sha256}
    return out


T = TypeVar("T", bound="ResultIO")

_META = "__meta__"


class ResultIO:
    """Mixin giving a dataclass ``save(path)`` and ``load(path)``."""

    def save(self, path: str | Path) -> Path:
        """Write the result to ``path`` (``.npz`` is appended if missing) and return the path.

        Parent directories are created as needed.

        Parameters
        ----------
        path : str or pathlib.Path
            Target file.

        Returns
        -------
        pathlib.Path
            The path written (ending in ``.npz``).

        Raises
        ------
        TypeError
            If the object is not a dataclass, or a field holds a value that is
            neither a numpy array nor JSON-representable.
        """
        if not dataclasses.is_dataclass(self):
            raise TypeError(f"{type(self).__name__} must be a dataclass to be saved")
        path = Path(path)
        if path.suffix != ".npz":
            path = path.with_suffix(path.suffix + ".npz")
        arrays: dict[str, np.ndarray] = {}
        meta: dict[str, Any] = {"__class__": type(self).__name__, "fields": {}}
        for f in dataclasses.fields(self):
            value = getattr(self, f.name)
            if isinstance(value, np.ndarray):
                arrays[f.name] = value
            elif isinstance(value, dict):
                plain = {}
                for key, item in value.items():
                    if isinstance(item, np.ndarray):
                        arrays[f"{f.name}.{key}"] = item
                    else:
                        plain[key] = _plain(item, f"{f.name}.{key}")
                meta["fields"][f.name] = {
                    "dict": plain,
                    "array_keys": [k for k, v in value.items() if isinstance(v, np.ndarray)],
                }
            else:
                meta["fields"][f.name] = {"value": _plain(value, f.name)}
        path.parent.mkdir(parents=True, exist_ok=True)
        np.savez_compressed(path, **arrays, **{_META: np.array(json.dumps(meta))})
        return path

    @classmethod
    def load(cls: type[T], path: str | Path) -> T:
        """Read a result written by :meth:`save`.

        Parameters
        ----------
        path : str or pathlib.Path
            File written by :meth:`save` (the full name, with ``.npz``).

        Returns
        -------
        ResultIO
            A new instance of ``cls`` with the stored fields.

        Raises
        ------
        ValueError
            If the file was written for another result class.
        """
        with np.load(Path(path), allow_pickle=False) as data:
            meta = json.loads(str(data[_META]))
            if meta.get("__class__") != cls.__name__:
                raise ValueError(f"path holds a {meta.get('__class__')!r}, not a {cls.__name__!r}: {path}")
            kwargs: dict[str, Any] = {}
            for f in dataclasses.fields(cls):  # type: ignore[arg-type]
                entry = meta["fields"].get(f.name)
                if entry is None:
                    kwargs[f.name] = np.array(data[f.name])
                elif "dict" in entry:
                    d = dict(entry["dict"])
                    for key in entry["array_keys"]:
                        d[key] = np.array(data[f"{f.name}.{key}"])
                    kwargs[f.name] = d
                else:
                    kwargs[f.name] = entry["value"]
        result = cls(**kwargs)
        result.check_loaded(str(path))
        return result

    def check_loaded(self, path: str) -> None:
        """Refuse a loaded file whose contents break the result's own rules (a subclass says which).

        Parameters
        ----------
        path : str
            The file read, named in the error.

        Raises
        ------
        ValueError
            When the contents are not a valid result (the base class accepts anything).
        """


def _plain(value: Any, name: str) -> Any:
    """Convert numpy scalars to Python ones; reject what JSON cannot hold."""
    if isinstance(value, np.generic):
        return value.item()
    if value is None or isinstance(value, (str, int, float, bool)):
        return value
    if isinstance(value, (list, tuple)):
        return [_plain(v, name) for v in value]
    if isinstance(value, dict):
        return {str(k): _plain(v, f"{name}.{k}") for k, v in value.items()}
    raise TypeError(f"result field {name} of type {type(value).__name__} cannot be saved")
