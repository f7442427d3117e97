"""The knowledge commands: build, cognize and correct, their JSON, and bad input."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from knowledge_fixtures import sample_count

from homecog.cli.main import main
from homecog.home import load_home
from homecog.knowledge.store import Store

HOMES = Path(__file__).parent / "homes"
STUDIO = str(HOMES / "studio.yaml")
CTX = "time=08:00,light=150,activity=work,blind=off,desk_lamp=off,radio=on"


@pytest.fixture(scope="module")
def built(tmp_path_factory):
    """A studio database built once: (db url, q path)."""
    tmp = tmp_path_factory.mktemp("cli")
    q = tmp / "q.npz"
    assert main(["train", "--home", STUDIO, "--episodes", "30000", "--out", str(q), "--json"]) == 0
    db = f"sqlite:///{tmp / 'studio.sqlite'}"
    assert main(["build", "--home", STUDIO, "--q", str(q), "--db", db, "--json"]) == 0
    return db, q


def run(capsys, *args):
    code = main(list(args))
    out, err = capsys.readouterr()
    return code, out, err


def test_build_json(built, capsys, tmp_path):
    _, q = built
    db = f"sqlite:///{tmp_path / 'b.sqlite'}"
    code, out, _err = run(capsys, "build", "--home", STUDIO, "--q", str(q), "--db", db, "--json")
    assert code == 0
    data = json.loads(out)
    assert set(data) >= {"samples", "nodes", "clusters", "seconds", "db"}
    assert data["samples"] == sample_count("studio") < 12 * 8  # a sample per class of contexts × device state
    assert data["nodes"] == 1 + 3 + 1 + 9  # root, open/close/care categories + idle, 8 services + Idle
    assert data["db"] == db


def test_cognize_and_correct(built, capsys):
    db, _ = built
    code, out, _ = run(capsys, "cognize", "--home", STUDIO, "--db", db, "--context", CTX, "--json")
    assert code == 0
    first = json.loads(out)
    assert set(first) >= {"services", "unknown", "explanations"}
    assert sorted(first["services"]) == ["BringTea", "LampOn", "RaiseBlind"]  # the radio: don't care at work
    assert first["unknown"] is False
    assert [e["service"] for e in first["explanations"]] == first["services"]

    code, out, _ = run(
        capsys,
        "correct",
        "--home",
        STUDIO,
        "--db",
        db,
        "--context",
        CTX,
        "--want",
        "LampOn,RaiseBlind,RadioOff",
        "--user",
        "kim",
        "--json",
    )
    assert code == 0
    data = json.loads(out)
    assert (data["added"], data["rejected"]) == (["RadioOff"], ["BringTea"])
    assert data["experiences"] == sample_count("studio") + 1  # the samples + this correction

    code, out, _ = run(
        capsys, "cognize", "--home", STUDIO, "--db", db, "--context", CTX, "--user", "kim", "--json"
    )
    assert sorted(json.loads(out)["services"]) == ["LampOn", "RadioOff", "RaiseBlind"]
    code, out, _ = run(
        capsys, "cognize", "--home", STUDIO, "--db", db, "--context", CTX, "--user", "lee", "--json"
    )
    assert sorted(json.loads(out)["services"]) == sorted(first["services"])


def _snapshot(db):
    store = Store.open(db, load_home(STUDIO))
    try:
        return store.counts(), store.load_tree().signature()
    finally:
        store.close()


BAD = [
    pytest.param(
        ["cognize", "--context", CTX + ",garden=on"],
        "unknown feature or device 'garden'",
        id="unknown-feature",
    ),
    pytest.param(
        ["cognize", "--context", CTX.replace(",radio=on", "")], "missing radio", id="missing-device"
    ),
    pytest.param(
        ["cognize", "--context", CTX.replace("activity=work", "activity=dance")],
        "activity: unknown value 'dance'; expected one of work, relax, sleep",
        id="unknown-value",
    ),
    pytest.param(
        ["cognize", "--context", CTX.replace("light=150", "light=-3")],
        "light: -3 lx is outside every bin; valid range [0, inf)",
        id="number-out-of-range",
    ),
    pytest.param(
        ["cognize", "--context", CTX.replace("light=150", "light=bright")],
        "light: not a number: 'bright'",
        id="not-a-number",
    ),
    pytest.param(
        ["cognize", "--context", CTX.replace("08:00", "25:30")],
        "time: time '25:30' out of range; expected 00:00 to 24:00",
        id="time-out-of-range",
    ),
    pytest.param(
        ["cognize", "--context", CTX.replace("radio=on", "radio=maybe")],
        "radio: unknown state 'maybe'; expected on or off",
        id="bad-device-state",
    ),
    pytest.param(
        ["cognize", "--context", "time"],
        "context: 'time' is malformed: expected name=value",
        id="not-name-value",
    ),
    pytest.param(
        ["correct", "--context", CTX, "--want", "LampOn,Dance"],
        "unknown service 'Dance'",
        id="unknown-service",
    ),
    pytest.param(
        ["correct", "--context", CTX.replace("light=150", "light=x"), "--want", "LampOn"],
        "light: not a number: 'x'",
        id="correct-bad-context",
    ),
]


@pytest.mark.parametrize(("args", "message"), BAD)
def test_bad_input_is_one_line_and_changes_nothing(built, capsys, args, message):
    db, _ = built
    before = _snapshot(db)
    code, out, err = run(capsys, *args, "--home", STUDIO, "--db", db)
    assert code == 2
    assert out == ""
    assert err.count("\n") == 1 and err.startswith("homecog: error: ")
    assert message in err
    assert "Traceback" not in err
    assert _snapshot(db) == before


def test_wrong_and_unreachable_database_urls(capsys, tmp_path):
    for url, message in [
        ("nosuchdb://x", "not a database URL"),
        ("postgresql+psycopg://postgres@127.0.0.1:1/x", "cannot use the database"),
        (f"sqlite:///{tmp_path / 'file.txt' / 'x.sqlite'}", "database sqlite:///"),
    ]:
        if url.startswith("sqlite"):
            (tmp_path / "file.txt").write_text("not a directory")
        code, out, err = run(capsys, "cognize", "--home", STUDIO, "--db", url, "--context", CTX)
        assert code == 2, url
        assert out == ""
        assert err.count("\n") == 1 and message in err, err
        assert "Traceback" not in err


def test_database_made_for_another_home(built, capsys, tmp_path):
    """A database holds many homes by name; a home file of the same name and other content is
    refused, naming both hashes, and nothing stored changes."""
    db, _ = built
    before = _snapshot(db)
    other = tmp_path / "studio.yaml"
    other.write_text(Path(STUDIO).read_text() + "\nrewards: {magnitude: 5}\n")
    code, _out, err = run(capsys, "correct", "--home", other, "--db", db, "--context", CTX, "--want", "")
    assert code == 2
    assert "holds the knowledge of home 'studio'" in err and "not of this file's home 'studio'" in err
    assert err.count("\n") == 1
    assert _snapshot(db) == before


def test_build_bad_arguments(capsys, tmp_path):
    for args, message in [
        (
            ["--mode", "deep"],
            "Invalid value for '--mode': Value error, 'deep' is not one of 'multi', 'paper'",
        ),
        (["--q", str(tmp_path / "none.npz")], "none.npz: no such file"),
        (["--seed", "-1"], "Invalid value for '--seed': Input should be greater than or equal to 0"),
    ]:
        code, _out, err = run(
            capsys, "build", "--home", STUDIO, "--db", f"sqlite:///{tmp_path / 'x.sqlite'}", *args
        )
        assert code == 2 and message in err and err.count("\n") == 1, err


def test_correct_add_and_reject_keep_the_other_services(built, capsys, tmp_path):
    _, q = built
    db = f"sqlite:///{tmp_path / 'add.sqlite'}"
    OFF = CTX.replace("radio=on", "radio=off")  # noqa: N806
    assert main(["build", "--home", STUDIO, "--q", str(q), "--db", db, "--json"]) == 0
    capsys.readouterr()

    def cognize(user):
        code, out, _ = run(
            capsys, "cognize", "--home", STUDIO, "--db", db, "--context", OFF, "--user", user, "--json"
        )
        assert code == 0
        return sorted(json.loads(out)["services"])

    before = cognize("kim")
    assert before == ["BringTea", "LampOn", "RaiseBlind"]
    code, out, _ = run(
        capsys,
        "correct",
        "--home",
        STUDIO,
        "--db",
        db,
        "--context",
        OFF,
        "--add",
        "RadioOn",
        "--user",
        "kim",
        "--json",
    )
    assert code == 0 and json.loads(out)["added"] == ["RadioOn"] and json.loads(out)["rejected"] == []
    assert cognize("kim") == ["BringTea", "LampOn", "RadioOn", "RaiseBlind"]  # nothing else rejected
    code, out, _ = run(
        capsys,
        "correct",
        "--home",
        STUDIO,
        "--db",
        db,
        "--context",
        OFF,
        "--reject",
        "BringTea",
        "--user",
        "kim",
        "--json",
    )
    assert code == 0 and json.loads(out)["rejected"] == ["BringTea"] and json.loads(out)["added"] == []
    assert cognize("kim") == ["LampOn", "RadioOn", "RaiseBlind"]
    assert cognize("ann") == before  # for that user only
    store = Store.open(db, load_home(STUDIO))
    from homecog.knowledge.history import correction_history

    kinds = [(c.kind, c.want, c.concerns) for c in correction_history(store).corrections]
    store.close()
    assert kinds == [("explicit", ["RadioOn"], ["RadioOn"]), ("explicit", [], ["BringTea"])]
    for args, message in [
        (
            ["--want", "LampOn", "--add", "RadioOn"],
            "give a context (--context, or --at, --where, --doing, NAME=VALUE) and --want (the whole set) "
            "or --add/--reject, or --events FILE",
        ),
        (["--add", "RadioOn", "--reject", "RadioOn"], "--add and --reject both name RadioOn"),
        (["--add", ""], "--add and --reject name no service"),
        (["--add", "Dance"], "unknown service 'Dance'"),
    ]:
        code, _, err = run(capsys, "correct", "--home", STUDIO, "--db", db, "--context", OFF, *args)
        assert code == 2 and err.strip().splitlines()[0].startswith(f"homecog: error: {message}"), err
