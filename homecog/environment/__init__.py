"""The environment stage: the smart home as a Gymnasium environment and its vectorized core.

Importing this package registers ``homecog/SmartHome-v0``.
"""

from __future__ import annotations

from gymnasium.envs.registration import register, registry

from homecog.environment.env import SmartHomeEnv

ENV_ID = "homecog/SmartHome-v0"
DEFAULT_MAX_STEPS = 30

if ENV_ID not in registry:
    register(
        id=ENV_ID, entry_point="homecog.environment.env:SmartHomeEnv", max_episode_steps=DEFAULT_MAX_STEPS
    )

__all__ = ["DEFAULT_MAX_STEPS", "ENV_ID", "SmartHomeEnv"]
