"""What homecog writes: never over one of the command's own inputs, and private to its user."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

from homecog.cli.main import main
from homecog.home import load_home

HOMES = Path(__file__).parent / "homes"
EXAMPLES = Path(__file__).parent.parent / "docs" / "examples"
LOG = "timestamp,entity,state\n2024-03-01T07:00,x10.lamp,on\n"


def refused(capsys, args: list[str], expected: str) -> None:
    assert main(args) == 2
    assert capsys.readouterr() == ("", f"homecog: error: {expected}\n")


# -- 5. an output is never an input ----------------------------------------------------------------
@pytest.fixture
def inputs(tmp_path: Path) -> Path:
    """A folder with a copy of the studio, the studio with a log section, a log and events."""
    for name in ("studio.yaml", "studio_log.yaml"):
        (tmp_path / name).write_text((HOMES / name).read_text())
    (tmp_path / "log.csv").write_text(LOG)
    (tmp_path / "events.csv").write_text((EXAMPLES / "paper_ann-events.csv").read_text())
    (tmp_path / "paper.yaml").write_text(
        Path(__file__).parent.parent.joinpath("homecog/home/homes/paper.yaml").read_text()
    )
    return tmp_path


def same_file(tmp_path: Path, target: str, how: str) -> Path:
    """``target`` itself, a symbolic link to it or another hard link of it."""
    if how == "itself":
        return tmp_path / target
    link = tmp_path / f"{how}-{target}"
    if how == "symlink":
        link.symlink_to(tmp_path / target)
    else:
        os.link(tmp_path / target, link)
    return link


@pytest.mark.parametrize("how", ["itself", "symlink", "hardlink"])
@pytest.mark.parametrize(
    ("args", "target", "option", "given_as"),
    [
        (["train", "--home", "{studio.yaml}", "--out", "{out}"], "studio.yaml", "--out", "--home"),
        (
            ["log", "events", "--home", "{studio_log.yaml}", "--log", "{log.csv}", "--out", "{out}"],
            "log.csv",
            "--out",
            "--log",
        ),
        (
            ["log", "events", "--home", "{studio_log.yaml}", "--log", "{log.csv}", "--out", "{out}"],
            "studio_log.yaml",
            "--out",
            "--home",
        ),
        (
            [
                "replay",
                "--home",
                "{paper.yaml}",
                "--events",
                "{events.csv}",
                "--methods",
                "frequency",
                "--predictions",
                "{out}",
            ],
            "events.csv",
            "--predictions",
            "--events",
        ),
        (
            ["simulate", "--home", "{paper.yaml}", "--services", "SendDrinks", "--png", "{out}"],
            "paper.yaml",
            "--png",
            "--home",
        ),
        (
            ["export", "pyrobosim", "--home", "{paper.yaml}", "--out", "{out}"],
            "paper.yaml",
            "--out",
            "--home",
        ),
    ],
)
def test_an_output_is_never_one_of_the_inputs(capsys, inputs, args, target, option, given_as, how):
    """``train --home h.yaml --out h.yaml`` wrote its Q table over the home file, ``log events
    --out`` the log it read: whether named alike, through a link or a hard link."""
    before = {p.name: p.read_bytes() for p in inputs.iterdir()}
    out = same_file(inputs, target, how)
    filled = [
        out.as_posix() if a == "{out}" else (str(inputs / a[1:-1]) if a.startswith("{") else a) for a in args
    ]
    refused(capsys, filled, f"{option} {out}: is the file of {given_as}, an input; write elsewhere")
    assert {p.name: p.read_bytes() for p in inputs.iterdir() if p.name in before} == before


def test_a_recorder_is_never_written_over(capsys, inputs):
    recorder = inputs / "home-assistant_v2.db"
    recorder.write_bytes(b"SQLite format 3\x00")
    for given in (str(recorder), f"sqlite:///{recorder}"):
        args = [
            "ha",
            "history",
            "--home",
            str(inputs / "studio.yaml"),
            "--recorder",
            given,
            "--out",
            str(recorder),
        ]
        refused(capsys, args, f"--out {recorder}: is the file of --recorder, an input; write elsewhere")
    assert recorder.read_bytes() == b"SQLite format 3\x00"


# -- 6. what homecog keeps is private -----------------------------------------------------------------
@pytest.fixture
def umask_022():
    """The usual umask, under which a file is made readable by everyone."""
    old = os.umask(0o022)
    yield
    os.umask(old)


def modes(root: Path) -> dict[str, int]:
    return {str(p.relative_to(root)): p.stat().st_mode & 0o777 for p in sorted(root.rglob("*"))}


def test_the_data_directory_is_private(capsys, tmp_path, monkeypatch, umask_022, studio_build):
    """The knowledge database and the Q tables were made by the umask (0644), the folders 0755:
    anyone on the machine could read what the household taught the robot."""
    data = tmp_path / "new" / "data"
    monkeypatch.setenv("HOMECOG_DATA", str(data))
    home = str(HOMES / "studio.yaml")
    assert main(["build", "--home", home, "--q", str(studio_build)]) == 0
    assert main(["train", "--home", home, "--episodes", "200"]) == 0
    capsys.readouterr()
    found = modes(tmp_path / "new")
    key = load_home(home).content_hash[:16]
    assert found == {
        "data": 0o700,
        "data/knowledge": 0o700,
        f"data/knowledge/studio-{key}.sqlite": 0o600,
        "data/qtables": 0o700,
        f"data/qtables/studio-{key}.npz": 0o600,
    }
    assert (tmp_path / "new").stat().st_mode & 0o777 == 0o700  # made by homecog too


def test_a_database_anywhere_and_its_wal_are_private(tmp_path, umask_022, studio):
    from homecog.knowledge.store import Store

    folder = tmp_path.stat().st_mode
    url = f"sqlite:///{tmp_path / 'k.sqlite'}"
    store = Store.open(url, studio)
    try:
        live = modes(tmp_path)
    finally:
        store.close()
    assert live == {"k.sqlite": 0o600, "k.sqlite-shm": 0o600, "k.sqlite-wal": 0o600}
    assert tmp_path.stat().st_mode == folder  # a folder of the user's: as it was


def test_a_q_table_written_anywhere_is_private(capsys, tmp_path, umask_022):
    out = tmp_path / "made" / "q.npz"
    assert main(["train", "--home", str(HOMES / "studio.yaml"), "--episodes", "200", "--out", str(out)]) == 0
    capsys.readouterr()
    assert modes(tmp_path) == {"made": 0o700, "made/q.npz": 0o600}
