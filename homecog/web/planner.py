"""``POST /api/plan``'s planner: one process of its own, shared by every home the server holds.

A plan costs a tenth of a second to a second of Python (decomposing, then simulating the robot).
Run in the server's threads, twenty clients asking for plans held every other answer behind the
interpreter lock (``GET /api/context`` waited half a second). Here plans run one at a time in a
worker process, started at the first plan; the event loop only awaits them, so cognition and
the context answer as fast as without them (the worker runs at a lower priority, so even on a
machine of one or two cores it takes only the time the server leaves). At most
:data:`MAX_WAITING` plan requests wait at once; more get 429 with ``Retry-After``
(docs/design.md, "Hostile input").

A home goes to the worker as pickled bytes, made once per home, and the worker keeps the
homes it has unpickled, so a large home costs its unpickling once.
"""

from __future__ import annotations

import asyncio
import contextlib
import multiprocessing
import os
import pickle
import threading
import time
from collections import OrderedDict
from collections.abc import Mapping
from concurrent.futures import ProcessPoolExecutor
from concurrent.futures.process import BrokenProcessPool
from typing import Any

from fastapi import HTTPException

from homecog.home.model import Home

MAX_WAITING = 8  # plan requests waiting or running at once
_KEPT = 16  # homes a worker keeps unpickled

_homes: OrderedDict[str, Home] = OrderedDict()  # in the worker


def _plan_in_worker(
    key: str, data: bytes, services: list[str], context: Mapping[str, Any] | None, robot: str = "builtin"
) -> bytes:
    """The plan as the answer's JSON, checked against its model here: a plan's answer is large
    (its timeline and trajectory), and checking and writing it cost the server's loop
    milliseconds that cognition would wait for."""
    from homecog.robot.plans import plan_request
    from homecog.web.models import PlanOut

    home = _homes.get(key)
    if home is None:
        home = _homes[key] = pickle.loads(data)  # bytes this server made from a loaded home
        while len(_homes) > _KEPT:
            _homes.popitem(last=False)
    return PlanOut.model_validate(plan_request(home, services, context, robot)).model_dump_json().encode()


def _behind_the_server() -> None:
    """The worker yields the processor to the server (an answer waits on no plan, even where
    the machine has one core for both), and ends when the server does, however it ended."""
    with contextlib.suppress(OSError):
        os.nice(19)
    server = os.getppid()

    def watch() -> None:
        while os.getppid() == server:
            time.sleep(1)
        os._exit(0)

    threading.Thread(target=watch, daemon=True, name="homecog-planner-watch").start()


class Planner:
    """Plans in a worker process, :data:`MAX_WAITING` at most at a time."""

    def __init__(self) -> None:
        self._pool: ProcessPoolExecutor | None = None
        # id(home) -> (the home, kept so that its id is not another's; key; bytes)
        self._pickled: OrderedDict[int, tuple[Home, str, bytes]] = OrderedDict()
        self._waiting = 0

    async def plan(
        self, home: Home, services: list[str], context: Mapping[str, Any] | None, robot: str = "builtin"
    ) -> bytes:
        """The plan's answer as JSON (:class:`~homecog.web.models.PlanOut`)."""
        if self._waiting >= MAX_WAITING:
            raise HTTPException(
                429,
                detail=f"the planner is busy with {self._waiting} plans; ask again in a moment",
                headers={"Retry-After": "1"},
            )
        self._waiting += 1
        try:
            key, data = self._home(home)
            loop = asyncio.get_running_loop()
            try:
                return await loop.run_in_executor(
                    self._executor(), _plan_in_worker, key, data, services, context, robot
                )
            except BrokenProcessPool:
                self._pool = None  # the worker died (killed, out of memory): a new one next time
                raise HTTPException(503, detail="the planner stopped; ask again") from None
        finally:
            self._waiting -= 1

    def _home(self, home: Home) -> tuple[str, bytes]:
        kept = self._pickled.get(id(home))
        if kept is None:
            kept = self._pickled[id(home)] = (home, f"{home.name}:{id(home)}", pickle.dumps(home))
            while len(self._pickled) > _KEPT:
                self._pickled.popitem(last=False)
        return kept[1], kept[2]

    def close(self) -> None:
        """Stop the worker (the server stops); a later plan starts another."""
        if self._pool is not None:
            self._pool.shutdown(wait=False, cancel_futures=True)
            self._pool = None

    def _executor(self) -> ProcessPoolExecutor:
        if self._pool is None:
            spawn = multiprocessing.get_context("spawn")
            self._pool = ProcessPoolExecutor(1, mp_context=spawn, initializer=_behind_the_server)
        return self._pool


#: The server's planner (one per process: every home's app shares it).
PLANNER = Planner()
