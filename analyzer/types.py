"""Closed sets and small records shared by every stage."""

from __future__ import annotations

from enum import StrEnum


class Format(StrEnum):
    """Input formats, as written in ``findings.json`` ``inputs[].format``."""

    MCAP = "mcap"
    ROS1BAG = "ros1bag"
    ROS2BAG = "ros2bag"
    CSV = "csv"


class FaultType(StrEnum):
    """Fault types of the contract (Chang et al. 2017, Eq. 11-13, plus ``other``)."""

    ADDITIVE = "additive"
    MULTIPLICATIVE = "multiplicative"
    DRIFT = "drift"
    OTHER = "other"


NS_PER_S = 1_000_000_000
