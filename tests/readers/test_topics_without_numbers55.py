"""A topic read whose messages hold no number (a ``std_msgs/String``, a status text) gives
no channel; beside numeric topics it vanished from ``inspect`` without a word (ux58 #9).
``inspect`` now names it, its type and its messages, in a note and in ``--json``'s
``topics_without_numbers``."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest
from readers_helpers import T0
from test_readers_probe30 import MS, NAMES, V3S, v3s, write

from analyzer.cli import main

STRING = "std_msgs/msg/String"


def _string(text: str) -> Any:
    return lambda store: store.types[STRING](data=text)


@pytest.mark.parametrize("fmt", ["mcap", "ros1", "ros2"])
def test_a_text_topic_is_named_as_not_analyzed(
    tmp_path: Path, fmt: str, capsys: pytest.CaptureFixture[str]
) -> None:
    messages = [("/v", V3S, T0 + i * MS, v3s(T0 + i * MS, i)) for i in range(200)]
    messages += [("/chatter", STRING, T0 + i * 10 * MS, _string(f"hi {i}")) for i in range(20)]
    messages.sort(key=lambda m: m[2])
    path = write(tmp_path / NAMES[fmt], fmt, messages)
    assert main(["inspect", str(path), "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc["topics_without_numbers"] == [
        {"topic": "/chatter", "type": doc["topics_without_numbers"][0]["type"], "messages": 20}
    ]
    assert doc["topics_without_numbers"][0]["type"].replace("/msg/", "/") == "std_msgs/String"
    assert any(
        n.startswith("no numeric field in their messages, not analyzed: /chatter (std_msgs/")
        and n.endswith(", 20 messages)")
        for n in doc["notes"]
    )
    assert main(["inspect", str(path)]) == 0
    assert "note: no numeric field in their messages, not analyzed: /chatter" in (
        capsys.readouterr().out
    )


def test_numeric_topics_alone_add_nothing(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    messages = [("/v", V3S, T0 + i * MS, v3s(T0 + i * MS, i)) for i in range(200)]
    path = write(tmp_path / "x.mcap", "mcap", messages)
    assert main(["inspect", str(path), "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert "topics_without_numbers" not in doc and doc["notes"] == []
