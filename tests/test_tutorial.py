"""docs/tutorial.md runs as written: its marked TOML blocks are written to a
scratch folder, its kinem commands and Python blocks run there in order."""
import re
import shlex
from pathlib import Path

from kinem import cli

ROOT = Path(__file__).resolve().parents[1]
BLOCK = re.compile(r"(?:<!-- file: (?P<file>[\w.]+) -->\n)?```(?P<lang>\w+)\n(?P<body>.*?)```", re.S)


def test_tutorial_runs_as_written(tmp_path, monkeypatch, capsys):
    import matplotlib

    matplotlib.use("Agg")
    monkeypatch.chdir(tmp_path)
    namespace = {"__name__": "tutorial"}
    ran = {"toml": 0, "sh": 0, "python": 0}
    for m in BLOCK.finditer((ROOT / "docs" / "tutorial.md").read_text()):
        lang, body = m["lang"], m["body"]
        if lang == "toml" and m["file"]:
            (tmp_path / m["file"]).write_text(body)
        elif lang == "sh":
            for line in body.splitlines():
                if line.startswith("kinem "):
                    code = cli.main(shlex.split(line, comments=True)[1:])
                    assert code == 0, (line, capsys.readouterr().err)
        elif lang == "python":
            exec(compile(body, "docs/tutorial.md", "exec"), namespace)
        else:
            continue
        ran[lang] += 1
    assert ran == {"toml": 2, "sh": 5, "python": 5}, ran
    out = capsys.readouterr().out
    assert "crank: frame x 0, y 0, phi 1.570796327; local O2 [0, 0], A [60, 0]" in out
    assert "the tallest coupler curve: B drawn at x =" in out
    for name in ("four_bar.csv", "sweep.csv", "coupler_curve.png", "four_bar.gif", "report/index.html",
                 "cam_lift.png"):
        assert (tmp_path / name).stat().st_size > 0, name
