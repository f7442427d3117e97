"""A Q table file is a zip of ``.npy`` arrays whose headers say what they hold: a crafted header
claiming 1.6 GB in a 1.6 MB file made ``build --q`` take 8.8 s and 1.7 GB before the shape was
found wrong. Each header is checked against the home before anything is allocated."""

from __future__ import annotations

import time
import tracemalloc
import zipfile
from pathlib import Path

import numpy as np
import pytest

from homecog.cli.main import main
from homecog.errors import QTableError
from homecog.learning.grouped import train_policy
from homecog.learning.policy import Policy
from homecog.learning.qtable import QTable
from homecog.learning.sarsa import SarsaConfig

STUDIO = str(Path(__file__).parent / "homes" / "studio.yaml")
MB = 1024 * 1024


@pytest.fixture(scope="module")
def grouped(studio, tmp_path_factory) -> Path:
    """The studio's policy, group by group (the file's format 3)."""
    policy = train_policy(studio, SarsaConfig(episodes=2000, seed=0)).policy
    return policy.save(tmp_path_factory.mktemp("grouped") / "studio.npz")


def crafted(source: Path, out: Path, member: str, descr: str, shape: tuple[int, ...], body: int = 64) -> Path:
    """``source`` with ``member`` replaced by a header claiming ``descr`` of ``shape`` and
    ``body`` bytes of zeros (never what the header claims)."""
    with zipfile.ZipFile(source) as z:
        members = {n: z.read(n) for n in z.namelist()}
    with zipfile.ZipFile(out, "w", zipfile.ZIP_DEFLATED) as z:
        for name, data in members.items():
            if name != f"{member}.npy":
                z.writestr(name, data)
                continue
            with z.open(name, "w", force_zip64=True) as f:
                header = {"descr": descr, "fortran_order": False, "shape": shape}
                np.lib.format.write_array_header_1_0(f, header)
                f.write(bytes(body))
    return out


def refused_fast_and_small(load, expected: str) -> None:
    """``load()`` raises exactly ``expected`` in under a second, allocating under 8 MB."""
    tracemalloc.start()
    start = time.perf_counter()
    try:
        with pytest.raises(QTableError) as e:
            load()
        seconds = time.perf_counter() - start
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert str(e.value) == expected
    assert seconds < 1 and peak < 8 * MB, (seconds, peak)


def test_a_header_claiming_gigabytes_is_refused_before_anything_is_allocated(studio, grouped, tmp_path):
    bomb = crafted(grouped, tmp_path / "bomb.npz", "q0", "<f2", (20_000, 40_000))
    refused_fast_and_small(
        lambda: Policy.load(bomb, studio),
        f"{bomb}: group 0's table is float16 of shape (20000, 40000); this home needs float16 of shape "
        "(8, 2); train again",
    )


def test_the_command_line_refuses_it_in_one_line(capsys, studio, grouped, tmp_path):
    bomb = crafted(grouped, tmp_path / "bomb.npz", "q0", "<f2", (20_000, 40_000))
    db = tmp_path / "k.sqlite"
    assert main(["build", "--home", STUDIO, "--q", str(bomb), "--db", f"sqlite:///{db}"]) == 2
    assert capsys.readouterr() == (
        "",
        f"homecog: error: {bomb}: group 0's table is float16 of shape (20000, 40000); this home needs "
        "float16 of shape (8, 2); train again\n",
    )


@pytest.mark.parametrize(
    ("member", "descr", "shape", "why"),
    [
        (
            "q1",
            "<f2",
            (9, 4),
            "group 1's table is float16 of shape (9, 4); this home needs float16 of shape (24, 4)",
        ),
        (
            "q1",
            "<f8",
            (24, 4),
            "group 1's table is float64 of shape (24, 4); this home needs float16 of shape (24, 4)",
        ),
        (
            "q0",
            "<f2",
            (16,),
            "group 0's table is float16 of shape (16,); this home needs float16 of shape (8, 2)",
        ),
        (
            "meta",
            "<U100000000",
            (),
            "not a homecog Q table (its metadata is text of 100,000,000 characters of shape (); expected one "
            "text of at most 4,194,304 characters)",
        ),
    ],
)
def test_a_table_that_does_not_fit_its_home_is_never_used(
    studio, grouped, tmp_path, member, descr, shape, why
):
    wrong = crafted(grouped, tmp_path / "wrong.npz", member, descr, shape)
    refused_fast_and_small(
        lambda: Policy.load(wrong, studio),
        f"{wrong}: {why}; train again" if member != "meta" else f"{wrong}: {why}",
    )


def test_a_joint_table_of_the_first_format_is_checked_alike(studio, studio_build, tmp_path):
    bomb = crafted(studio_build, tmp_path / "bomb.npz", "q", "<f4", (100_000, 10_000))
    expected = (
        f"{bomb}: the table is float32 of shape (100000, 10000); this home needs float32 of shape "
        "(144, 8); train again"
    )
    refused_fast_and_small(lambda: QTable.load(bomb, studio), expected)
    refused_fast_and_small(lambda: Policy.load(bomb, studio), expected)
    marks = crafted(studio_build, tmp_path / "marks.npz", "tried", "<i8", (144, 2))
    refused_fast_and_small(
        lambda: QTable.load(marks, studio),
        f"{marks}: the table's tried marks is int64 of shape (144, 2); this home needs int64 of shape "
        "(144, 1); train again",
    )
    assert QTable.load(studio_build, studio).q.shape == (144, 8)  # the file as made still loads
