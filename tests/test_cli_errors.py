"""The command line contract for bad input.

Bad input exits non-zero with one line on stderr, ``homecog: error: …``, never a
traceback, prints nothing on stdout and overwrites nothing. Good input with ``--json``
prints exactly one JSON object on stdout.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from homecog.cli.main import main
from homecog.environment.core import Core
from homecog.errors import QTableError
from homecog.home import load_home
from homecog.learning.qtable import QTable

HOMES = Path(__file__).parent / "homes"
STUDIO = str(HOMES / "studio.yaml")
REPO = Path(__file__).resolve().parent.parent

BROKEN_HOMES = {
    "bad.yaml": "name: [unclosed",
    "empty.yaml": "",
    "list.yaml": "- name\n- context\n",
    "nocomfort.yaml": (HOMES / "studio.yaml").read_text(encoding="utf-8").split("comfort:")[0],
    "nap.yaml": (HOMES / "studio.yaml")
    .read_text(encoding="utf-8")
    .replace("activity: [relax]}, want: on", "activity: [nap]}, want: on"),
    "overlap.yaml": (HOMES / "studio.yaml")
    .read_text(encoding="utf-8")
    .replace("dim: [0, 200]", "dim: [0, 250]"),
    "dance.yaml": (HOMES / "studio.yaml")
    .read_text(encoding="utf-8")
    .replace("RadioOn: [{when:", "Dance: [{when:"),
}


@pytest.fixture
def files(tmp_path: Path) -> Path:
    """tmp_path with the broken homes above and a regular file ``file.txt``."""
    for name, text in BROKEN_HOMES.items():
        (tmp_path / name).write_text(text, encoding="utf-8")
    (tmp_path / "file.txt").write_text("not a directory\n", encoding="utf-8")
    return tmp_path


def run(capsys: pytest.CaptureFixture[str], argv: list[str]) -> tuple[int, str, str]:
    code = main(argv)
    captured = capsys.readouterr()
    return code, captured.out, captured.err


def assert_one_line_error(code: int, out: str, err: str, names: str) -> None:
    assert code != 0
    assert out == ""
    assert "Traceback" not in err
    assert err.endswith("\n")
    lines = err.rstrip("\n").split("\n")
    assert len(lines) == 1, err
    assert lines[0].startswith("homecog: error: "), err
    assert names in lines[0], err


ERROR_CASES = [
    # home check
    pytest.param(
        ["home", "check", "{tmp}/none.yaml"], "{tmp}/none.yaml: no such file", id="check-missing-file"
    ),
    pytest.param(["home", "check", "{tmp}"], "{tmp}: is a directory, not a home file", id="check-directory"),
    pytest.param(
        ["home", "check", "{tmp}/bad.yaml"],
        "{tmp}/bad.yaml: line 2: not valid YAML: did not find expected ',' or ']'",
        id="check-not-yaml",
    ),
    pytest.param(
        ["home", "check", "{tmp}/empty.yaml"],
        "{tmp}/empty.yaml: is empty; expected a home definition",
        id="check-empty-file",
    ),
    pytest.param(
        ["home", "check", "{tmp}/list.yaml"],
        "{tmp}/list.yaml: expected a mapping, got a list",
        id="check-top-level-list",
    ),
    pytest.param(
        ["home", "check", "{tmp}/nocomfort.yaml"],
        "{tmp}/nocomfort.yaml: missing section 'comfort'",
        id="check-missing-section",
    ),
    pytest.param(
        ["home", "check", "{tmp}/nap.yaml"],
        "{tmp}/nap.yaml: comfort.radio[0].when.activity: unknown value 'nap'; "
        "expected one of work, relax, sleep",
        id="check-unknown-value",
    ),
    pytest.param(
        ["home", "check", "{tmp}/overlap.yaml"],
        "{tmp}/overlap.yaml: context.light.bins: bins 'dim' and 'bright' overlap (200 to 250)",
        id="check-overlapping-bins",
    ),
    pytest.param(
        ["home", "check", "{tmp}/dance.yaml"],
        "{tmp}/dance.yaml: prohibited.Dance: unknown service 'Dance'",
        id="check-unknown-service",
    ),
    pytest.param(
        ["home", "check", "{tmp}/nap.yaml", "--json"],
        "{tmp}/nap.yaml: comfort.radio[0].when.activity: unknown value 'nap'",
        id="check-json-still-stderr",
    ),
    pytest.param(["home", "check"], "Missing argument", id="check-without-file"),
    # home show
    pytest.param(
        ["home", "show", "--home", "nope"],
        "unknown home 'nope'; built-in homes: paper, paper_ann, or give the path of a YAML file",
        id="show-unknown-home",
    ),
    pytest.param(
        ["home", "show", "--home", "{tmp}/overlap.yaml"],
        "{tmp}/overlap.yaml: context.light.bins: bins 'dim' and 'bright' overlap",
        id="show-broken-home",
    ),
    pytest.param(["home", "bogus"], "No such command 'bogus'", id="unknown-command"),
    # train
    pytest.param(
        ["train", "--home", STUDIO, "--episodes", "-5"],
        "episodes must be 0 or more, got -5",
        id="train-negative-episodes",
    ),
    pytest.param(
        ["train", "--home", STUDIO, "--episodes", "abc"],
        "Invalid value for '--episodes'",
        id="train-episodes-not-a-number",
    ),
    pytest.param(
        ["train", "--home", STUDIO, "--alpha", "0"], "alpha must be in (0, 1], got 0", id="train-alpha-zero"
    ),
    pytest.param(
        ["train", "--home", STUDIO, "--gamma", "2"], "gamma must be in [0, 1], got 2", id="train-gamma-two"
    ),
    pytest.param(
        ["train", "--home", STUDIO, "--max-steps", "0"],
        "max_steps must be at least 1, got 0",
        id="train-zero-max-steps",
    ),
    pytest.param(
        ["train", "--home", STUDIO, "--episodes", "10", "--out", "{tmp}/file.txt/q.npz"],
        "--out {tmp}/file.txt/q.npz: cannot write there: {tmp}/file.txt is not a directory",
        id="train-out-under-a-file",
    ),
    pytest.param(
        ["train", "--home", STUDIO, "--episodes", "10", "--out", "{tmp}/file.txt/deeper/q.npz"],
        "cannot write there: {tmp}/file.txt is not a directory",
        id="train-out-deep-under-a-file",
    ),
    pytest.param(
        ["train", "--home", STUDIO, "--episodes", "10", "--out", "{tmp}"],
        "--out {tmp}: is a directory",
        id="train-out-is-a-directory",
    ),
    pytest.param(
        ["train", "--home", "{tmp}/nap.yaml", "--episodes", "10"],
        "{tmp}/nap.yaml: comfort.radio[0].when.activity: unknown value 'nap'",
        id="train-broken-home",
    ),
    pytest.param(
        ["train", "--home", STUDIO, "--epsilon-c", "nan"],
        "homecog: error: epsilon_c must be ≥ 0 and finite and epsilon_min in [0, 1]",
        id="train-epsilon-nan",
    ),
    pytest.param(
        ["train", "--home", STUDIO, "--epsilon-c", "inf"],
        "homecog: error: epsilon_c must be ≥ 0 and finite and epsilon_min in [0, 1]",
        id="train-epsilon-inf",
    ),
    pytest.param(
        ["train", "--home", STUDIO, "--max-steps", "1" + "0" * 22],
        "homecog: error: max_steps must be at most 9223372036854775807, got 1" + "0" * 22,
        id="train-max-steps-past-int64",
    ),
    pytest.param(
        ["train", "--home", STUDIO, "--episodes", "1" + "0" * 22],
        "homecog: error: episodes must be at most 9223372036854775807, got 1" + "0" * 22,
        id="train-episodes-past-int64",
    ),
    pytest.param(
        ["eval", "--home", STUDIO, "--days", "1", "--start", "9999-12-31 23:59"],
        "homecog: error: --start 9999-12-31 23:59: 1 day from then is past the year 9999",
        id="eval-start-at-the-end-of-time",
    ),
    pytest.param(["train", "--bogus"], "No such option: --bogus", id="unknown-option"),
]


@pytest.mark.parametrize(("argv", "names"), ERROR_CASES)
def test_bad_input_is_one_line_on_stderr(
    capsys: pytest.CaptureFixture[str], files: Path, argv: list[str], names: str
) -> None:
    before = sorted(p.name for p in files.iterdir())
    code, out, err = run(capsys, [a.format(tmp=files) for a in argv])
    assert_one_line_error(code, out, err, names.format(tmp=files))
    assert sorted(p.name for p in files.iterdir()) == before  # nothing written, no stray temp files


def test_no_traceback_end_to_end(files: Path) -> None:
    """The installed entry point, in a fresh interpreter: still one line, still no traceback."""
    env = {**os.environ, "HOMECOG_DATA": str(files / "data")}
    for argv, names in [
        (["home", "check", str(files / "nap.yaml")], f"{files}/nap.yaml: comfort.radio[0].when.activity"),
        (["train", "--episodes", "abc"], "Invalid value for '--episodes'"),
    ]:
        proc = subprocess.run(
            [sys.executable, "-m", "homecog.cli.main", *argv],
            capture_output=True,
            text=True,
            cwd=REPO,
            env=env,
            timeout=120,
            check=False,
        )
        assert proc.returncode == 2, proc.stderr
        assert_one_line_error(proc.returncode, proc.stdout, proc.stderr, names)


# -- overwrite nothing ---------------------------------------------------------------------------
def test_bad_input_overwrites_nothing(
    capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch, files: Path
) -> None:
    monkeypatch.setenv("HOMECOG_DATA", str(files))
    q = files / "q.npz"
    code, out, err = run(capsys, ["train", "--home", STUDIO, "--episodes", "2000", "--out", str(q), "--json"])
    assert code == 0, err
    data = json.loads(out)
    assert data["q_path"] == str(q)
    assert data["episodes"] == 2000
    assert data["home"] == "studio"
    saved = q.read_bytes()
    listing = sorted(p.name for p in files.iterdir())

    for argv, names in [
        (["--home", STUDIO, "--episodes", "-1"], "episodes must be 0 or more, got -1"),
        (["--home", STUDIO, "--episodes", "abc"], "Invalid value for '--episodes'"),
        (["--home", STUDIO, "--alpha", "0"], "alpha must be in (0, 1]"),
        (["--home", str(files / "overlap.yaml")], f"{files}/overlap.yaml: context.light.bins"),
        (["--home", str(files / "bad.yaml")], f"{files}/bad.yaml: line 2: not valid YAML"),
    ]:
        code, out, err = run(capsys, ["train", *argv, "--out", str(q)])
        assert_one_line_error(code, out, err, names)
        assert q.read_bytes() == saved
        assert sorted(p.name for p in files.iterdir()) == listing


# -- Q tables --------------------------------------------------------------------------------------
def test_q_table_of_another_home_is_refused(tmp_path: Path) -> None:
    studio, paper = load_home(HOMES / "studio.yaml"), load_home("paper")
    path = QTable.empty(Core(studio)).save(tmp_path / "q.npz")
    assert QTable.load(path, home=studio).home_name == "studio"  # the right home is accepted
    with pytest.raises(QTableError) as caught:
        QTable.load(path, home=paper)
    assert str(caught.value) == (
        f"{path} was made for home 'studio' ({studio.content_hash[:12]}), not for home 'paper' "
        f"({paper.content_hash[:12]}); train again for this home"
    )


@pytest.mark.parametrize(
    ("content", "message"),
    [
        pytest.param(b"just some text\n", "{path}: not a homecog Q table", id="text-file"),
        pytest.param(b"", "{path}: not a homecog Q table", id="empty-file"),
        pytest.param(None, "{path}: no such file", id="missing-file"),
    ],
)
def test_not_a_q_table(tmp_path: Path, content: bytes | None, message: str) -> None:
    path = tmp_path / "q.npz"
    if content is not None:
        path.write_bytes(content)
    with pytest.raises(QTableError) as caught:
        QTable.load(path, home=load_home("paper"))
    assert str(caught.value) == message.format(path=path)


# -- good input ------------------------------------------------------------------------------------
def test_home_check_json_is_one_object(capsys: pytest.CaptureFixture[str]) -> None:
    code, out, err = run(capsys, ["home", "check", STUDIO, "--json"])
    assert code == 0
    assert err == ""
    assert out.endswith("\n")
    assert out.count("\n") == 1
    data = json.loads(out)
    assert isinstance(data, dict)
    assert {"ok", "name", "contexts", "devices", "services", "states"} <= data.keys()
    assert data["ok"] is True
    assert data["name"] == "studio"
    assert (data["contexts"], data["devices"], data["services"]) == (2 * 2 * 3, 3, 8)
    assert data["states"] == 144


def test_home_show_lists_every_service(capsys: pytest.CaptureFixture[str]) -> None:
    code, out, err = run(capsys, ["home", "show", "--home", "paper"])
    assert code == 0
    assert err == ""
    paper = load_home("paper")
    assert len(paper.service_names) == 20
    missing = [name for name in paper.service_names if name not in out]
    assert missing == []
    missing_devices = [name for name in paper.device_names if name not in out]
    assert missing_devices == []
