"""``homecog fleet train``: every home file of a folder learned and stored, as tasks on Ray.

Each task loads one home file, trains it group by group, makes its samples and tree, and
writes all of it, with the home file and the Q tables, through the store in one transaction:
a training killed at any moment leaves each home complete or absent. A home whose file does
not load, or that fails, is reported and the others go on; a home the database already holds
for the same content hash is skipped before any task starts.

Ray is an optional dependency (``pip install homecog[fleet]``); without ``--ray`` a local Ray
is started on this machine with ``workers`` CPUs. ``serial`` runs the same tasks one after
another in this process, for comparison and where Ray cannot be had.
"""

from __future__ import annotations

import os
import tempfile
import time
from collections.abc import Callable, Iterator
from dataclasses import asdict, dataclass
from pathlib import Path

from homecog.errors import FleetError, HomecogError, HomeFileError, StoreError
from homecog.home.validator import load_home_text
from homecog.knowledge.database import db_message, make_engine, migrate
from homecog.knowledge.store import Store
from homecog.knowledge.store_log import stored_homes
from homecog.text_files import HOME_FILE_LIMIT, read_text

QUIET = {"log_to_driver": False, "logging_level": "ERROR", "configure_logging": False}
RAY_HINT = "Ray is not installed; install it with pip install 'homecog[fleet]' (or use --serial)"


@dataclass
class HomeResult:
    """What became of one home file."""

    file: str
    home: str | None = None
    status: str = "learned"  # learned, skipped, failed
    greedy_optimal_rate: float | None = None
    samples: int = 0
    seconds: float = 0.0
    error: str | None = None

    def as_dict(self) -> dict[str, object]:
        return asdict(self)


def home_files(folder: Path) -> list[Path]:
    """The home files of a folder (``*.yaml``, ``*.yml``), by name; :class:`FleetError` when
    it is not a folder or holds none."""
    if not folder.is_dir():
        raise FleetError(f"{folder}: not a folder of home files")
    files = sorted(p for p in folder.iterdir() if p.suffix in (".yaml", ".yml") and p.is_file())
    if not files:
        raise FleetError(f"{folder}: no home files (*.yaml) in it")
    return files


def learn_home(path: str, url: str, seed: int = 0) -> HomeResult:
    """Train, sample, build and store one home file; never raises for a bad home (the result
    says why). Runs in a Ray worker, or in this process when serial."""
    from homecog.knowledge.pipeline import build_from
    from homecog.learning.grouped import train_policy
    from homecog.learning.sarsa import SarsaConfig

    start = time.perf_counter()
    result = HomeResult(file=Path(path).name)
    try:
        text = read_text(Path(path), limit=HOME_FILE_LIMIT, what="a home file", error=HomeFileError)
        home = load_home_text(text, Path(path).name)
        result.home = home.name
        trained = train_policy(home, SarsaConfig(seed=seed), workers=1)
        with tempfile.TemporaryDirectory() as tmp:
            policy = trained.policy.save(Path(tmp) / "q.npz").read_bytes()
        store = Store.open(url, home, replace=True, engine=_engine(url))
        built = build_from(
            home, trained.policy, store, start=start, seed=seed, source=text, policy_file=policy
        )
        result.samples = built.samples
        result.greedy_optimal_rate = trained.greedy_optimal_rate
    except (HomecogError, OSError, UnicodeDecodeError) as e:
        result.status, result.error = "failed", str(e) if isinstance(e, HomecogError) else f"{path}: {e}"
    except Exception as e:  # one home's surprise must not stop the fleet: reported, with its kind
        result.status, result.error = "failed", f"{Path(path).name}: {type(e).__name__}: {e}"
    result.seconds = time.perf_counter() - start
    return result


_engines: dict[str, object] = {}


def _engine(url: str):  # one engine per process: a Ray worker runs many tasks
    if url not in _engines:
        _engines[url] = make_engine(url)
    return _engines[url]


def plan(files: list[Path], url: str) -> tuple[list[Path], list[HomeResult]]:
    """Migrate the database, and split the files into those to learn and those already
    learned for the same content hash (skipped) or that do not load (failed)."""
    engine = make_engine(url)
    try:
        migrate(engine)
        with engine.connect() as conn:
            learned = {name: h for name, h, built in stored_homes(conn) if built}
    except HomecogError:
        raise
    except Exception as e:  # any failure to reach or use the database: one line
        raise StoreError(db_message(url, e)) from None
    finally:
        engine.dispose()
    todo, done = [], []
    for path in files:
        try:
            text = read_text(path, limit=HOME_FILE_LIMIT, what="a home file", error=HomeFileError)
            home = load_home_text(text, path.name)
        except (HomecogError, OSError, UnicodeDecodeError) as e:
            error = str(e) if isinstance(e, HomecogError) else f"{path.name}: {e}"
            done.append(HomeResult(file=path.name, status="failed", error=error))
            continue
        if learned.get(home.name) == home.content_hash:
            done.append(HomeResult(file=path.name, home=home.name, status="skipped"))
        else:
            todo.append(path)
    return todo, done


def run_serial(files: list[Path], url: str, seed: int = 0) -> Iterator[HomeResult]:
    """The homes one after another in this process."""
    for path in files:
        yield learn_home(str(path), url, seed)


def run_ray(
    files: list[Path], url: str, *, address: str | None, workers: int, seed: int = 0
) -> Iterator[HomeResult]:
    """The homes as Ray tasks, one CPU each, results as they finish; a local Ray of ``workers``
    CPUs unless ``address`` names a cluster."""
    os.environ.setdefault("RAY_USAGE_STATS_ENABLED", "0")  # no reports home from a robot maker's cluster
    ray = import_ray()
    started = False
    if not ray.is_initialized():
        try:
            if address is None:
                ray.init(
                    num_cpus=workers, include_dashboard=False, log_to_driver=False, logging_level="ERROR"
                )
            else:
                ray.init(address=address, **QUIET)
        except (ConnectionError, RuntimeError, ValueError) as e:
            raise FleetError(f"Ray at {address or 'local'}: cannot start or reach it: {e}") from None
        started = True
    try:
        task = ray.remote(num_cpus=1, max_retries=0)(learn_home)
        pending = {task.remote(str(p), url, seed): p for p in files}
        while pending:
            ready, _ = ray.wait(list(pending), num_returns=1)
            for ref in ready:
                path = pending.pop(ref)
                try:
                    yield ray.get(ref)
                except Exception as e:  # a worker that died: that home failed, the rest go on
                    yield HomeResult(
                        file=path.name, status="failed", error=f"{path.name}: {type(e).__name__}"
                    )
    finally:
        if started:
            ray.shutdown()


def import_ray():  # type: ignore[no-untyped-def]
    """Ray, or :class:`FleetError` saying how to install it."""
    try:
        import ray
    except ImportError:
        raise FleetError(RAY_HINT) from None
    return ray


def fleet_train(
    folder: Path,
    url: str,
    *,
    address: str | None = None,
    workers: int = 2,
    serial: bool = False,
    seed: int = 0,
    on_result: Callable[[HomeResult], None] | None = None,
) -> tuple[list[HomeResult], float]:
    """Learn every home file of ``folder`` into the database at ``url``; the results of every
    file (learned, skipped, failed) and the seconds it took."""
    start = time.perf_counter()
    files = home_files(folder)
    if not serial:
        import_ray()  # before any work: say at once how to have it
    todo, results = plan(files, url)
    for r in results:
        if on_result is not None:
            on_result(r)
    runs = (
        run_serial(todo, url, seed)
        if serial
        else run_ray(todo, url, address=address, workers=workers, seed=seed)
    )
    for r in runs:
        results.append(r)
        if on_result is not None:
            on_result(r)
    order = {p.name: i for i, p in enumerate(files)}
    results.sort(key=lambda r: order[r.file])
    return results, time.perf_counter() - start


__all__ = ["HomeResult", "fleet_train", "home_files", "learn_home"]
