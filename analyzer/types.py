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

MSG_PATH_ENV = "ANALYZER_MSG_PATH"
"""Environment variable holding the message path (``--msg-path`` sets it, so the
watcher's analyses inherit it): directories, separated by ``os.pathsep``, below which
each ``<package>/msg/<Type>.msg`` defines ``package/msg/Type`` for the files that embed
no definition of it (ROS 2 sqlite bags recorded before Iron, say; see
:func:`analyzer.readers.rostypes.user_store`)."""
