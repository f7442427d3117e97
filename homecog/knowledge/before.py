"""What a tree's users had before corrections, to put back when the database does not store them
(:class:`~homecog.knowledge.store.Store`): memory holds exactly what the database does.

>>> from homecog.home import load_home
>>> from homecog.knowledge.ihdr import IHDRTree
>>> tree = IHDRTree(load_home("paper"))
>>> kept, versions = Before(tree), {"kim": 3}
>>> kept.keep("kim", versions)
>>> point = tree.space.point({"time": "07:00", "temperature": 25, "illumination": 100,
...     "location": "bed", "posture": "lie", "behavior": "sleep", "window": "off", "curtain": "off",
...     "tv_living": "off", "tv_bedroom": "off", "ac_living": "off", "ac_bedroom": "off",
...     "lamp": "off", "ceiling_light": "off"})
>>> _ = tree.correct_one(point, ["SendDrinks"], "kim")
>>> versions["kim"] = 4
>>> len(tree.user_examples("kim")), tree.n_experiences
(1, 1)
>>> kept.restore(versions)
>>> len(tree.user_examples("kim")), tree.n_experiences, versions
(0, 0, {'kim': 3})
"""

from __future__ import annotations

from typing import Any

from homecog.knowledge.ihdr import IHDRTree


class Before:
    """What a tree's users had before corrections (their examples, the version this store
    read, the tree's count of experiences), to put back when the corrections are not stored:
    memory holds exactly what the database does.

    A user's examples are only appended to, or replaced whole by a reload: the list and its
    length then are enough, without copying it."""

    def __init__(self, tree: IHDRTree | None) -> None:
        self.tree = tree
        self.experiences = None if tree is None else tree.n_experiences
        self.users: dict[str, tuple[list[Any], int, int | None]] = {}

    def keep(self, user: str, versions: dict[str, int]) -> None:
        if self.tree is not None and user not in self.users:
            examples = self.tree.user_examples(user)
            self.users[user] = (examples, len(examples), versions.get(user))

    def restore(self, versions: dict[str, int]) -> None:
        if self.tree is None:
            versions.clear()  # a batch without its tree: what this store believes may not be stored
            return
        for user, (examples, n, version) in self.users.items():
            self.tree.set_user_examples(user, examples[:n])
            if version is None:
                versions.pop(user, None)
            else:
                versions[user] = version
        self.tree.n_experiences = self.experiences  # type: ignore[assignment]
