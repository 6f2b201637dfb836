"""Hostile configs: refused at once in bounded memory, one line naming the file (and the
line or the metric), in `check` and `eval` alike -- never a hang or a traceback."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import pytest

from stook.service.cli._main import run_cli

METRIC = """\
version: 1
topics:
  t: {schema: {x: int}}
metrics:
  M:
    type: test
    template: scalar
"""


@pytest.fixture(autouse=True)
def _console_errors(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("STOOK_LOG_FORMAT", "console")


def _bomb() -> str:
    """'Billion laughs': nine levels of nine aliases, 9**9 strings once expanded."""
    lines = ['  a: &a ["lol", "lol", "lol", "lol", "lol", "lol", "lol", "lol", "lol"]']
    for previous, name in zip("abcdefgh", "bcdefghi", strict=True):
        lines.append(f"  {name}: &{name} [{', '.join([f'*{previous}'] * 9)}]")
    return (
        "version: 1\nlaughs:\n" + "\n".join(lines) + "\n" + METRIC.removeprefix("version: 1\n")
    ) + "    query_string: SELECT 1\n    description: *i\n"


def _in_list(items: int) -> str:
    return "SELECT x FROM t WHERE x IN (" + ", ".join(str(i) for i in range(items)) + ")"


HOSTILE: dict[str, tuple[Callable[[], str], str]] = {
    "alias bomb": (_bomb, "line 10: its aliases expand the config past 64 MiB"),
    "alias to itself": (lambda: "version: 1\nx: &a [1, *a]\n", "line 2: alias *a refers to itself"),
    "description nested 10,000 deep": (
        lambda: (
            METRIC + "    query_string: SELECT 1\n    description: " + "[" * 10_000 + "]" * 10_000
        ),
        "line 9: ",  # libyaml's own bound may say it first
    ),
    "template_settings nested 10,000 deep": (
        lambda: (
            METRIC
            + "    query_string: SELECT 1\n    template_settings: "
            + "{a: " * 10_000
            + "1"
            + "}" * 10_000
            + "\n"
        ),
        "line 9: nested deeper than 64 levels",
    ),
    "5 MB of parentheses": (
        lambda: METRIC + "    query_string: 'SELECT " + "(" * 5_000_000 + "'\n",
        "metrics 'M': query_string is 5,000,007 characters long; Trino takes at most 1,000,000",
    ),
    "parentheses 100 deep": (
        lambda: METRIC + "    query_string: 'SELECT " + "(" * 100 + "1" + ")" * 100 + "'\n",
        "metrics 'M': query_string nests parentheses deeper than 32 levels",
    ),
    "5 MB IN list": (
        lambda: METRIC + f"    query_string: '{_in_list(650_000)}'\n",
        "metrics 'M': query_string is 5,",
    ),
    "2,001 metrics": (
        lambda: (
            "version: 1\nmetrics:\n"
            + "".join(f"  M{i}: {{type: test, query_string: SELECT 1}}\n" for i in range(2_001))
        ),
        ": 2,001 metrics; stook reads at most 2,000",
    ),
    "17 MB file": (
        lambda: (
            METRIC + "    query_string: SELECT 1\n    description: '" + "x" * 17_000_000 + "'\n"
        ),
        ": the config files are larger than 16 MiB",
    ),
}


@pytest.mark.parametrize("case", sorted(HOSTILE))
@pytest.mark.parametrize("command", ["check", "eval"])
def test_a_hostile_config_is_one_line_naming_the_file(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], case: str, command: str
) -> None:
    make, problem = HOSTILE[case]
    config = tmp_path / "config.resim.yml"
    config.write_text(make(), encoding="utf-8")
    emissions = tmp_path / "emissions.resim.jsonl"
    emissions.write_text("", encoding="utf-8")
    out = tmp_path / "out"
    args = ["metrics-config", command, str(config)]
    if command == "eval":
        args += ["--emissions", str(emissions), "--level", "test", "--outputs", str(out)]
    assert run_cli(args) == 2
    err = capsys.readouterr().err
    assert "Traceback" not in err
    (line,) = err.splitlines()
    assert str(config) in line
    assert problem in line
    assert not out.exists()


def test_the_size_cap_counts_every_file(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    half = "version: 1\nx: '" + "x" * 9_000_000 + "'\n"
    first, second = tmp_path / "a.yml", tmp_path / "b.yml"
    first.write_text(half, encoding="utf-8")
    second.write_text(half.replace("x:", "y:"), encoding="utf-8")
    assert run_cli(["metrics-config", "check", str(first)]) == 0
    assert run_cli(["metrics-config", "check", str(first), str(second)]) == 2
    assert f"{second}: the config files are larger than 16 MiB" in capsys.readouterr().err


def test_a_few_aliases_are_fine(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    text = """\
version: 1
topics:
  t: {schema: {x: int}}
defaults: &scalar
  type: test
  template: scalar
  skip_if_no_data: true
metrics:
  A: {<<: *scalar, query_string: SELECT MAX(x) AS value FROM t}
  B: {<<: *scalar, query_string: SELECT MIN(x) AS value FROM t}
"""
    config = tmp_path / "config.resim.yml"
    config.write_text(text, encoding="utf-8")
    assert run_cli(["metrics-config", "check", str(config)]) == 0
    # The anchor's home is no key the platform reads: said, not refused.
    (warning,) = capsys.readouterr().err.splitlines()
    assert "unknown key 'defaults'" in warning


def test_parentheses_in_literals_and_comments_do_not_count(tmp_path: Path) -> None:
    from stook.service.metrics_config import load_config

    deep = "(" * 40
    query = f"SELECT '{deep}' AS \"{deep}\" -- {deep}\n /* {deep} */ FROM t"
    config = tmp_path / "config.resim.yml"
    block = "".join(f"      {line}\n" for line in query.splitlines())
    config.write_text(METRIC + "    query_string: |\n" + block, encoding="utf-8")
    assert list(load_config([config]).metrics) == ["M"]
