"""The suffix registry (`quadpipe.core.formats`): lookup, lazy loading, missing optional packages."""

from __future__ import annotations

import sys
from pathlib import Path

import pytest

from quadpipe.core.errors import QuadpipeError
from quadpipe.core.formats import FileFormat, FormatTable
from quadpipe.exporters import CLIP_FORMATS
from quadpipe.importers import LIMITS_FORMATS, SKELETON_FORMATS
from quadpipe.render import RENDER_FORMATS

ABSENT_MODULE = "quadpipe_test_absent_package"
"""A top-level module that no package installs."""


@pytest.fixture
def module_needing_absent_package(tmp_path, monkeypatch):
    """The name of an importable module whose own import fails: it imports `ABSENT_MODULE`."""
    name = "quadpipe_test_needs_absent_package"
    (tmp_path / f"{name}.py").write_text(f"import {ABSENT_MODULE}\n\n\ndef read(path):\n    return path\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    monkeypatch.delitem(sys.modules, name, raising=False)
    return name


def _issue(excinfo: pytest.ExceptionInfo[QuadpipeError]):
    assert len(excinfo.value.issues) == 1
    return excinfo.value.issues[0]


def test_a_module_failing_to_import_for_want_of_its_package_is_reported_with_the_pip_hint(
    module_needing_absent_package,
):
    fmt = FileFormat((".xyz",), module_needing_absent_package, "read", "test format", package="xyz-tools")
    assert fmt.available  # nothing to look for: only importing the module tells
    with pytest.raises(QuadpipeError) as excinfo:
        fmt.load(Path("out/data.XYZ"))
    issue = _issue(excinfo)
    assert issue.code == "format-unavailable"
    assert issue.message == "format .xyz unavailable: pip install xyz-tools"
    assert issue.hint == "pip install xyz-tools"
    assert issue.where.file == str(Path("out/data.XYZ"))
    assert isinstance(excinfo.value.__cause__, ImportError)


def test_a_missing_package_is_found_without_importing_the_module_and_only_when_used():
    fmt = FileFormat(
        (".xyz",), "quadpipe_test_never_imported", "read", "test format", package="xyz-tools", imports=ABSENT_MODULE
    )
    assert not fmt.available and fmt.install_hint == "pip install xyz-tools"
    for check in (fmt.check_available, fmt.load):
        with pytest.raises(QuadpipeError) as excinfo:
            check(Path("run.xyz"))
        issue = _issue(excinfo)
        assert (issue.code, issue.message, issue.where.file) == (
            "format-unavailable",
            "format .xyz unavailable: pip install xyz-tools",
            "run.xyz",
        )
    assert "quadpipe_test_never_imported" not in sys.modules


def test_an_import_error_of_a_format_without_an_optional_package_is_a_bug_and_propagates(module_needing_absent_package):
    fmt = FileFormat((".xyz",), module_needing_absent_package, "read", "test format")
    with pytest.raises(ImportError):
        fmt.load(Path("run.xyz"))


def test_an_available_format_loads_its_function_on_first_use():
    fmt = FileFormat((".json",), "json", "loads", "JSON", package="json-stdlib", imports="json")
    assert fmt.available and fmt.install_hint is None
    import json

    assert fmt.load(Path("a.json")) is json.loads


def test_a_table_finds_formats_by_suffix_in_any_case_and_keeps_its_order():
    first = FileFormat((".b", ".a"), "json", "loads", "first")
    second = FileFormat((".c",), "json", "dumps", "second")
    table = FormatTable((first, second))
    assert list(table) == [".b", ".a", ".c"] and len(table) == 3
    assert table.find("dir/x.B") is first and table.find(Path("y.c")) is second
    assert table.find("z.d") is None and table.find("no_suffix") is None
    assert ".a" in table and table[".c"] is second


def test_a_suffix_registered_twice_is_refused():
    with pytest.raises(ValueError, match=r"\.a"):
        FormatTable((FileFormat((".a",), "json", "loads", "one"), FileFormat((".a",), "json", "dumps", "two")))


@pytest.mark.parametrize("table", [SKELETON_FORMATS, LIMITS_FORMATS, CLIP_FORMATS, RENDER_FORMATS])
def test_every_registered_format_loads_a_function(table):
    for suffix, fmt in table.items():
        assert suffix == suffix.lower() and suffix.startswith(".")
        assert fmt.description
        assert callable(fmt.load(Path(f"file{suffix}"))), suffix
