"""Where text becomes data (`core.textfiles`, `core.yamlio`'s measuring) and the limits of `core.limits`."""

from __future__ import annotations

import codecs
import re
import time
from pathlib import Path

import pytest
import yaml

from quadpipe.core import limits, yamlio
from quadpipe.core.errors import QuadpipeError
from quadpipe.core.limits import Limit
from quadpipe.core.textfiles import decode, read_text
from quadpipe.core.yamlio import parse_yaml
from quadpipe.importers.bvh import read_skeleton as read_bvh


def _issue(error: pytest.ExceptionInfo[QuadpipeError]) -> tuple[str, str]:
    (issue,) = error.value.issues
    return issue.code, str(issue.where)


# --------------------------------------------------------------------------- decoding


def test_utf8_is_read_and_a_byte_order_mark_dropped() -> None:
    assert decode("name: é\n".encode(), "f") == "name: é\n"
    assert decode(codecs.BOM_UTF8 + b"name: x\n", "f") == "name: x\n"


@pytest.mark.parametrize(
    ("data", "where", "says"),
    [
        ("schema: 1\n".encode("utf-16"), "f:1:1", "UTF-16 byte order mark"),
        ("a: 1\nb: café\n".encode("latin-1"), "f:2:7", "byte 0xe9 at offset 11 (perhaps Latin-1"),
        (codecs.BOM_UTF8 + "a: é\n".encode("latin-1"), "f:1:4", "byte 0xe9 at offset 6"),
    ],
)
def test_bytes_that_are_not_utf8_are_located_at_the_first_bad_one(data: bytes, where: str, says: str) -> None:
    with pytest.raises(QuadpipeError) as error:
        decode(data, "f")
    assert _issue(error) == ("not-utf8", where)
    assert says in error.value.issues[0].message
    assert "save the file as UTF-8" in (error.value.issues[0].hint or "")


def test_a_nul_byte_is_not_text() -> None:
    with pytest.raises(QuadpipeError) as error:
        decode(b"a: 1\nb: x\x00y\n", "f")
    assert _issue(error) == ("not-text", "f:2:5")


def test_a_file_over_its_size_limit_is_refused_before_it_is_read(tmp_path: Path) -> None:
    path = tmp_path / "big.yaml"
    path.write_bytes(b"\xff" * 101)  # not UTF-8 either: the size is what is reported
    with pytest.raises(QuadpipeError) as error:
        read_text(path, Limit("the file's size", 100, "bytes", "use a smaller file"))
    assert _issue(error)[0] == "limit-exceeded"
    assert "over the limit of 100 bytes (101 bytes)" in error.value.issues[0].message


# --------------------------------------------------------------------------- YAML measuring


def _small(monkeypatch: pytest.MonkeyPatch, name: str, value: float) -> None:
    old = getattr(limits, name)
    monkeypatch.setattr(limits, name, Limit(old.what, value, old.unit, old.advice))


DOCUMENT = "a: &x [1, 2, 3]\nb: [*x, *x]\n"
"""16 values once expanded: the root, key a, its list and 3 items, key b, its list, 2 x 4 copied."""


def test_aliases_are_counted_expanded_without_being_expanded(monkeypatch: pytest.MonkeyPatch) -> None:
    _small(monkeypatch, "MAX_YAML_NODES", 16)
    assert parse_yaml(DOCUMENT).data == {"a": [1, 2, 3], "b": [[1, 2, 3], [1, 2, 3]]}
    _small(monkeypatch, "MAX_YAML_NODES", 15)
    with pytest.raises(QuadpipeError) as error:
        parse_yaml(DOCUMENT, "f")
    assert _issue(error) == ("limit-exceeded", "f:2:9")


def test_alias_uses_are_counted(monkeypatch: pytest.MonkeyPatch) -> None:
    _small(monkeypatch, "MAX_YAML_ALIASES", 1)
    with pytest.raises(QuadpipeError) as error:
        parse_yaml(DOCUMENT, "f")
    assert _issue(error) == ("limit-exceeded", "f:2:9")


def test_a_billion_laughs_is_refused_at_once() -> None:
    lines = ["a0: &a0 [lol, lol, lol, lol, lol, lol, lol, lol, lol]"]
    lines += [f"a{i}: &a{i} [{', '.join([f'*a{i - 1}'] * 9)}]" for i in range(1, 12)]
    start = time.perf_counter()
    with pytest.raises(QuadpipeError) as error:
        parse_yaml("\n".join(lines), "f")
    assert _issue(error)[0] == "limit-exceeded"
    assert time.perf_counter() - start < 1.0


def test_nesting_deeper_than_the_limit_is_refused_before_python_recurses() -> None:
    depth = 50_000
    with pytest.raises(QuadpipeError) as error:
        parse_yaml("x: " + "[" * depth + "]" * depth, "f")
    assert _issue(error) == ("limit-exceeded", "f:1:103")  # the 100th "[" is the 101st level


class _LibyamlWithANestingLimit(yaml.SafeLoader):
    """PyYAML's loader refusing a flow nesting past 1000 levels as a syntax error, as the libyaml
    of some PyYAML wheels does ("while increasing flow level: exceeded maximum nesting depth")."""

    def fetch_flow_collection_start(self, token_class: type) -> None:  # type: ignore[override]
        if self.flow_level >= 1000:
            mark = self.get_mark()
            raise yaml.scanner.ScannerError("while increasing flow level", mark, "exceeded maximum nesting depth", mark)
        super().fetch_flow_collection_start(token_class)  # type: ignore[misc]


def test_a_libyaml_that_refuses_deep_nesting_as_a_syntax_error_gives_the_same_answer(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    monkeypatch.setattr(yamlio, "_LOADER", _LibyamlWithANestingLimit)
    depth = 50_000
    with pytest.raises(QuadpipeError) as error:
        parse_yaml("x: " + "[" * depth + "]" * depth, "f")
    assert _issue(error) == ("limit-exceeded", "f:1:103")


def test_an_alias_inside_its_own_anchor_is_refused() -> None:
    with pytest.raises(QuadpipeError) as error:
        parse_yaml("a: &x [1, *x]\n", "f")
    assert _issue(error) == ("yaml-recursive-alias", "f:1:11")


def test_a_control_character_is_located() -> None:
    with pytest.raises(QuadpipeError) as error:
        parse_yaml("a: 1\nb: x\x07\n", "f")
    assert _issue(error) == ("yaml-bad-character", "f:2:5")


# --------------------------------------------------------------------------- limits


def test_a_limit_is_raised_by_its_environment_variable(monkeypatch: pytest.MonkeyPatch) -> None:
    assert limits.MAX_ANIMALS.env == "QUADPIPE_MAX_ANIMALS"
    monkeypatch.setenv("QUADPIPE_MAX_ANIMALS", "500")
    assert limits.MAX_ANIMALS.value == 500
    limits.MAX_ANIMALS.check(500)
    with pytest.raises(QuadpipeError) as error:
        limits.MAX_ANIMALS.check(501)
    assert "QUADPIPE_MAX_ANIMALS=N" in (error.value.issues[0].hint or "")


@pytest.mark.parametrize("text", ["abc", "0", "-3", "inf", "nan"])
def test_a_limit_variable_that_is_not_a_positive_number_is_an_error(monkeypatch: pytest.MonkeyPatch, text: str) -> None:
    monkeypatch.setenv("QUADPIPE_MAX_SECONDS", text)
    with pytest.raises(QuadpipeError) as error:
        _ = limits.MAX_SIMULATED_SECONDS.value
    assert error.value.issues[0].code == "bad-limit"


def test_every_limit_is_documented_with_a_unit() -> None:
    source = Path(limits.__file__).read_text(encoding="utf-8")
    named = {name: value for name, value in vars(limits).items() if isinstance(value, Limit)}
    assert len(named) >= 15
    for name, limit in named.items():
        assert limit.unit and limit.advice, name
        assert re.search(rf'^{name} = Limit\((?:(?!= Limit\().)*?^\)\n"""', source, flags=re.DOTALL | re.MULTILINE), (
            f"{name} has no docstring"
        )


# --------------------------------------------------------------------------- skeletons


def test_a_bvh_chain_deeper_than_pythons_recursion_limit_is_read(tmp_path: Path) -> None:
    depth = 1_500
    lines = ["HIERARCHY", "ROOT j0", "{", "OFFSET 0 50 0"]
    for i in range(1, depth):
        lines += [f"JOINT j{i}", "{", "OFFSET 0 0 1"]
    path = tmp_path / "deep.bvh"
    path.write_text("\n".join(lines + ["}"] * depth + ["MOTION"]) + "\n")
    joints = read_bvh(path).joints
    assert len(joints) == depth
    assert joints[-1].parent == f"j{depth - 2}"
    assert joints[-1].position == pytest.approx((0.0, 50.0, depth - 1.0))
