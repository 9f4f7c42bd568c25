"""File formats by suffix: which module reads or writes each one, loaded only when it is used.

The importers (skeletons, joint-limit tables), the exporters (clips) and the renderer (videos,
contact sheets) each keep a `FormatTable` of `FileFormat` entries, in the spirit of trimesh's
`exchange` package:

    FileFormat((".usdz",), "quadpipe.exporters.usd", "export_usdz",
               "OpenUSD package: the .usdc layer in a zip", package="usd-core", imports="pxr")

An entry names its module and function as strings, so listing the formats imports nothing, and
a format whose optional package is missing is reported only when it is used, as

    out/run.usdz: error format-unavailable: format .usdz unavailable: pip install usd-core
"""

from __future__ import annotations

import importlib.util
from collections.abc import Callable, Iterator, Mapping
from dataclasses import dataclass
from importlib import import_module
from pathlib import Path

from quadpipe.core.errors import QuadpipeError


@dataclass(frozen=True)
class FileFormat:
    """One file format: the suffixes it goes by and the function that reads or writes it.

    Attributes:
        suffixes: lower-case file suffixes with their dot (`.csv`, `.tsv`).
        module: dotted path of the module holding the function, imported on first use.
        function: name of the reader or writer in that module.
        description: what the file holds, for listings and hints.
        package: the pip package the format needs beyond quadpipe's own dependencies
            (`usd-core`), None when it needs none.
        imports: the top-level module that package installs (`pxr`), looked for (not
            imported) to tell whether the format is available.
    """

    suffixes: tuple[str, ...]
    module: str
    function: str
    description: str
    package: str | None = None
    imports: str | None = None

    @property
    def available(self) -> bool:
        """Whether the package the format needs is installed (always, when it needs none)."""
        return self.imports is None or importlib.util.find_spec(self.imports) is not None

    @property
    def install_hint(self) -> str | None:
        """How to make the format available (`pip install usd-core`); None when it is."""
        return None if self.available else f"pip install {self.package}"

    def check_available(self, path: Path) -> None:
        """Raise unless the format's package is installed.

        Raises:
            QuadpipeError: code `format-unavailable`, located at `path`, with the pip hint.
        """
        if not self.available:
            raise self._unavailable(path)

    def load(self, path: Path) -> Callable:
        """The reader or writer of the format, its module imported now.

        Args:
            path: the file it is for (where an error is reported).

        Raises:
            QuadpipeError: code `format-unavailable` when the package is not installed, or
                when importing the module fails for want of it (an `ImportError`).
        """
        self.check_available(path)
        try:
            module = import_module(self.module)
        except ImportError as exc:
            if self.package is None:
                raise
            raise self._unavailable(path) from exc
        return getattr(module, self.function)

    def _unavailable(self, path: Path) -> QuadpipeError:
        return QuadpipeError.single(
            "format-unavailable",
            f"format {path.suffix.lower()} unavailable: pip install {self.package}",
            file=str(path),
            hint=f"pip install {self.package}",
        )


class FormatTable(Mapping[str, FileFormat]):
    """The formats of one kind of file (skeletons, clips, renders): suffix -> `FileFormat`.

    A read-only mapping, in the order the entries are given (the order listings use).

    Raises:
        ValueError: two entries claim the same suffix (a programming error).
    """

    def __init__(self, formats: tuple[FileFormat, ...]):
        self._by_suffix: dict[str, FileFormat] = {}
        for fmt in formats:
            for suffix in fmt.suffixes:
                if suffix in self._by_suffix:
                    raise ValueError(f"suffix {suffix} is registered twice")
                self._by_suffix[suffix] = fmt

    def __getitem__(self, suffix: str) -> FileFormat:
        return self._by_suffix[suffix]

    def __iter__(self) -> Iterator[str]:
        return iter(self._by_suffix)

    def __len__(self) -> int:
        return len(self._by_suffix)

    def find(self, path: str | Path) -> FileFormat | None:
        """The format of a file, by its suffix (case-insensitive); None when there is none."""
        return self._by_suffix.get(Path(path).suffix.lower())
