"""MCAP files and ROS bags on a simulation clock (log times before 1973: Gazebo's
``/clock`` from 0, a harness from 0.1 s) have relative times, as a CSV without dates
does: several runs that each start near 0 are refused as one archive (they were stitched,
and all but the first run's overlap dropped: 8903 of the 9989 messages of cart-pole's
kinda_works.mcap), relative files of different channels are merged, and one beside a
file of Unix times is refused (one clock). Files with Unix times are stitched as before.
Logs are built with the project's writers (mcap, rosbags)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from readers_helpers import T0, collect

from analyzer.cli import main
from analyzer.errors import ReaderError
from analyzer.readers import Unstitchable, open_archive, open_input
from analyzer.writers import write_archive

SIM0 = 100_000_000  # 0.1 s on the simulation clock
STEP = 10_000_000  # 100 Hz
NAMES = {"mcap": "run{}.mcap", "ros1bag": "run{}.bag", "ros2bag": "run{}_bag"}
FORMATS = list(NAMES)


def _run(folder: Path, fmt: str, k: int, start: int, key: str = "s0", n: int = 300) -> Path:
    """Run ``k``: ``n`` samples of channel ``/{key}.data`` from ``start`` (log time)."""
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / NAMES[fmt].format(k)
    t_ns = start + np.arange(n, dtype=np.int64) * STEP
    write_archive(path, fmt, t_ns, {key: np.sin(np.arange(n) / 10.0 + k)})
    return path


@pytest.mark.parametrize("fmt", FORMATS)
def test_sim_clock_file_has_relative_times(tmp_path: Path, fmt: str) -> None:
    """The reader says which clock its file keeps (it said Unix times for every MCAP
    and bag)."""
    assert not open_input(_run(tmp_path, fmt, 0, SIM0)).info.absolute_time
    assert open_input(_run(tmp_path, fmt, 1, T0)).info.absolute_time


@pytest.mark.parametrize("fmt", FORMATS)
def test_sim_clock_runs_that_overlap_are_refused(
    tmp_path: Path, fmt: str, capsys: pytest.CaptureFixture[str]
) -> None:
    """Three runs, each from 0.1 s, one channel: refused naming two of them (runs 1 and
    2 were dropped sample by sample as "overlap the previous input"); exit 2, one line."""
    folder = tmp_path / "sim"
    for k in range(3):
        _run(folder, fmt, k, SIM0)
    archive = open_archive(folder)
    with pytest.raises(
        Unstitchable,
        match=(
            r"run0\S* and \S*run1\S* have relative times \(seconds from their own start\) and "
            r"both hold /s0\.data over the same span: they cannot be stitched in time"
        ),
    ):
        collect(archive.chunks())
    assert main(["inspect", str(folder)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith("analyzer: error: ") and "run1" in err
    assert main(["inspect", str(next(folder.iterdir()))]) == 0  # one at a time: fine
    capsys.readouterr()


@pytest.mark.parametrize("fmt", FORMATS)
def test_sim_clock_runs_of_other_channels_merge(tmp_path: Path, fmt: str) -> None:
    """One file per simulated sensor, each from 0.1 s, different channels: merged, as
    relative CSV files of different channels are."""
    paths = [_run(tmp_path, fmt, 0, SIM0, "a0"), _run(tmp_path, fmt, 1, SIM0, "b0")]
    archive = open_archive(paths)
    samples = collect(archive.chunks())
    assert {n: t.size for n, (t, _) in samples.items()} == {"/a0.data": 300, "/b0.data": 300}
    assert all(not i.errors for i in archive.inputs)


def test_sim_clock_run_beside_unix_times_is_refused(tmp_path: Path) -> None:
    """A simulated run beside a recording of Unix times: one archive needs one clock (it
    was stitched with a 56-year gap)."""
    sim = _run(tmp_path, "mcap", 0, SIM0)
    real = _run(tmp_path, "ros1bag", 1, T0)
    with pytest.raises(ReaderError, match=r"run0\.mcap has relative times .*run1\.bag Unix"):
        open_archive([sim, real])


@pytest.mark.parametrize("fmt", FORMATS)
def test_unix_time_files_that_overlap_still_stitch(tmp_path: Path, fmt: str) -> None:
    """Files of Unix times that overlap: the overlap is dropped with a line, as before."""
    paths = [_run(tmp_path, fmt, 0, T0), _run(tmp_path, fmt, 1, T0 + 200 * STEP)]
    archive = open_archive(paths)
    samples = collect(archive.chunks())
    assert samples["/s0.data"][0].size == 500
    assert archive.inputs[1].errors == [
        "/s0: 100 messages overlap the previous input in time (990 ms that "
        f"{paths[0].name} covers already; its samples are kept); dropped"
    ]


@pytest.mark.realdata
def test_cart_pole_runs_are_not_stitched(corpus: Path) -> None:
    """cart-pole: three runs of a simulated cart-pole from 0.1 s (1970) and test.mcap of
    2024. The folder needs one clock; the three runs cannot be stitched; each alone is
    read whole (kinda_works.mcap's 9989 states: 1086 were left after stitching)."""
    folder = corpus / "mcap/cart-pole"
    with pytest.raises(ReaderError, match=r"kinda_works\.mcap has relative times .*test\.mcap"):
        open_archive(folder)
    runs = [folder / f"{n}.mcap" for n in ("kinda_works", "simulation_example", "out_of_bounds")]
    with pytest.raises(Unstitchable, match=r"out_of_bounds\.mcap and .*simulation_example\.mcap"):
        collect(open_archive(runs).chunks())
    reader = open_input(runs[0])
    assert not reader.info.absolute_time
    assert collect(reader.chunks())["/cartpole/state.cart_position"][0].size == 9989
    assert open_input(folder / "test.mcap").info.absolute_time


def test_a_dated_recording_with_one_message_logged_at_zero_keeps_its_dates(tmp_path: Path) -> None:
    """The end decides: a 2023 recording whose one constant message was logged at 0
    (published before the clock was set) was taken for a simulation clock (its start
    and onsets null; beside other dated files, refused as a second clock; the review)."""
    from mcap.writer import Writer
    from rosbags.typesys import Stores, get_typestore

    store = get_typestore(Stores.ROS2_HUMBLE)
    kind = "std_msgs/msg/Float64"
    text = store.generate_msgdef(kind, ros_version=2)[0]

    def payload(x: float) -> bytes:
        return bytes(store.serialize_cdr(store.types[kind](data=x), kind))

    path = tmp_path / "dated.mcap"
    with path.open("wb") as handle:
        writer = Writer(handle)
        writer.start(profile="ros2", library="test")
        schema = writer.register_schema(kind, "ros2msg", text.encode())
        meta = writer.register_channel("/meta", "cdr", schema)
        data = writer.register_channel("/s0", "cdr", schema)
        writer.add_message(meta, log_time=0, data=payload(1.0), publish_time=0)
        for i in range(50):
            t = T0 + i * STEP
            writer.add_message(data, log_time=t, data=payload(float(i)), publish_time=t)
        writer.finish()
    assert open_input(path).info.absolute_time
    assert not open_input(_run(tmp_path, "mcap", 0, SIM0)).info.absolute_time
