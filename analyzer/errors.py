"""One exception tree for the whole tool.

Every error a user can cause derives from :class:`AnalyzerError`; the CLI catches it,
prints its message on one line and exits with code 2. Messages quote the bad value and
say what was expected.
"""

from __future__ import annotations


def one_line(err: BaseException | str) -> str:
    """An exception (or text) as a single line, for ``InputInfo.errors`` and messages."""
    text = str(err).strip() or type(err).__name__
    return " ".join(text.split())


class AnalyzerError(Exception):
    """Root of every error the analyzer raises on purpose."""


class UsageError(AnalyzerError):
    """A command-line option or argument is wrong."""


class ConfigError(AnalyzerError):
    """The TOML config file is unreadable, has an unknown key or a bad value."""


class ReaderError(AnalyzerError):
    """An input file is missing, of unknown format, truncated or corrupt."""


class StoreError(AnalyzerError):
    """The channel store cannot serve what was asked (unknown channel, empty range...)."""


class DetectorError(AnalyzerError):
    """A detector cannot be fitted or run (too little healthy data, singular model...)."""
