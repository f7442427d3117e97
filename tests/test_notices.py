"""A command that learns or builds on its own says so on stderr, with where it keeps what it
makes: a user who points ``$HOMECOG_DATA`` or ``--db`` elsewhere sees the robot start afresh."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

from homecog.home import load_home

HOMES = Path(__file__).parent / "homes"
STUDIO = HOMES / "studio.yaml"
CONTEXT = "time=08:00,light=500,activity=work,blind=on,desk_lamp=off,radio=off"


def _run(data: Path, *args: str) -> subprocess.CompletedProcess[str]:
    env = {**os.environ, "HOMECOG_DATA": str(data)}
    env.pop("HOMECOG_DB", None)
    return subprocess.run(
        [sys.executable, "-m", "homecog.cli.main", *args, "--home", str(STUDIO), "--json"],
        capture_output=True,
        text=True,
        env=env,
        check=True,
    )


def test_cognize_says_it_trains_and_builds_and_where(tmp_path):
    home = load_home(STUDIO)
    stem = f"studio-{home.content_hash[:16]}"
    first = _run(tmp_path, "cognize", "--context", CONTEXT)
    assert json.loads(first.stdout)["services"] is not None  # stdout is still one JSON object
    assert first.stderr.splitlines() == [
        f"homecog: no knowledge tree of studio in sqlite:///{tmp_path}/knowledge/{stem}.sqlite yet: "
        "building it there",
        f"homecog: no Q table of studio in {tmp_path} yet: training one group by group, kept at "
        f"{tmp_path}/qtables/{stem}.npz",
    ]
    assert _run(tmp_path, "cognize", "--context", CONTEXT).stderr == ""  # found, nothing said
    other = tmp_path / "other.sqlite"
    again = _run(tmp_path, "correct", "--context", CONTEXT, "--want", "RadioOn", "--db", f"sqlite:///{other}")
    assert again.stderr.splitlines() == [
        f"homecog: no knowledge tree of studio in sqlite:///{other} yet: building it there"
    ]


def test_eval_says_it_trains(tmp_path):
    done = _run(tmp_path, "eval", "--scenarios", "20", "--methods", "multi")
    assert json.loads(done.stdout)["scenarios"] == 20
    (line,) = done.stderr.splitlines()
    assert line.startswith(f"homecog: no Q table of studio in {tmp_path} yet: training one group by group")
