"""The home definition stage: features, devices, services and common-sense rules."""

from __future__ import annotations

from homecog.home.content import content_hash, is_compatible
from homecog.home.home_file import builtin_homes
from homecog.home.model import ComfortRule, Condition, Device, Feature, Home, Rewards, RewardWeights, Service
from homecog.home.validator import load_home, load_home_text

__all__ = [
    "ComfortRule",
    "Condition",
    "Device",
    "Feature",
    "Home",
    "RewardWeights",
    "Rewards",
    "Service",
    "builtin_homes",
    "content_hash",
    "is_compatible",
    "load_home",
    "load_home_text",
]
