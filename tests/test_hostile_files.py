"""Home files, event files and names against hostile input: one line naming what is
wrong, fast and in bounded memory; a name is never a path; nothing is learned from a file that is
refused; no folder is made outside the data directory."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import pytest

from homecog.errors import HomeFileError
from homecog.home import load_home_text
from homecog.knowledge.pipeline import build
from homecog.knowledge.store import Store
from homecog.learning.size import big_number
from homecog.names import shown

HOMES = Path(__file__).parent / "homes"
STUDIO = (HOMES / "studio.yaml").read_text()
CONTEXT = "time=10:00,light=50,activity=work,blind=off,desk_lamp=off,radio=off"
MB = 1024 * 1024


TIME = shutil.which("time", path="/usr/bin:/bin")  # GNU time: a child's own peak memory


def homecog(*args: str, env: dict[str, str] | None = None) -> tuple[int, str, str, float, float]:
    """Run the command: (status, stdout, stderr, seconds, its peak memory in MB, or 0 where GNU
    time is missing). Measured by GNU time, a small process of its own: a child forked from
    this large test process would report this process's size as its peak."""
    with tempfile.NamedTemporaryFile("r") as peak:
        timed = [TIME, "-q", "-o", peak.name, "-f", "%M"] if TIME else []
        start = time.monotonic()
        run = subprocess.run(
            [*timed, sys.executable, "-m", "homecog.cli.main", *args],
            capture_output=True,
            text=True,
            env={**os.environ, **(env or {})},
            timeout=60,
        )
        seconds = time.monotonic() - start
        kb = peak.read().strip().splitlines()
    return run.returncode, run.stdout, run.stderr, seconds, int(kb[-1]) / 1024 if kb else 0.0


def one_line_error(args: list[str], expected: str, env: dict[str, str] | None = None) -> float:
    """Assert the command fails with exactly ``expected`` as one line, within 2 s of work and
    300 MB; its seconds."""
    status, out, err, seconds, peak = homecog(*args, env=env)
    assert (status, out, err) == (2, "", f"homecog: error: {expected}\n")
    assert peak < 300, peak
    return seconds


# -- names ---------------------------------------------------------------------------------------
RULE = "1 to 64 letters, digits, _ or -, beginning with a letter or digit"


@pytest.mark.parametrize(
    "name", ["/tmp/pwn", "../../x", "a/b", "..", "x" * 65, "naïve", "-rf", "", "a b", "a.b"]
)
def test_a_home_name_is_an_identifier_never_a_path(name):
    with pytest.raises(HomeFileError) as e:
        load_home_text(STUDIO.replace("name: studio", f"name: {name!r}"), "evil.yaml")
    assert str(e.value) == f"evil.yaml: name: {shown(name)} is not a home name: {RULE}"


def test_nothing_is_written_outside_the_data_directory(tmp_path):
    """A name that climbed out of the data directory made its folders and wrote its Q tables
    and database there; a database URL made its folders (``/nonexist/`` at the root)."""
    data = tmp_path / "data"
    evil = tmp_path / "homes" / "evil.yaml"
    evil.parent.mkdir()
    evil.write_text(STUDIO.replace("name: studio", 'name: "../../escaped/pwn"'))
    env = {"HOMECOG_DATA": str(data)}
    one_line_error(
        ["train", "--home", str(evil)], f"{evil}: name: '../../escaped/pwn' is not a home name: {RULE}", env
    )
    nowhere = tmp_path / "no" / "such" / "folder"
    one_line_error(
        [
            "cognize",
            "--home",
            str(HOMES / "studio.yaml"),
            "--context",
            CONTEXT,
            "--db",
            f"sqlite:///{nowhere}/k.sqlite",
        ],
        f"database sqlite:///{nowhere}/k.sqlite: no folder {nowhere}; make it first",
        env,
    )
    assert sorted(p.name for p in tmp_path.iterdir()) == ["homes"] and not (tmp_path / "no").exists()


# -- home files ----------------------------------------------------------------------------------
def alias_bomb(levels: int) -> str:
    lines = ['a0: &a0 ["lol", "lol", "lol", "lol", "lol", "lol", "lol", "lol", "lol"]']
    for i in range(1, levels + 1):
        lines.append(f"a{i}: &a{i} [{', '.join([f'*a{i - 1}'] * 9)}]")
    return STUDIO.replace("unit: lx", f"unit: *a{levels}").replace(
        "context:", "\n".join(lines) + "\ncontext:", 1
    )


# a0 is line 3; a5 (597,871 values aliases expanded) is where the count passes 100,000: line 8
HOME_CASES = {
    "alias-bomb": (
        lambda p: p.write_text(alias_bomb(9)),
        "line 8: not valid YAML: more than 100,000 values (aliases expanded)",
    ),
    "nested": (lambda p: p.write_text("[" * 100_000), "line 1: not valid YAML: nested deeper than 32 levels"),
    "self-alias": (
        lambda p: p.write_text("name: &n [*n]\n"),
        "line 1: not valid YAML: an alias inside the node it names",
    ),
    "too-big": (lambda p: p.write_text("#" * (2 * MB)), "2 MiB, over the 1 MiB a home file may have"),
    "nul": (
        lambda p: p.write_text(STUDIO + "\x00\n"),
        f"line {STUDIO.count(chr(10)) + 1}: a NUL byte; a home file is text",
    ),
    "one-long-text": (  # another file given as a home: not echoed back whole
        lambda p: p.write_text("secret:" + "s" * 500_000 + "\n  more text"),
        "expected a mapping, got the text 'secret:" + "s" * 33 + "…'",
    ),
    "folder": (lambda p: p.mkdir(), "is a directory, not a home file"),
    "fifo": (lambda p: os.mkfifo(p), "is a named pipe (FIFO), not a home file"),
}


@pytest.mark.parametrize("case", list(HOME_CASES))
def test_a_hostile_home_file_is_one_line_fast_and_small(tmp_path, case):
    make, why = HOME_CASES[case]
    path = tmp_path / "home.yaml"
    make(path)
    seconds = one_line_error(["home", "check", str(path)], f"{path}: {why}")
    assert seconds < 10  # of which starting Python and homecog is most (the benchmark measures it)


def test_a_device_is_refused_as_a_home_file():
    one_line_error(["home", "show", "--home", "/dev/zero"], "/dev/zero: is a device, not a home file")


def test_ten_thousand_devices_print_their_counts_without_overflow(tmp_path):
    devices = ", ".join(f"d{i}: {{}}" for i in range(10_000))
    path = tmp_path / "many.yaml"
    path.write_text(
        "name: many\ncontext: {mode: {kind: categorical, values: [a, b]}}\n"
        f"devices: {{{devices}}}\n"
        "services: {S0: {category: c, set: {d0: on}}}\ncomfort: {d0: [{want: on}]}\n"
    )
    status, out, err, _, _ = homecog("home", "show", "--home", str(path), "--json")
    assert status == 0 and err == ""
    import json

    assert json.loads(out)["summary"]["start_states"] == 2 << 10_000
    seconds = one_line_error(
        ["train", "--joint", "--home", str(path)],
        f"many: too large to learn: the joint table has {big_number(2 << 10_000)} states (2 contexts × "
        "2^10000 device states) × 1 services; learn it group by group (without --joint)",
    )
    assert big_number(2 << 10_000) == "4.0e+3010" and seconds < 30


def test_a_malformed_context_says_which_entry():
    one_line_error(["cognize", "--context", ",,,==,"], "context: '==' is malformed: expected name=value")


# -- event files and users -----------------------------------------------------------------------
@pytest.fixture
def built_db(tmp_path, studio, studio_build) -> str:
    url = f"sqlite:///{tmp_path / 'k.sqlite'}"
    store = Store.open(url, studio)
    try:
        build(studio, store, q_path=studio_build)
    finally:
        store.close()
    return url


def events_file(path: Path, users: list[str]) -> Path:
    rows = ["timestamp,time,light,activity,blind,desk_lamp,radio,services,user"]
    for i, user in enumerate(users):
        cell = '"' + user.replace('"', '""') + '"'
        rows.append(f"2024-03-01T{8 + i // 60:02d}:{i % 60:02d},10:00,50,work,off,off,off,RadioOn,{cell}")
    path.write_bytes(("\n".join(rows) + "\n").encode())
    return path


def experiences(url: str, studio) -> int:
    store = Store.open(url, studio)
    try:
        return store.experience_count()
    finally:
        store.close()


@pytest.mark.parametrize(
    ("user", "why"),
    [
        ("a\x00b", "line 151: a NUL byte; an event file is text"),
        (
            "kim\nx",
            "line 151, column user: 'kim\\nx' is not a user name: it contains '\\n', which is not printable",
        ),
        (
            "x" * 65,
            f"line 151, column user: {'x' * 38!r}"[:-1] + "… is not a user name: longer than 64 characters",
        ),
    ],
)
def test_an_event_file_with_a_bad_user_is_refused_before_anything_is_learned(
    tmp_path, studio, built_db, user, why
):
    """The file's 150th row is the bad one: before, the first hundred rows were learned (one
    transaction) and then the file refused."""
    path = events_file(tmp_path / "events.csv", ["ann"] * 149 + [user])
    before = experiences(built_db, studio)
    one_line_error(
        ["correct", "--events", str(path), "--home", str(HOMES / "studio.yaml"), "--db", built_db],
        f"{path}: {why}",
    )
    assert experiences(built_db, studio) == before


@pytest.mark.parametrize(
    ("given", "why"),
    [
        ("/dev/zero", "is a device, not an event file"),
        ("folder", "is a directory, not an event file"),
        ("fifo", "is a named pipe (FIFO), not an event file"),
        ("missing.csv", "no such file"),
    ],
)
def test_events_that_are_not_a_file_say_what_they_are(tmp_path, given, why):
    path = Path(given) if given.startswith("/") else tmp_path / given
    if given == "folder":
        path.mkdir()
    elif given == "fifo":
        os.mkfifo(path)
    commands = [["correct", "--events", str(path)]] + (
        [["replay", "--events", str(path)]] if given == "fifo" else []
    )
    for command in commands:
        one_line_error([*command, "--home", str(HOMES / "studio.yaml")], f"--events {path}: {why}")


@pytest.mark.parametrize(
    ("user", "why"),
    [
        ("kim\n", "'kim\\n' is not a user name: it contains '\\n', which is not printable"),
        ("   ", "'   ' is not a user name: it is only white space"),
    ],
)
def test_a_user_name_is_refused_alike_by_the_command_line(user, why):
    one_line_error(
        ["cognize", "--home", str(HOMES / "studio.yaml"), "--context", CONTEXT, "--user", user],
        f"--user: {why}",
    )


EXAMPLE = str(HOMES.parent.parent / "docs" / "examples" / "paper_ann-events.csv")


# -- files to write ------------------------------------------------------------------------------
@pytest.mark.parametrize(
    ("args", "why"),
    [
        (["train", "--out", "{out}"], "--out {out}: is {kind}, not a file to write"),
        (
            ["replay", "--events", EXAMPLE, "--methods", "frequency", "--predictions", "{out}"],
            "--predictions {out}: is {kind}, not a file to write",
        ),
        (
            ["simulate", "--services", "SendDrinks", "--png", "{out}"],
            "--png {out}: is {kind}, not a file to write",
        ),
    ],
)
@pytest.mark.parametrize("given", ["/dev/null", "fifo"])
def test_a_device_or_a_pipe_is_never_written_over(tmp_path, args, why, given):
    """``train --out /dev/null`` renamed its Q table over /dev/null (a regular file since), and
    ``--predictions`` a named pipe waited for a reader for ever."""
    out = Path(given) if given.startswith("/") else tmp_path / given
    if given == "fifo":
        os.mkfifo(out)
    kind = "a device" if given.startswith("/") else "a named pipe (FIFO)"
    filled = [a.replace("{out}", str(out)) for a in args]
    one_line_error(filled, why.format(out=out, kind=kind), env={"HOMECOG_DATA": str(tmp_path / "data")})
    assert (os.stat(out).st_mode & 0o170000) in (0o020000, 0o010000)  # still a device or a pipe
