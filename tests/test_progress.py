"""A long command's progress on stderr: a line every few seconds where stderr is no terminal, a
live bar where it is one, nothing on stdout but the command's own output."""

from __future__ import annotations

import io
import json
import os
import re
import subprocess
import sys
import time
from pathlib import Path

import pytest

from homecog.cli.main import main
from homecog.cli.progress import CommandProgress
from homecog.progress import Counted

ROOT = Path(__file__).resolve().parent.parent
EVENTS = ROOT / "docs" / "examples" / "paper_ann-events.csv"
LINE = re.compile(
    r"^homecog: (?P<what>[^:]+): (?P<message>.*?)(?: \((?P<share>\d+) %\))?, (?P<seconds>\d+) s$"
)


def test_off_a_terminal_a_line_every_few_seconds_and_none_for_a_short_command():
    stream = io.StringIO()
    with CommandProgress("replay", stream=stream, terminal=False, seconds=0.05) as progress:
        progress(Counted.of("events", 300, 1200))
        time.sleep(0.3)
        progress("learning corrections")
        progress.update(5, 20)
        time.sleep(0.3)
    lines = stream.getvalue().splitlines()
    assert len(lines) >= 4
    assert all(LINE.match(line) for line in lines), lines
    assert lines[0] == "homecog: replay: 300 of 1,200 events (25 %), 0 s"
    assert lines[-1].startswith("homecog: replay: learning corrections 5 of 20 (25 %), ")
    quiet = io.StringIO()
    with CommandProgress("build", stream=quiet, terminal=False, seconds=5) as progress:
        progress("making samples")  # over before the first line is due
    assert quiet.getvalue() == ""
    with CommandProgress("build", stream=quiet, terminal=False, seconds=0) as progress:
        time.sleep(0.1)  # 0: no lines at all
    assert quiet.getvalue() == ""


def test_on_a_terminal_a_live_bar_that_is_gone_at_the_end():
    stream = io.StringIO()
    with CommandProgress("cognize", stream=stream, terminal=True) as progress:
        progress("reading the tree")  # a quick command: no bar flashes
    assert stream.getvalue() == ""
    with CommandProgress("correct --events", stream=stream, terminal=True, bar_after=0) as progress:
        progress("learning corrections")
        progress.update(30, 120)
        time.sleep(0.3)  # rich draws it ten times a second
        drawn = stream.getvalue()
        progress.say("a line of the command's own")
    assert "correct --events: learning corrections" in drawn and "30/120" in drawn
    assert "━" in drawn  # the bar
    assert "a line of the command's own" in stream.getvalue()


def test_a_bad_setting_of_the_seconds_is_one_line(capsys, monkeypatch):
    monkeypatch.setenv("HOMECOG_PROGRESS_SECONDS", "often")
    assert main(["eval", "--home", str(ROOT / "tests" / "homes" / "studio.yaml"), "--scenarios", "5"]) == 2
    captured = capsys.readouterr()
    assert captured.out == ""
    assert captured.err == (
        "homecog: error: $HOMECOG_PROGRESS_SECONDS: expected seconds from 0 to 86400, got 'often'\n"
    )


@pytest.mark.parametrize(
    ("command", "what", "counts"),
    [(["replay", "--methods", "frequency"], "replay", False), (["correct"], "correct --events", True)],
)
def test_a_command_piped_to_a_file_says_its_progress_on_stderr(tmp_path, command, what, counts):
    """The installed entry point, stderr to a pipe: lines by the clock, stdout one JSON object."""
    env = {**os.environ, "HOMECOG_PROGRESS_SECONDS": "0.05", "HOMECOG_DB": f"sqlite:///{tmp_path}/k.sqlite"}
    done = subprocess.run(
        [sys.executable, "-m", "homecog.cli.main", *command, "--events", str(EVENTS), "--json"],
        capture_output=True,
        text=True,
        env=env,
        timeout=300,
        check=False,
        cwd=ROOT,
    )
    assert done.returncode == 0, done.stderr[-2000:]
    assert json.loads(done.stdout)["events"] == 288
    lines = [line for line in done.stderr.splitlines() if line.startswith(f"homecog: {what}: ")]
    assert lines, done.stderr
    assert all(LINE.match(line) for line in lines), lines
    if counts:  # how far, not only what
        assert any(m and m["share"] is not None for m in map(LINE.match, lines)), lines
