"""A model file never runs code when it is loaded (``run``/``watch --model``): its pickle
may name only the exact ``(module, name)`` pairs of ``modelfile._ALLOWED``, and that
table holds everything the models ``--save-model`` writes name (a security audit, ux63
item H1: a crafted file ran ``touch`` through ``np.f2py.subprocess.Popen``, created a
file through ``np.memmap``, and a real model with such a command put in front ran
normally, with nothing said)."""

from __future__ import annotations

import io
import pickle
import subprocess
import sys
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from cli_helpers import one_line_error, run_cli

from analyzer.detectors.ar_kalman import ARKalmanBank
from analyzer.detectors.kalman_bank import BankFilter
from analyzer.detectors.lti import LiftedBank
from analyzer.detectors.network import Propagation
from analyzer.modelfile import _ALLOWED, MAGIC, _Restricted, framed, load_model, save_model
from analyzer.simulate import band_limited_noise, shear_building, simulate_response
from analyzer.writers import write_archive

RATE = 50.0
SENSORS = ["s0", "s1", "s2", "s3", "s4", "s5"]
REFUSED = "does not hold an analyzer model"


@pytest.fixture(scope="module")
def building(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A 3-floor building, two sensors a floor (s0..s5), its ground acceleration measured
    twice (a1, a2) and its state-space model in m.npz; 40 s at 50 Hz."""
    root = tmp_path_factory.mktemp("building")
    rng = np.random.default_rng(4)
    b = shear_building(3)
    n = int(40 * RATE)
    u = band_limited_noise(n, RATE, 2 * b.frequencies_hz[-1], rng)
    clean = np.repeat(simulate_response(b, u, RATE), 2, axis=1)
    y = clean + rng.standard_normal(clean.shape) * np.sqrt(np.mean(clean**2, axis=0)) / 10
    A, B, C, D = b.discrete(RATE)
    np.savez(root / "m.npz", A=A, B=np.hstack([B / 2, B / 2]), C=np.repeat(C, 2, axis=0),
             D=np.repeat(np.hstack([D / 2, D / 2]), 2, axis=0), dt=1 / RATE)  # fmt: skip
    data = {name: y[:, j] for j, name in enumerate(SENSORS)}
    data["a1"] = u + 0.01 * rng.standard_normal(n)
    data["a2"] = u + 0.01 * rng.standard_normal(n)
    t_ns = np.round(np.arange(n) / RATE * 1e9).astype(np.int64)
    write_archive(root / "d.csv", "csv", t_ns, data)
    (root / "groups.toml").write_text(
        '[[group]]\nname = "low"\nchannels = ["s0", "s1", "s2"]\nreference = ["s0", "s1"]\n'
        'uncertain = ["s2"]\ninputs = ["a1"]\n'
        '[[group]]\nname = "high"\nchannels = ["s3", "s4", "s5"]\nreference = ["s3", "s4"]\n'
        'uncertain = ["s5"]\ninputs = ["a1"]\n'
        '[detectors.equivalent_model]\npropagation = "chained"\ninputs = {s0 = "a1"}\n'
        '[detectors.error_function]\ndirection = "paper"\n'
    )
    (root / "model.toml").write_text(
        '[model]\nfile = "m.npz"\noutputs = ["s0", "s1", "s2", "s3", "s4", "s5"]\n'
        'inputs = ["a1", "a2"]\n[detectors.ar_kalman_bank]\norder = "aic"\n'
    )
    return root


SAVES: dict[str, list[str]] = {
    "default": [],
    "ar_kalman_bank": ["--detectors", "ar_kalman_bank"],
    "error_function": ["--detectors", "error_function"],
    "detection_filter": ["--detectors", "detection_filter"],
    "equivalent_model": ["--detectors", "equivalent_model"],
    "groups": ["--config", "groups.toml"],
    "state_space": ["--config", "model.toml"],
}
"""The models ``--save-model`` writes: each detector alone and all of them, with a
config's groups (the error functions among them) and with its ``[model]``."""


@pytest.fixture(scope="module")
def saved(building: Path) -> dict[str, Path]:
    """Each kind of :data:`SAVES`, saved by ``run --save-model`` (the writer, and so the
    format, is the one of 49eb6ce: these are the files that analyzer saved too), and the
    default model with its bank in the lifted form a filter with a long memory takes."""
    from analyzer.cli import main

    models = {}
    for kind, extra in SAVES.items():
        extra = [str(building / a) if a.endswith(".toml") else a for a in extra]
        path = building / f"{kind}.model"
        argv = ["run", str(building / "d.csv"), "--out", str(building / f"o_{kind}"),
                "--train", "0:30", "--save-model", str(path), "--no-progress", *extra]  # fmt: skip
        assert main(argv) in (0, 1), kind
        models[kind] = path
    m = load_model(models["default"])
    det, fitted = m.fits[""]["ar_kalman_bank"]
    bank = BankFilter.build(fitted.estimators, 16, fitted.innovation_inv_cov, lifted=True)
    fits = {**m.fits[""], "ar_kalman_bank": (det, replace(fitted, bank=bank))}
    models["lifted"] = building / "lifted.model"
    save_model(models["lifted"], replace(m, fits={"": fits}))
    assert isinstance(load_model(models["lifted"]).fits[""]["ar_kalman_bank"][1].bank.system,
                      LiftedBank)  # fmt: skip
    return models


class _Listing(pickle.Unpickler):
    """Every ``(module, name)`` a (trusted) pickle names, as it builds it."""

    def __init__(self, data: bytes) -> None:
        super().__init__(io.BytesIO(data))
        self.named: set[tuple[str, str]] = set()

    def find_class(self, module: str, name: str) -> Any:
        self.named.add((module, name))
        return super().find_class(module, name)


def _payload(path: Path) -> bytes:
    return path.read_bytes()[len(MAGIC) :].partition(b"\n")[2]


def test_every_kind_of_saved_model_names_only_what_the_loader_allows(saved):
    """The table stays complete: a model that names anything the table lacks fails here
    (naming it), not at a user's ``--model``."""
    allowed = {(module, name) for module, names in _ALLOWED.items() for name in names}
    named: set[tuple[str, str]] = set()
    for kind, path in saved.items():
        listing = _Listing(_payload(path))
        listing.load()
        assert listing.named <= allowed, (kind, sorted(listing.named - allowed))
        named |= listing.named
        assert load_model(path).detectors()
    assert {"error_function", "equivalent_model"} <= set(load_model(saved["groups"]).detectors())
    # every analyzer class of the table is one a saved model names: none is there for nothing
    assert {k for k in allowed if k[0].startswith("analyzer.")} <= named


@pytest.mark.filterwarnings("ignore:numpy.core:DeprecationWarning")  # numpy 1's names
def test_the_table_names_each_class_where_it_is_defined():
    """A pickle names a class by its defining module: an entry under a module that
    merely imports it would never match (and would widen the table for nothing)."""
    for module, names in _ALLOWED.items():
        for name in names:
            obj = _Restricted(io.BytesIO(b"")).find_class(module, name)
            if module.startswith("analyzer."):
                assert (obj.__module__, obj.__qualname__) == (module, name)


def _s(text: str) -> bytes:
    """A pickle's SHORT_BINUNICODE of ``text``."""
    raw = text.encode()
    return b"\x8c" + bytes([len(raw)]) + raw


def _call(module: str, name: str, *args: str) -> bytes:
    """Pickle opcodes that call ``module.name(args)`` through STACK_GLOBAL and REDUCE
    (protocol 4 follows a dotted ``name``), leaving the result on the stack."""
    return _s(module) + _s(name) + b"\x93(" + b"".join(_s(a) for a in args) + b"tR"


def _memmap(mark: Path) -> bytes:
    """Opcodes that create ``mark`` by ``np.memmap(mark, "uint8", "w+", 0, (16,))``
    reached through the detector module's ``np`` (bfs.py's gadget)."""
    call = _s("analyzer.detectors.ar_kalman") + _s("np.memmap") + b"\x93("
    return call + _s(str(mark)) + _s("uint8") + _s("w+") + b"K\x00K\x10\x85tR"


def _crafted(tmp_path: Path, real: Path) -> dict[str, tuple[Path, Path]]:
    """The audit's files (/tmp/h_ux63/evil_model.py, trojan_model.py, bfs.py), each with
    the file it would create: a ``touch`` through ``subprocess.Popen``, a file created by
    ``np.memmap``, and a real model with that put in front (then popped), which loaded
    and ran as the real model, with nothing said."""
    marks = {k: tmp_path / f"created_by_{k}" for k in ("evil", "memmap", "trojan")}
    evil = _s("analyzer.detectors.ar_kalman") + _s("np.f2py.subprocess.Popen") + b"\x93("
    evil += _s("touch") + _s(str(marks["evil"])) + b"l\x85R"  # Popen(["touch", mark])
    payload = _payload(real)
    files = {}
    for kind, data in (
        ("evil", b"\x80\x04" + evil + b"."),
        ("memmap", b"\x80\x04" + _memmap(marks["memmap"]) + b"."),
        ("trojan", payload[:2] + _memmap(marks["trojan"]) + b"0" + payload[2:]),
    ):
        files[kind] = (tmp_path / f"{kind}.model", marks[kind])
        files[kind][0].write_bytes(framed(data))
    return files


def test_the_audits_crafted_model_files_are_refused_and_run_nothing(
    saved, building, tmp_path, capsys
):
    for kind, (path, mark) in _crafted(tmp_path, saved["default"]).items():
        code, _, err = run_cli(
            ["run", building / "d.csv", "--out", tmp_path / f"o_{kind}", "--model", path,
             "--no-progress"], capsys)  # fmt: skip
        assert not mark.exists(), kind  # (a Popen's touch may come a moment later)
        assert code == 2, (kind, err)
        one_line_error(err, "--model", str(path), REFUSED, "np.", "people you trust")
        assert not (tmp_path / f"o_{kind}").exists()


def test_the_watcher_refuses_a_crafted_model_at_its_start(saved, building, tmp_path):
    """``watch --model`` reads the model with the same loader, once, at its start."""
    path, mark = _crafted(tmp_path, saved["default"])["trojan"]
    inbox = tmp_path / "inbox"
    inbox.mkdir()
    (inbox / "d.csv").write_bytes((building / "d.csv").read_bytes())
    argv = ["watch", inbox, "--out", tmp_path / "rep", "--once", "--model", path]
    done = subprocess.run(
        [sys.executable, "-m", "analyzer", *map(str, argv)], capture_output=True, text=True
    )
    assert done.returncode == 2, done.stderr
    one_line_error(done.stderr, "--model", REFUSED)
    assert not mark.exists() and not (tmp_path / "rep").exists()


@pytest.mark.parametrize(
    ("module", "name"),
    [
        ("analyzer.detectors.ar_kalman", "np.f2py.subprocess.Popen"),  # a dotted name
        ("analyzer.detectors.ar_kalman", "np.memmap"),
        ("analyzer.modelfile", "io.FileIO"),
        ("analyzer.modelfile", "pickle._Unpickler"),
        ("analyzer.modelfile", "builtins.eval"),
        ("analyzer.diagnosis.changes", "operator.attrgetter"),
        ("analyzer.detectors.ar_kalman", "FittedBank.__init__"),  # an allowed class's
        ("analyzer.typesX", "FaultType"),  # a prefix of an allowed module
        ("analyzer.config", "Config"),  # an analyzer class no model holds
        ("analyzer.detectors.lti", "np"),
        ("builtins", "eval"),
        ("builtins", "getattr"),
        ("numpy", "memmap"),
        ("numpy", "load"),
        ("posix", "system"),
    ],
)
def test_anything_outside_the_table_is_refused_before_it_is_imported(module, name):
    payload = b"\x80\x04" + _s(module) + _s(name) + b"\x93."
    before = set(sys.modules)
    with pytest.raises(pickle.UnpicklingError):
        _Restricted(io.BytesIO(payload)).load()
    assert set(sys.modules) == before


def _build(module: str, name: str, build: bytes) -> bytes:
    """A pickle that names ``module.name`` (allowed) and sets attributes on it (BUILD
    with a slot state): a change the whole process would keep."""
    return b"\x80\x04" + _s(module) + _s(name) + b"\x93" + build + b"b."


def test_a_model_cannot_change_the_analyzers_classes(tmp_path, capsys):
    """A pickle's BUILD sets attributes on whatever it built, an allowed class or enum
    member too: such a file is refused and the class put back as it was (a watcher
    keeps its process for every later archive)."""
    run = ARKalmanBank.run
    slot_state = b"N}%sK\x07s\x86"  # BUILD's (None, {NAME: 7})
    member = _call("analyzer.detectors.network", "Propagation", "direct")
    cases = {
        "class": _build("analyzer.detectors.ar_kalman", "ARKalmanBank", slot_state % _s("run")),
        "new": _build("analyzer.detectors.ar_kalman", "ARKalmanBank", slot_state % _s("extra")),
        "member": b"\x80\x04" + member + b"N}" + _s("_value_") + _s("chained") + b"s\x86b.",
    }
    for kind, payload in cases.items():
        path = tmp_path / f"{kind}.model"
        path.write_bytes(framed(payload))
        code, _, err = run_cli(["run", path, "--out", tmp_path / "o", "--model", path], capsys)
        assert code == 2, (kind, err)
        one_line_error(err, "--model", REFUSED, "put back as it was")
    assert ARKalmanBank.run is run and not hasattr(ARKalmanBank, "extra")
    assert Propagation.DIRECT.value == "direct" and Propagation("direct") is Propagation.DIRECT


def test_what_a_model_is_made_of_goes_through():
    """Arrays of any layout (a strided one is rebuilt by ``_reconstruct``, not from a
    buffer), numpy scalars, complex numbers and the analyzer's enums."""
    arr = np.arange(12.0).reshape(3, 4)
    value = (arr, arr.T, arr[:, ::2], np.float64(2.5), np.int64(3), np.bool_(True),
             1 + 2j, Propagation.CHAINED, {"a": (1.0, None)}, {1, 2}, frozenset({3}))  # fmt: skip
    for protocol in (4, 5):  # (the files are 5's)
        back = _Restricted(io.BytesIO(pickle.dumps(value, protocol=protocol))).load()
        assert all(np.array_equal(a, b) for a, b in zip(back[:3], value[:3], strict=True))
        assert back[3:7] == value[3:7] and back[7] is Propagation.CHAINED
        assert back[8:] == value[8:]
