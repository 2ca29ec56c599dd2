"""``index_view`` built the index's archives by name once per episode, and searched each
episode's list of archives once per archive (review of ux53 item 9's grouping): a year
of hourly archives, each with a fault, took 31.8 s in place of 0.25 s. The archives are
now looked up by name, built once per index. Counted here, not timed: how often the
archives are walked, and whether an episode's list is searched."""

from __future__ import annotations

from typing import Any

from analyzer.watch_index import index_view


class _Walked(list):  # type: ignore[type-arg]
    """A list that counts the times it is walked and searched with ``in``."""

    def __init__(self, items: Any) -> None:
        super().__init__(items)
        self.walks = 0
        self.searches = 0

    def __iter__(self) -> Any:
        self.walks += 1
        return super().__iter__()

    def __contains__(self, item: object) -> bool:
        self.searches += 1
        return super().__contains__(item)


def _iso(i: int) -> str:
    return f"2026-03-{1 + i // 24:02d}T{i % 24:02d}:00:00.000Z"


def _index(n_episodes: int, n_archives: int = 48) -> tuple[dict[str, Any], _Walked, list[_Walked]]:
    rows = _Walked(
        {
            "name": f"h{i:03d}.csv",
            "sha256": f"{i:064x}",
            "processed": f"p{i:03d}",
            "verdict": "fault",
            "error": None,
            "report": f"h{i:03d}.csv/report.html",
            "faulty_sensors": ["s3"],
            "start": _iso(i),
            "duration_s": 3600.0,
            "moved_to": [],
        }
        for i in range(n_archives)
    )
    lists = [_Walked([f"h{i:03d}.csv"]) for i in range(n_episodes)]
    episodes = [
        {
            "channel": "s3",
            "types": ["multiplicative"],
            "size": "gain ×0 (dead sensor)",
            "onset": _iso(i),
            "from_start": True,  # (the onset's words look at the episode's archives)
            "end": _iso(i + 1),
            "archives": lists[i],
        }
        for i in range(n_episodes)
    ]
    index = {
        "analyzer_version": "test",
        "updated": "now",
        "archives": rows,
        "episodes": episodes,
        "counts": {"fault": n_archives, "no fault": 0, "error": 0},
    }
    return index, rows, lists


def test_the_archives_are_walked_as_often_whatever_the_number_of_episodes():
    one, rows_one, _ = _index(1)
    many, rows_many, _ = _index(40)
    view_one, view_many = index_view(one), index_view(many)
    assert len(view_one.episodes) == 1 and len(view_many.episodes) == 40
    assert rows_many.walks == rows_one.walks, (rows_one.walks, rows_many.walks)


def test_no_episodes_list_of_archives_is_searched_per_archive():
    index, _, lists = _index(40)
    view = index_view(index)
    assert [ls.searches for ls in lists] == [0] * 40
    # the words are those of before: each episode there from its archive's first sample
    assert view.episodes[3].onset == f"from the start ({_iso(3)})"
    assert view.episodes[3].archives == "h003.csv"
