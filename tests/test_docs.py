"""The project's own documentation (README.md and docs/) against the code: every link leads to a
file of the repository (and a heading there), the home file reference's example loads and every
key the loader accepts is documented, every command and option is in the command reference, and
every path of the HTTP API's schema is in the API reference."""

from __future__ import annotations

import copy
import re
from pathlib import Path
from typing import Any

import pytest
import yaml

from homecog.errors import HomeFileError
from homecog.home import load_home_text
from homecog.home.home_file import read_yaml

ROOT = Path(__file__).resolve().parent.parent
DOCS = sorted((ROOT / "docs").glob("*.md"))
PAGES = [ROOT / "README.md", *DOCS]
LINK = re.compile(r"!?\[(?:[^\]\[]|\[[^\]]*\])*\]\(\s*<?([^)\s>]+)>?(?:\s+\"[^\"]*\")?\s*\)")
FENCE = re.compile(r"^(```|~~~).*?^\1", re.S | re.M)


def prose(text: str) -> str:
    """The text without its fenced code blocks and inline code, where a link is no link."""
    return re.sub(r"`[^`\n]*`", "", FENCE.sub("", text))


def slug(heading: str) -> str:
    """A heading's anchor as GitHub makes it.

    >>> slug("Missing readings: `unknown`"), slug("The running system: `bin/bench web`")
    ('missing-readings-unknown', 'the-running-system-binbench-web')
    """
    text = re.sub(r"[`*]|\[([^\]]*)\]\([^)]*\)", r"\1", heading.strip()).lower()
    return re.sub(r"[^\w\- ]", "", text).replace(" ", "-")


def anchors(path: Path) -> set[str]:
    """Every anchor of a Markdown file: its headings' (a repeated one numbered, as GitHub does)."""
    seen: dict[str, int] = {}
    out = set()
    for line in FENCE.sub("", path.read_text(encoding="utf-8")).splitlines():
        m = re.match(r"#{1,6}\s+(.*?)\s*#*\s*$", line)
        if m:
            base = slug(m.group(1))
            n = seen.get(base, 0)
            seen[base] = n + 1
            out.add(base if n == 0 else f"{base}-{n}")
    return out


def link_problems(page: Path) -> list[str]:
    """Every link of a page that does not lead to a file of the repository (and, with an
    anchor, a heading of that file)."""
    problems = []
    for target in LINK.findall(prose(page.read_text(encoding="utf-8"))):
        where, _, anchor = target.partition("#")
        if re.match(r"^[a-z][a-z0-9+.-]*:", where) or where.startswith("/"):
            problems.append(f"{target}: leaves the repository")
            continue
        file = (page.parent / where).resolve() if where else page
        if not file.is_relative_to(ROOT) or not file.exists():
            problems.append(f"{target}: no such file in the repository")
        elif anchor and file.suffix == ".md" and anchor not in anchors(file):
            problems.append(f"{target}: no heading #{anchor} in {file.relative_to(ROOT)}")
    return problems


@pytest.mark.parametrize("page", PAGES, ids=lambda p: p.name)
def test_every_link_stays_in_the_repository_and_nothing_cites_the_design_notes(page):
    text = page.read_text(encoding="utf-8")
    assert link_problems(page) == []
    assert "SPEC" not in text
    assert "../shared" not in text and "/work/" not in text


def test_the_link_check_can_fail(tmp_path, monkeypatch):
    """A link out of the repository, to a missing file or to a missing heading is found."""
    monkeypatch.setattr(f"{__name__}.ROOT", tmp_path)
    (tmp_path / "b.md").write_text("# Title\n\n## A `code` heading\n")
    page = tmp_path / "a.md"
    page.write_text(
        "[ok](b.md#a-code-heading) [web](https://example.org) [up](../x.md) [gone](c.md)"
        " [anchor](b.md#nowhere) `[not a link](https://example.org)`\n"
    )
    assert link_problems(page) == [
        "https://example.org: leaves the repository",
        "../x.md: no such file in the repository",
        "c.md: no such file in the repository",
        "b.md#nowhere: no heading #nowhere in b.md",
    ]


# -- the home file reference --------------------------------------------------------------------
HOME_FILE = ROOT / "docs" / "home-file.md"


def example_text() -> str:
    """The complete example of docs/home-file.md (between its example markers)."""
    text = HOME_FILE.read_text(encoding="utf-8")
    m = re.search(r"<!-- example:begin -->\s*```yaml\n(.*?)```\s*<!-- example:end -->", text, re.S)
    assert m, "docs/home-file.md has no example between its markers"
    return m.group(1)


def test_the_home_file_example_loads_and_home_check_accepts_it(tmp_path, capsys):
    import json

    from homecog.cli.main import main

    path = tmp_path / "flat.yaml"
    path.write_text(example_text(), encoding="utf-8")
    assert main(["home", "check", str(path), "--json"]) == 0
    report = json.loads(capsys.readouterr().out)
    assert report["ok"] and report["name"] == "flat"
    assert (report["features"], report["devices"], report["services"], report["scenes"]) == (5, 4, 12, 1)
    assert report["unsolvable_start_states"] == 0
    home = load_home_text(example_text(), "flat.yaml")
    sections = read_yaml(example_text(), "flat.yaml")
    # every section of the file is in the example, each read
    assert set(sections) >= {"layout", "routine", "household", "home_assistant", "log", "prohibited"}
    assert home.layout is not None and home.home_assistant is not None and home.log is not None


# Where the loader checks a mapping's keys: (the section it belongs to, a path into the example
# as keys and list indexes). Inserting a key nobody knows there makes the loader name every key it
# accepts ("unknown key; expected one of ...").
PROBES: list[tuple[str, tuple[Any, ...]]] = [
    ("", ()),
    ("context", ("context", "time")),
    ("context", ("context", "activity")),
    ("devices", ("devices", "fan")),
    ("services", ("services", "LightOn")),
    ("comfort", ("comfort", "blind", 0)),
    ("needs", ("needs", "BringTea", 0)),
    ("prohibited", ("prohibited", "BlindUp", 0)),
    ("rewards", ("rewards",)),
    ("rewards", ("rewards", "weights")),
    ("layout", ("layout",)),
    ("layout", ("layout", "errands", "BringTea")),
    ("routine", ("routine", 0)),
    ("household", ("household",)),
    ("household", ("household", "weights")),
    ("home_assistant", ("home_assistant",)),
    ("home_assistant", ("home_assistant", "features", "activity")),
    ("home_assistant", ("home_assistant", "devices", "fan")),
    ("log", ("log",)),
    ("log", ("log", "features", "activity")),
    ("log", ("log", "features", "location")),
    ("log", ("log", "devices", "ceiling_light")),
]
EXPECTED = re.compile(r"unknown (?:key|kind|feature); expected (?:at, set or )?one of (.*)$")


def accepted_keys(data: dict[str, Any], path: tuple[Any, ...]) -> list[str]:
    """The keys the loader accepts at ``path``, as its error for an unknown key names them."""
    probe = copy.deepcopy(data)
    target = probe
    for step in path:
        target = target[step]
    target["zz_unknown"] = 1
    with pytest.raises(HomeFileError) as refused:
        load_home_text(yaml.safe_dump(probe, allow_unicode=True), "probe.yaml")
    message = str(refused.value)
    m = EXPECTED.search(message)
    assert m, f"{path}: not the loader's list of keys: {message}"
    keys = m.group(1).split(", ")
    if message.endswith(m.group(0)) and "expected at, set or" in message:
        keys = ["at", "set"]  # a routine step: at, set, or a categorical feature (named as such)
    return keys


def sections(text: str) -> dict[str, str]:
    """The reference's text per top-level section (``## `name` ``)."""
    parts = re.split(r"^## ", text, flags=re.M)
    out = {}
    for part in parts[1:]:
        m = re.match(r"`(\w+)`", part)
        if m:
            out[m.group(1)] = part
    return out


def test_every_key_the_loader_accepts_is_in_the_home_file_reference():
    data = read_yaml(example_text(), "flat.yaml")
    text = HOME_FILE.read_text(encoding="utf-8")
    by_section = sections(text)
    found = {}
    for section, path in PROBES:
        where = by_section[section] if section else text.split("## `context`")[0]
        keys = accepted_keys(data, path)
        assert keys, path
        missing = [k for k in keys if f"`{k}`" not in where]
        assert missing == [], f"{'.'.join(map(str, path)) or 'top level'}: {missing} not documented"
        found[path] = keys
    # a section of its own for every top-level key but the two plain ones
    assert set(found[()]) - {"name", "description"} == set(by_section)
    assert sum(len(k) for k in found.values()) >= 70  # the loader's whole vocabulary, probed


def test_an_undocumented_key_would_be_found():
    """The probe reads the loader's own list: a section whose keys the text lacks is caught."""
    data = read_yaml(example_text(), "flat.yaml")
    keys = accepted_keys(data, ("layout", "errands", "BringTea"))
    assert keys == ["bring", "pour", "dock", "say"]
    assert [k for k in keys if f"`{k}`" not in "only `bring` and `dock` here"] == ["pour", "say"]


# -- the command reference ----------------------------------------------------------------------
def commands() -> dict[str, list[str]]:
    """Every command of ``homecog`` (``homecog home check``) and its parameters as written on the
    command line (``--json``, ``FILE``, ``NAME=VALUE``), from the application itself."""
    import typer

    from homecog.cli.main import app

    out: dict[str, list[str]] = {}

    def walk(command: Any, path: list[str]) -> None:
        subcommands = getattr(command, "commands", None)
        if subcommands:
            for name, sub in subcommands.items():
                walk(sub, [*path, name])
            return
        out[" ".join(path)] = [
            p.opts[0] if p.param_type_name == "option" else (p.metavar or p.name.upper())
            for p in command.params
        ]

    walk(typer.main.get_command(app), ["homecog"])
    return out


def undocumented(text: str, known: dict[str, list[str]]) -> list[str]:
    """What the command reference lacks: a section per command (``### `homecog X` ``), and in it
    every option and argument."""
    parts = {
        m.group(1): m.group(2)
        for m in re.finditer(r"^### `(homecog[^`]*)`\n(.*?)(?=^##|\Z)", text, re.S | re.M)
    }
    problems = []
    for command, params in known.items():
        if command not in parts:
            problems.append(f"{command}: no section")
            continue
        problems += [f"{command} {p}" for p in params if f"`{p}" not in parts[command]]
    problems += [f"{command}: no such command" for command in parts if command not in known]
    return problems


def test_every_command_and_option_is_in_the_command_reference():
    known = commands()
    assert (
        len(known) == 19
        and "homecog fleet train" in known
        and "--exclude-user" in known["homecog log events"]
    )
    assert undocumented((ROOT / "docs" / "commands.md").read_text(encoding="utf-8"), known) == []


def test_a_missing_option_or_command_would_be_found():
    text = "### `homecog plan`\n\n| `--services S` | `--home H` |\n\n### `homecog fly`\n"
    assert undocumented(text, {"homecog plan": ["--services", "--json"], "homecog up": []}) == [
        "homecog plan --json",
        "homecog up: no section",
        "homecog fly: no such command",
    ]


# -- the API reference --------------------------------------------------------------------------
def operations(schema: dict[str, Any]) -> list[str]:
    """``METHOD path`` of every operation of an OpenAPI document."""
    return [f"{method.upper()} {path}" for path, ops in schema["paths"].items() for method in ops]


def test_every_path_of_the_api_schemas_is_in_the_api_reference(tmp_path):
    """The schemas as the servers give them: ``homecog up``'s ``/openapi.json``, and for
    ``homecog serve`` the list's and a home's (its paths where the fleet serves them)."""
    from fastapi.testclient import TestClient
    from webserver import LAYOUT

    from homecog.context.manual import ManualSource
    from homecog.fleet.schema import fleet_schema, prefixed
    from homecog.knowledge.pipeline import build
    from homecog.knowledge.store import Store
    from homecog.robot.runtime import Runtime
    from homecog.web.main import create_app
    from homecog.web.settings import Settings

    home = load_home_text((ROOT / "tests" / "homes" / "studio.yaml").read_text() + LAYOUT, "studio.yaml")
    store = Store.open(f"sqlite:///{tmp_path / 'k.sqlite'}", home)
    try:
        runtime = Runtime(home=home, store=store, tree=build(home, store).tree, source=ManualSource(home))
        up = (
            TestClient(create_app(runtime, Settings(token="a-token-of-the-docs"))).get("/openapi.json").json()
        )
        one = TestClient(create_app(runtime, fleet=True)).get("/openapi.json").json()
    finally:
        store.close()
    served = operations(up) + operations(fleet_schema(token=True))
    served += operations(prefixed(one, "/api/homes/{home}"))
    assert len(served) == 14 + 1 + 5 and "POST /api/actions/{action}/undo" in served
    text = (ROOT / "docs" / "api.md").read_text(encoding="utf-8")
    assert [op for op in served if f"`{op}" not in text] == []
    # and the reference names no operation the servers lack
    named = set(re.findall(r"`((?:GET|PUT|POST|DELETE) /api[^`\s]*)", text))
    schemas = {"GET /api/openapi.json", "GET /api/homes/{home}/openapi.json"}
    assert named - set(served) - schemas == set()


# -- the README's tour ---------------------------------------------------------------------------
def tour() -> list[tuple[list[str], list[str]]]:
    """The tour's commands (``bin/homecog`` lines of its ``sh`` blocks), each with the output
    lines the README shows after it (those of a plain block right after its ``sh`` block)."""
    import shlex

    text = (ROOT / "README.md").read_text(encoding="utf-8")
    part = text.split("<!-- tour:begin -->")[1].split("<!-- tour:end -->")[0]
    steps: list[tuple[list[str], list[str]]] = []
    for m in re.finditer(r"```(\w*)\n(.*?)```(?=\n\n(```\n(.*?)```)?)", part, re.S):
        if m.group(1) != "sh":
            continue
        commands = [
            shlex.split(line)[1:] for line in m.group(2).splitlines() if line.startswith("bin/homecog ")
        ]
        shown = m.group(4).strip().splitlines() if m.group(3) else []
        steps += [(c, shown if i == len(commands) - 1 else []) for i, c in enumerate(commands)]
    return steps


@pytest.mark.slow
def test_the_readme_tour_runs_and_shows_what_the_commands_print(tmp_path, monkeypatch, capsys):
    from homecog.cli.main import main

    steps = tour()
    assert [s[0][0] for s in steps] == [
        "build",
        "cognize",
        "correct",
        "cognize",
        "replay",
        "plan",
        "simulate",
    ]
    assert sum(len(shown) for _, shown in steps) == 4 + 4 + 2
    monkeypatch.chdir(tmp_path)  # what the tour writes (run.png) goes here
    for args, shown in steps:
        args = [str(ROOT / a) if a.startswith("docs/") else a for a in args]
        assert main(args) == 0, args
        out = [line.strip() for line in capsys.readouterr().out.splitlines()]
        assert [line for line in shown if line.strip() not in out] == [], args
    assert (tmp_path / "run.png").read_bytes()[:4] == b"\x89PNG"
