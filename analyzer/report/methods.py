"""What each detector and test does, in a few sentences, with its seed reference: the
"Method" section of the report. Prose only; the numbers used (thresholds, windows,
false-alarm rate) are added from the analysis by :mod:`analyzer.report.view`."""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True, slots=True)
class Method:
    name: str
    title: str
    reference: str
    summary: str


DETECTORS: dict[str, Method] = {
    "ar_kalman_bank": Method(
        "ar_kalman_bank",
        "Bank of Kalman estimators on an autoregressive model",
        "Chang, Chou, Tan & Wang (2017), A sensor fault detection strategy for structural "
        "health monitoring systems, Smart Structures and Systems.",
        "A multichannel autoregressive (AR) model of all sensors is fitted to the healthy "
        "training window (order by BIC) and put in state-space form. Estimator j of the bank "
        "uses every sensor except sensor j and predicts sensor j from the others. A faulty "
        "sensor j leaves its own estimator consistent while every estimator that uses it "
        "degrades; the residual (measured minus estimated) of sensor j then carries the "
        "fault's shape: a step (offset), a scaled copy of the signal (gain) or a ramp (drift).",
    ),
    "error_function": Method(
        "error_function",
        "Decoupled sensor error functions",
        "Li, Koh & Nagarajaiah (2007), Detecting sensor failure via decoupled error function "
        "and inverse input-output model, Journal of Engineering Mechanics 133(11).",
        "Sensors are split into trusted reference sensors and uncertain sensors. For each "
        "uncertain sensor a linear combination of a window of samples of the reference "
        "sensors and of that sensor is found (from the healthy data, Eq. 26-29, or from a "
        "state-space model) that is zero while the sensor reads the structure correctly, "
        "whatever the other uncertain sensors read. A failure of that sensor, and only of it, "
        "makes its error function depart from zero.",
    ),
    "detection_filter": Method(
        "detection_filter",
        "Beard-Jones detection filter with sensor-fault states",
        "Park, Rizzoni & Ribbens (1994), On the representation of sensor faults in fault "
        "detection filters, Automatica 30(11).",
        "Each sensor's fault is added to the model as an extra state, which turns the sensor "
        "fault into an actuator-like fault. The filter gain is chosen so that a fault of sensor "
        "i keeps the output residual in a fixed direction (that sensor's own axis); one filter "
        "per sensor forms a bank, and the sensor whose filter stays on its direction while "
        "the others leave theirs is the faulty one. The only condition is observability of "
        "the model (identified from the healthy window when no model is given).",
    ),
    "equivalent_model": Method(
        "equivalent_model",
        "Equivalent-model observers with an assistant state",
        "Wang & Song (2014), Robust model-based sensor fault monitoring system for nonlinear "
        "systems in sensor networks, Sensors 14.",
        "Each sensor is described by a one-dimensional linear equation whose uncertainty "
        "absorbs everything else; an assistant state computed from neighbouring sensors "
        "(a relation identified on the healthy window) lets an observer cancel that "
        "uncertainty exactly, so its residual responds only to the sensor's own fault "
        "(Eq. 30-32) and regenerates the fault signal (Section 6.3). The sensor network's "
        "diagnosis laws (Section 6.2) tell a faulty sensor from one that only sees a faulty "
        "neighbour.",
    ),
}

CHECKS: dict[str, Method] = {
    "constant_check": Method(
        "constant_check",
        "A sensor that reads one value",
        "",
        "A channel the user named (with --channels, as a sensor of the config's groups or "
        "model, or as a channel of a saved model given with --model) that reads one value "
        "on every one of at least 100 samples, while the other channels vary, is reported "
        "as a fault of its own, from the record's start (it may have read so before the "
        "record began) to its end. It has nothing for a model to fit, so no detector "
        "analyzes it; only a saved model's detectors still read it, as the model needs "
        "each of its channels, and what they found on it is part of this one finding. "
        "At 0 it is a dead sensor (a gain of 0), at another value a sensor stuck there; "
        "either way it may also be a signal below the sensor's resolution. It needs no "
        "healthy window: where the detectors could not run (a record too short for them), "
        "its findings are reported alone, and nothing else was searched for. A run that "
        "names no channel (no --channels, config groups or model) leaves constant channels "
        "out and only warns of one named like analyzed channels; a channel that a "
        "--channels pattern such as '/imu.*' matches, and that no other channel is named "
        "like, is left out with a warning (nothing tells a dead sensor from a quantity "
        "nothing changed, a planar robot's height).",
    ),
    "silent_check": Method(
        "silent_check",
        "A sensor that goes silent",
        "",
        "A channel that has readings and then, to the end of the record, none, while the "
        "other channels go on, is reported as a fault from its first missing sample, when "
        "the file marks the silence: blank (or nan) cells on rows whose other columns have "
        "data, or a topic that goes on publishing NaN. It needs at least 100 samples and "
        "three of the detectors' long alarm windows of silence. A topic whose messages "
        "simply stop is not reported: a recorder or a node stopped, not necessarily the "
        "sensor; a note says the channel has no reading there. The fault's size is the "
        "time without a reading (no_data_s).",
    ),
}
"""Checks that are not detectors, described where they reported something (a report
lists every detector, run or not; a check only when it ran)."""

TESTS = Method(
    "tests",
    "Innovation tests of the standardized residual",
    "Innovation sequence tests (IST): model-based sensor validation for structural health "
    "monitoring with Kalman innovation tests (Advanced Control Systems 2012/2013).",
    "Under healthy operation a correct model's standardized residual is zero-mean, of unit "
    "variance, Gaussian and white. Each property is tested at the 5 % level on the stretch "
    "before the onset and on the stretch after it: Shewhart chart (fraction of samples "
    "beyond ±3), Anderson-Darling and Cramér-von Mises (normality, Stephens' modified "
    "statistics), Ljung-Box Q over 20 lags (N/20 on a stretch of fewer than 400 "
    "samples, where Q's chi-square law needs it) with the ±1.96/√N autocorrelation band "
    "(whiteness), and tests of zero mean and unit covariance. Which properties break speaks "
    "for the fault type: the mean for an offset or a drift, the covariance without the mean "
    "for a gain change, whiteness for a slow trend. The residuals of leave-one-out estimators "
    "are coloured even when healthy, so whiteness may reject on both sides: what changes "
    "across the onset is what counts.",
)

DECISION = (
    "Each residual is standardized with its training mean and standard deviation. Two "
    "trailing-window statistics are watched: the window mean (an offset or a drift moves "
    "it) and the log of the window mean square (a gain change or an erratic sensor raises "
    "it), each over a short window (times abrupt faults) and a window eight times longer "
    "(sees small sustained changes). Their healthy spread is measured on the training "
    "window, and each threshold sits where a Gaussian tail with that spread has the "
    "false-alarm probability per sample, shared among the channels and window lengths "
    "(Bonferroni). Onset and end are then placed by the maximum-likelihood change point "
    "(Gaussian GLR) around the first and last alarm, and the type by comparing offset, "
    "gain and drift fits of the residual (BIC)."
)

__all__ = ["DECISION", "DETECTORS", "TESTS", "Method"]
