"""The tables of the report's view: the archive's inputs and channels, each detector's
model (parameters, per-channel columns, training and windowed tests), the methods and the
thresholds, and the formatting of innovation-test results shared with each finding's
test table.

:class:`TableParts` is the table-building part of the view's access object
(:class:`analyzer.report.view._Access` inherits it). It is apart from the verdict and the
findings because it reads the archive and the fitted models rather than the faults found,
and most of its rows come from ``findings.json``'s nested model summaries, which the
helpers here flatten into columns.
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import TYPE_CHECKING, Any

from analyzer.errors import counted
from analyzer.readers import renamed_words
from analyzer.report import format as fmt
from analyzer.report.methods import CHECKS, DETECTORS, Method
from analyzer.report.view_records import (
    ChannelTable,
    ChannelView,
    Fact,
    InputView,
    MethodView,
    ModelView,
    TestCell,
)
from analyzer.types import NS_PER_S

MAX_MODEL_COLUMNS = 8
"""Per-channel model columns shown per detector (the rest is in findings.json)."""

TEST_LABELS: dict[str, tuple[str, str]] = {
    "shewhart": ("Shewhart chart", "fraction of |z| > 3 vs. expected"),
    "anderson_darling": ("Anderson-Darling", "A²* (normality)"),
    "cramer_von_mises": ("Cramér-von Mises", "W²* (normality)"),
    "whiteness": ("Whiteness", "Ljung-Box Q, 20 lags (N/20 if fewer)"),
    "mean": ("Zero mean", "max |√N · mean|"),
    "covariance": ("Unit covariance", "N · variance, two-sided"),
}

FINDING_TEST_LABELS: dict[str, tuple[str, str]] = {
    **{k: v for k, v in TEST_LABELS.items() if k != "covariance"},
    "mean_long_run": (
        "Zero mean, long-run",
        "|t|: mean over its long-run deviation (Newey-West, whiteness's lags)",
    ),
    "covariance": TEST_LABELS["covariance"],
}
"""A finding's innovation-test table: the training tests' rows, with the long-run mean
test (findings.json's ``mean_long_run``) beside the plain one: where whiteness is
rejected the type vote reads it (:func:`analyzer.diagnosis.evidence.mean_test_read`)."""

MEAN_READ: dict[str, str] = {
    "mean_long_run": (
        "The type vote read the long-run zero-mean test: after the onset the residual is "
        "not white (whiteness rejected), and the plain zero-mean test assumes white samples, "
        "so the mean is held against the larger spread its correlation gives it."
    ),
    "mean": (
        "The type vote read the plain zero-mean test: after the onset the residual is white "
        "enough (whiteness not rejected); the long-run test is shown for comparison."
    ),
}
"""Which mean test the type vote read, in plain words (under a finding's test table)."""


class TableParts:
    """The tables of a view (see the module doc), a base of
    :class:`analyzer.report.view._Access`, whose ``__init__`` sets the state declared
    here."""

    an: Any
    doc: Mapping[str, Any]
    rate: float
    when: fmt.Clock
    analyzed: tuple[str, ...]
    results: dict[Any, Any]

    if TYPE_CHECKING:  # in analyzer.report.view._Access

        def far_text(self) -> str: ...

    # -- archive overview -------------------------------------------------------------------
    def inputs(self) -> list[InputView]:
        infos = list(getattr(self.an, "inputs", []) or [])
        out = []
        for i, d in enumerate(self.doc.get("inputs", [])):
            size = getattr(infos[i], "size_bytes", 0) if i < len(infos) else 0
            if not size:
                size = _disk_size(Path(str(d.get("path", ""))))
            out.append(
                InputView(
                    str(d.get("path")),
                    str(d.get("format")),
                    fmt.size(size),
                    str(d.get("sha256") or fmt.MISSING),
                    [str(e) for e in d.get("errors", [])],
                )
            )
        return out

    def _start_ns(self) -> int:
        return int(getattr(self.an, "start_ns", 0) or 0)

    def channels(self) -> list[ChannelView]:
        start = self._start_ns()
        out = []
        for c in getattr(self.an, "channels", []) or []:
            out.append(
                ChannelView(
                    name=c.name,
                    analyzed=c.name in self.analyzed,
                    samples=f"{c.samples:,}",
                    rate=fmt.rate(c.rate_hz),
                    start_s=self.when((c.start_ns - start) / NS_PER_S),
                    end_s=self.when((c.end_ns - start) / NS_PER_S),
                    gaps=str(c.gaps),
                    range=fmt.num_range(c.minimum, c.maximum),
                    renamed=self._renamed(c.name),
                )
            )
        listed = {v.name for v in out}
        for name, what in (getattr(self.an, "no_reading", {}) or {}).items():
            # (a column with no reading at all: no sample, said for what it is; a saved
            # model's such channel too, analyzed: its finding says it is dead)
            if name not in listed:
                out.append(
                    ChannelView(
                        name=name,
                        analyzed=name in self.analyzed,
                        samples="0",
                        rate=fmt.MISSING,
                        start_s=fmt.MISSING,
                        end_s=fmt.MISSING,
                        gaps=fmt.MISSING,
                        range=f"no reading: {what}",
                        renamed=self._renamed(name),
                    )
                )
        return out

    def _renamed(self, name: str) -> str:
        """Channel ``name``'s :attr:`ChannelView.renamed`: the names ``--rename`` read as
        it and the inputs that held them (:attr:`analyzer.findings.Analysis.renamed`)."""
        renamed = (getattr(self.an, "renamed", {}) or {}).get(name)
        return renamed_words(renamed) if renamed else ""

    # -- models and method ---------------------------------------------------------------------
    def model_view(self, d: Mapping[str, Any]) -> ModelView:
        name = str(d.get("name"))
        model = dict(d.get("model") or {})
        chans = [str(c) for c in d.get("channels", [])]
        params = [
            Fact(k, fmt.scalar(v))
            for k, v in (d.get("params") or {}).items()
            if fmt.is_scalar(v) or fmt.is_short_list(v)
        ]
        summary = [
            Fact(k.replace("_", " "), fmt.scalar(v))
            for k, v in model.items()
            if k not in ("training_tests", "windowed_tests", "channels", "outputs")
            and (fmt.is_scalar(v) or fmt.is_short_list(v))
        ]
        per_channel_cols = _per_channel_columns(
            {k: v for k, v in model.items() if k not in ("training_tests", "windowed_tests")},
            set(chans),
        )
        cols = list(per_channel_cols)[:MAX_MODEL_COLUMNS]
        result = self.results.get(name)
        header = [
            "channel",
            "residual σ (training)",
            "window (samples)",
            "mean threshold (σ units)",
            "false-alarm rate",
            *[c.replace("_", " ") for c in cols],
        ]
        rows = []
        for ch in chans:
            th = result.thresholds.get(ch) if result is not None else None
            th = th if isinstance(th, dict) else {}
            sigma = result.sigma.get(ch) if result is not None else None
            rows.append(
                [
                    ch,
                    fmt.num(th.get("std", sigma)),
                    " / ".join(str(w) for w in th.get("windows", [])) or fmt.MISSING,
                    " / ".join(fmt.num(x, 3) for x in th.get("mean_threshold", [])) or fmt.MISSING,
                    fmt.num(th.get("false_alarm_rate"), 3),
                    *[per_channel_cols[c].get(ch, "") for c in cols],
                ]
            )
        tt = model.get("training_tests") or {}
        t_header = ["channel", *[TEST_LABELS[k][0] for k in TEST_LABELS]]
        t_rows, rejects = [], 0
        for ch, tests in tt.items():
            cells = [str(ch)]
            for k in TEST_LABELS:
                c = _cell(tests.get(k), k)
                rejects += bool(c.reject)
                cells.append(_compact(c, tests.get(k)))
            t_rows.append(cells)
        total = len(tt) * len(TEST_LABELS)
        windowed, windowed_note = self._windowed(model.get("windowed_tests") or {})
        return ModelView(
            detector=name,
            channels=f"{len(chans)}: {', '.join(chans[:16])}" + (" ..." if len(chans) > 16 else ""),
            params=params,
            summary=summary,
            per_channel=ChannelTable(header, rows),
            training_tests=ChannelTable(t_header, t_rows),
            training_rejects=f"{rejects} of {total} tests reject on the training window"
            if total
            else "",
            windowed=windowed,
            windowed_note=windowed_note,
            notes=[str(n) for n in d.get("notes", [])],
        )

    def _windowed(self, wt: Mapping[str, Any]) -> tuple[ChannelTable, str]:
        """The windowed tests over the whole record (``model["windowed_tests"]``): per
        channel and test, the share of windows that reject, beside the share of the
        training window's windows (``training``, the healthy reference) where the run
        measured one."""
        header = ["channel", *[TEST_LABELS[k][0] for k in TEST_LABELS]]
        rows, layout, whitened = [], None, False
        pairs: list[tuple[str, str, Mapping[str, Any]]] = []  # (channel, test, its dict)
        for ch, tests in wt.items():
            if not isinstance(tests, Mapping):
                continue
            layout = layout or tests.get("windows")
            shape = tests.get("windows")
            whitened = whitened or (isinstance(shape, Mapping) and "whitening_order" in shape)
            cells = [str(ch)]
            for k in TEST_LABELS:
                t = tests.get(k) or {}
                cells.append(_windowed_cell(t))
                if t.get("windows"):
                    pairs.append((str(ch), k, t))
            rows.append(cells)
        note = ""
        if isinstance(layout, Mapping) and layout.get("window"):
            w = int(layout["window"])
            note = (
                f"Consecutive windows of {w} samples ({fmt.seconds(w / self.rate, 2)}), "
                f"{layout.get('valid', layout.get('count'))} per channel, over the whole record "
                "(faulty stretches included), "
                + (
                    "on the residual whitened by its AR model of the training window, as "
                    "around each finding's onset. "
                    if whitened
                    else "on the residual as it is (no training window of the record's own "
                    "to whiten it by). "
                )
                + self._reference_note(layout, pairs, whitened)
            )
        return ChannelTable(header, rows), note

    def _reference_note(
        self,
        layout: Mapping[str, Any],
        pairs: list[tuple[str, str, Mapping[str, Any]]],
        whitened: bool,
    ) -> str:
        """What each share is to be compared with: the share of the training window's
        windows the same test rejected (measured, :func:`analyzer.stats.summarize`'s
        ``training_fraction``), with the channel and test whose healthy share is the largest as
        the example; or why there is no such reference. A real residual is rarely white
        or normal even when healthy (the SKAB pump's healthy channels rejected in 70-90 %
        of their windows), so the nominal 5 % is no reference for it."""
        span = layout.get("training_span")
        measured = [(ch, k, t) for ch, k, t in pairs if t.get("training_windows")]
        if not isinstance(span, list | tuple) or len(span) != 2:
            return (
                "Each cell: the share of the record's windows the test rejected at 5 % "
                "(rejecting / windows). No healthy reference to compare them with: "
                + (
                    "this run has no training window of the record's own (it reused a "
                    "model file), so no healthy residual's windows were tested. "
                    if not whitened
                    else "findings.json does not carry the training window's shares (an "
                    "older analyzer wrote it). "
                )
                + "The 5 % of the tests' level holds only for a white, normal residual, "
                "which a real one rarely is even when healthy: read the shares across "
                "channels and detectors rather than against 5 %."
            )
        lo, hi = (float(x) / self.rate for x in span)
        where = f"the training window's windows from {fmt.seconds(lo, 2)} to {fmt.seconds(hi, 2)}"
        if not measured:
            return (
                "Each cell: the share of the record's windows the test rejected at 5 % "
                f"(rejecting / windows). No healthy reference: {where} hold no whole window of "
                f"{layout.get('window')} samples, so none was tested; the 5 % of the tests' "
                "level holds only for a white, normal residual."
            )
        ch, k, t = max(measured, key=lambda x: float(x[2].get("training_fraction") or 0.0))
        return (
            "Each cell: the share of the record's windows the test rejected at 5 % "
            "(rejecting / windows), then, after “training”, the share of "
            f"{where} (after its first quarter, where the filters have settled; healthy "
            f"by assumption, {t.get('training_windows')} windows per channel) that the same test "
            "rejected. That measured share, not 5 %, is the reference: a real residual "
            "is rarely white or normal even when healthy, and then rejects in many "
            f"windows without a fault (on the healthy training window, "
            f"{TEST_LABELS[k][0]} on {ch} rejected {fmt.percent(t.get('training_fraction'))} "
            f"of windows; over the record {fmt.percent(t.get('fraction'))}). A share well "
            "above its training share is a change; one near it is as healthy as training."
        )

    def methods(self) -> list[MethodView]:
        ran = {str(r["name"]): r for r in self.doc.get("detectors", [])}
        skipped = self.doc.get("skipped_detectors") or {}
        out = []
        for name, m in DETECTORS.items():
            if name in ran:
                status = f"ran on {counted(len(ran[name].get('channels', [])), 'channel')}"
            elif name in skipped:
                status = f"skipped: {skipped[name]}"
            else:
                status = "not run"
            out.append(MethodView(m, status, name in ran))
        for name in ran:
            if name not in DETECTORS:
                m = CHECKS.get(name, Method(name, name, "", ""))
                status = f"reported {counted(len(ran[name].get('channels', [])), 'channel')}"
                out.append(MethodView(m, status, True))
        return out

    def threshold_facts(self) -> list[Fact]:
        facts = [Fact("False-alarm rate", self.far_text())]
        windows = set()
        for r in self.results.values():
            for th in r.thresholds.values():
                if isinstance(th, dict) and th.get("windows"):
                    windows.add(tuple(int(w) for w in th["windows"]))
        for w in sorted(windows):
            secs = " / ".join(fmt.seconds(x / self.rate, 2) for x in w)
            facts.append(Fact("Windows", f"{' / '.join(map(str, w))} samples ({secs})"))
        facts.append(Fact("Test level", "5 % per innovation test"))
        return facts


# -- helpers ------------------------------------------------------------------------------


def _windowed_cell(t: Mapping[str, Any]) -> str:
    """``78.0 % (39/50); training 77.0 % (10/13)``: the share of the record's windows one
    test rejected, then the share of the training window's (the healthy reference)
    where it was measured."""
    if not t.get("windows"):
        return fmt.MISSING
    cell = f"{fmt.percent(t.get('fraction'))} ({t.get('rejected')}/{t.get('windows')})"
    if t.get("training_windows"):
        cell += (
            f"; training {fmt.percent(t.get('training_fraction'))} "
            f"({t.get('training_rejected')}/{t.get('training_windows')})"
        )
    return cell


def _cell(t: Mapping[str, Any] | None, test: str = "") -> TestCell:
    """One test result as display strings. The Shewhart chart's ``critical`` is the
    fraction expected beyond the limits (the decision is a binomial test of the count),
    so it is labelled as such; it and the normality tests (decided by their tabulated
    points) carry their p-value where known."""
    if not t:
        return TestCell(fmt.MISSING, fmt.MISSING, None)
    crit = fmt.num(t.get("critical"), 4)
    if test == "shewhart":
        crit = f"exp. {crit}"
    if test in ("shewhart", "anderson_darling", "cramer_von_mises") and t.get("pvalue") is not None:
        crit += f", p {fmt.num(t['pvalue'], 2)}"
    if t.get("critical_low") is not None:
        crit = f"{fmt.num(t['critical_low'], 4)} to {crit}"
    reject = t.get("reject")
    return TestCell(fmt.num(t.get("statistic"), 4), crit, None if reject is None else bool(reject))


def _compact(c: TestCell, t: Mapping[str, Any] | None) -> str:
    """``statistic / critical mark`` for the training-test table; a two-sided test that
    rejects below its upper critical value rejected on the low side and says so."""
    if c.reject is None:
        return fmt.MISSING
    low = ""
    try:
        if c.reject and t and float(t["statistic"]) < float(t["critical"]):
            low = " (low)"
    except (KeyError, TypeError, ValueError):
        pass
    return f"{c.statistic} / {c.critical} {'✗' if c.reject else '✓'}{low}"


def _per_channel_columns(
    tree: Mapping[str, Any], chans: set[str], depth: int = 3, path: str = ""
) -> dict[str, dict[str, str]]:
    """Per-channel columns of a model summary: wherever a dict is keyed by channel names,
    its scalar (or short-list) leaves, up to two levels below the channel, become columns
    named by their path (``r_squared``, ``filters: spectral radius``...). Columns whose
    value is the same on every channel say nothing per channel and are dropped."""
    cols: dict[str, dict[str, str]] = {}
    keys = set(tree)
    if keys and keys <= chans:
        for ch, v in tree.items():
            for name, val in _leaves(v, 2):
                col = ": ".join(p for p in (path, name) if p) or "value"
                cols.setdefault(col.replace("_", " "), {})[ch] = val
    elif depth > 0:
        for k, v in tree.items():
            if isinstance(v, Mapping):
                sub = _per_channel_columns(
                    v, chans, depth - 1, ": ".join(p for p in (path, k) if p)
                )
                cols.update(sub)
    return {k: v for k, v in cols.items() if len(set(v.values())) > 1 or len(chans) == 1}


def _leaves(v: Any, depth: int, path: str = "") -> list[tuple[str, str]]:
    if fmt.is_scalar(v) or fmt.is_short_list(v):
        return [(path, fmt.scalar(v))]
    if isinstance(v, Mapping) and depth > 0:
        out = []
        for k, x in v.items():
            out += _leaves(x, depth - 1, " ".join(p for p in (path, str(k)) if p))
        return out
    return []


def _disk_size(p: Path) -> int | None:
    try:
        if p.is_dir():
            return sum(q.stat().st_size for q in p.rglob("*") if q.is_file())
        return p.stat().st_size
    except OSError:
        return None


__all__ = ["MAX_MODEL_COLUMNS", "TEST_LABELS", "TableParts"]
