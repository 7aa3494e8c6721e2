"""The command line as a new user meets it (issue 25, front door): help for
every argument, a suggestion for a mistyped engine, export saying what it
wrote, shell completion."""
import sys
from pathlib import Path

import pytest

from kinem.cli import main, parser

ROOT = Path(__file__).resolve().parents[1]


def test_every_argument_has_help():
    import argparse

    p = parser()
    sub = next(a for a in p._actions if isinstance(a, argparse._SubParsersAction))
    missing = [f"{name} {a.dest}" for name, command in sub.choices.items() for a in command._actions
               if not a.help and not isinstance(a, argparse._HelpAction)]
    assert missing == []


def test_a_mistyped_engine_gets_the_near_name(capsys):
    assert main(["compare", str(ROOT / "cases" / "four_bar.toml"), "--engines", "pymunk,mujocoo"]) == 2
    err = capsys.readouterr().err.strip()
    assert err == "kinem: error: --engines: unknown engine 'mujocoo'; did you mean 'mujoco'?"


def test_export_prints_the_file_it_wrote(tmp_path, capsys):
    out = tmp_path / "four_bar.xml"
    assert main(["export", str(ROOT / "cases" / "four_bar.toml"), "--engine", "mujoco", "--out", str(out)]) == 0
    assert capsys.readouterr().out == f"{out}\n" and out.read_text().startswith("<!--")


def test_completion_script(capsys):
    pytest.importorskip("shtab")
    assert main(["completion", "bash"]) == 0
    script = capsys.readouterr().out
    assert "solve" in script and "animate" in script and "--max-work" in script


def test_completion_without_shtab_names_it(monkeypatch, capsys):
    monkeypatch.setitem(sys.modules, "shtab", None)
    assert main(["completion", "bash"]) == 1
    assert capsys.readouterr().err.strip() == ("kinem: error: completion needs shtab, which is not installed: "
                                               "pip install shtab")
