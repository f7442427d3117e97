"""The smart home as a Gymnasium environment, registered as ``homecog/SmartHome-v0``.

>>> import gymnasium as gym
>>> import homecog.environment  # registers the environment
>>> env = gym.make("homecog/SmartHome-v0", home="paper")
>>> obs, info = env.reset(seed=3)
>>> env.action_space
Discrete(20)
"""

from __future__ import annotations

from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium import spaces

from homecog.environment.core import Core
from homecog.home import Home, load_home
from homecog.home.encoding import context_index, hardware_code


class SmartHomeEnv(gym.Env[np.ndarray, np.int64]):
    """A home whose devices the robot switches until the user is comfortable.

    ## Description
    The context (time, weather, where the user is and what they do) is fixed within an
    episode. Each step the robot performs one service: a device service switches its
    devices, an interaction service serves one pending need. The episode ends when
    every device the comfort rules care about is in its wanted state and no need is
    pending (the optimum).

    ## Action Space
    ``Discrete(number of services)``, in the order of the home file's ``services``.

    ## Observation Space
    ``MultiDiscrete``: one code per context feature (its value's position), then one
    0/1 per device (1 = on), then one 0/1 per interaction service that some needs rule
    can ask for (1 = still pending).

    ## Starting State
    A uniformly random context and device state that is not the optimum already, with
    every need of the context pending; ``reset(options={"context": codes, "devices":
    states})`` starts from a given one (either may be given alone).

    ## Reward
    Eq. 1 of the paper with the home's weights: ``w_p·(+m if the distance fell else −m)
    + w_t·(m if the optimum is reached) − w_x·(m if the service is prohibited)``; for the
    paper's weights −2 for a useless service, +2 for progress, +7 for the last step.

    ## Episode End
    Terminated at the optimum; truncated after ``max_episode_steps`` (default 30) by the
    registered time limit.

    ## Rendering
    ``render_mode="ansi"`` gives the state in the paper's notation (Fig. 8), e.g.
    ``612-323-21221222``: context codes (1-based), then 1 = on and 2 = off per device.
    """

    metadata = {"render_modes": ["ansi"], "render_fps": 4}  # noqa: RUF012 - gymnasium API

    def __init__(self, home: str | Home = "paper", render_mode: str | None = None) -> None:
        self.home = home if isinstance(home, Home) else load_home(home)
        self.core = Core(self.home)
        if render_mode is not None and render_mode not in self.metadata["render_modes"]:
            modes = self.metadata["render_modes"]
            raise ValueError(f"render_mode must be one of {modes}, got {render_mode!r}")
        self.render_mode = render_mode
        self._needs = list(self.home.need_services)
        nvec = [f.radix for f in self.home.features] + [2] * (len(self.home.devices) + len(self._needs))
        self.observation_space = spaces.MultiDiscrete(np.array(nvec, dtype=np.int64))
        self.action_space = spaces.Discrete(len(self.home.services))
        self._c = self._h = self._n = 0

    def _obs(self) -> np.ndarray:
        codes = self.core.codes(self._c)
        devices = [self._h >> d & 1 for d in range(self.core.n_devices)]
        needed = self.core.need_services(self._c)  # in need-bit order
        pending_services = {a for j, a in enumerate(needed) if self._n >> j & 1}
        pending = [int(a in pending_services) for a in self._needs]
        return np.array([*codes, *devices, *pending], dtype=np.int64)

    def _info(self) -> dict[str, Any]:
        return {
            "distance": self.core.distance(self._c, self._h, self._n),
            "state": self.core.index(self._c, self._h, self._n),
        }

    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[np.ndarray, dict[str, Any]]:
        super().reset(seed=seed)
        options = options or {}
        if "context" in options:
            self._c = context_index(self.home, options["context"])
        if "devices" in options:
            self._h = self.core.bits(list(options["devices"]))
        # A random start is not the optimum already (such an episode has nothing to do),
        # unless a thousand draws find none.
        for _ in range(1000):
            if "context" not in options:
                self._c = int(self.np_random.integers(self.core.n_contexts))
            if "devices" not in options:
                self._h = int(self.np_random.integers(1 << self.core.n_devices))
            if self.core.distance(self._c, self._h) > 0 or {"context", "devices"} <= options.keys():
                break
        self._n = self.core.full_needs(self._c)
        return self._obs(), self._info()

    def step(self, action: int | np.integer) -> tuple[np.ndarray, float, bool, bool, dict[str, Any]]:
        if not self.action_space.contains(action):
            raise ValueError(f"invalid action {action!r}; expected 0..{self.action_space.n - 1}")
        a = int(action)
        self._h, self._n, reward, terminated, prohibited = self.core.step(self._c, self._h, self._n, a)
        info = self._info() | {"service": self.home.services[a].name, "prohibited": prohibited}
        return self._obs(), reward, terminated, False, info

    def render(self) -> str | None:
        if self.render_mode != "ansi":
            return None
        codes = "".join(str(k + 1) for k in self.core.codes(self._c))
        half = len(codes) // 2
        return f"{codes[:half]}-{codes[half:]}-{hardware_code(self.core.states(self._h))}"
