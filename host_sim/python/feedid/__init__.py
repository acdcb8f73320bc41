"""feedid from Python: identify a feed drive's mass and friction from numpy
arrays or trace files, diagnose the gap, validate and replay a model, with the host
tool's own reader, identify(), diagnose() and validate().

Results are the dicts of the CLI's JSON (``feedid identify --json``), parsed:
the same keys, units in ``result["units"]``. Errors are exceptions carrying
the host's message. docs/python.md has examples; ``feedid.fleet`` runs many
logs on a dask cluster.
"""
import json
import math
import os
import warnings

from . import _feedid

__all__ = ["Error", "NotPhysical", "identify", "identify_files", "diagnose", "diagnose_files", "validate",
           "validate_files", "replay", "replay_file", "monitor", "compensate", "read"]


class Error(ValueError):
    """The host could not identify the trace; ``result`` holds its JSON dict
    (status and error) when it got as far as identify()."""

    def __init__(self, message, result=None):
        super().__init__(message)
        self.result = result


class NotPhysical(Error):
    """The identified model is not physical (a negative mass, Coulomb force
    or viscous coefficient): the CLI's exit 2. ``result`` holds the figures
    with ``physical`` false, for inspection."""


def _failed_on_error(text):
    """The JSON text of a command's to_json as a dict; Error where it carries one."""
    result = json.loads(text)
    if result.get("error"):
        raise Error(result["error"], result)
    return result


def _checked(text):
    """The JSON text of identify's to_json as a dict; raises where the CLI
    exits 2 (an error, or a model that is not physical)."""
    result = _failed_on_error(text)
    if result.get("physical") is False:
        raise NotPhysical(
            "the identified model is not physical: %s. Such a model pushes with the motion, and so would a "
            "compensation from it. Likeliest cause: %s" % (result.get("not_physical"), result.get("not_physical_cause")),
            result)
    return result


def _signals(t, x, u, v):
    if u is None:
        raise TypeError("the drive force u is required")
    return t, x, v, u


def identify(t, x=None, u=None, *, v=None, axis="linear", force_unit=None, **options):
    """Identifies the nine parameters from one recording's signals.

    t: time (s); x: position (m, or rad with axis="rotary"); u: drive force
    (N, N m, or the unit force_unit names, e.g. "V"); v (keyword): velocity
    (m/s or rad/s), optional where x is logged. One-dimensional arrays (or
    sequences) of one length. Rows with NaN/Inf are skipped and counted
    (bad_rows="error" to refuse them), rows repeating the previous exactly
    are left out, and time must increase: the CSV reader's rules.

    options: the CLI's identify options with '_' for '-': method,
    alignment, force_lag_s, velocity_lag_s, velocity_filter, velocity_min,
    velocity_resolution, position_scale, force_scale, time_scale, bad_rows.

    Returns the dict of ``feedid identify --json``; its "warnings" (what
    the CLI prints as WARNING) are Python warnings too. Raises Error with
    the host's message when the trace cannot be identified, NotPhysical
    when the model is not physical, ValueError for bad input, TypeError for
    an unknown option. The GIL is released while the host works.
    """
    options.update(axis=axis, force_unit=force_unit)
    return _identified(_feedid.run_arrays("identify", *_signals(t, x, u, v), options))


def _identified(text_and_warnings):
    """identify's dict (_checked), its warnings given as Python warnings
    first (an implausible magnitude, a lag only the reversals tell)."""
    text, notes = text_and_warnings
    for note in notes:
        warnings.warn(note, stacklevel=3)
    return _checked(text)


def _plain(value, name, key=""):
    """value with numpy scalars and arrays as Python numbers and lists (a
    np.float32 'm' was refused as not JSON serializable); ValueError naming
    the key of a NaN or Inf (json.dumps wrote NaN, which the host's parser
    refused with a column of JSON text)."""
    if isinstance(value, dict):
        return {k: _plain(v, name, "%s.%s" % (key, k) if key else str(k)) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_plain(v, name, "%s[%d]" % (key, i)) for i, v in enumerate(value)]
    if hasattr(value, "tolist") and not isinstance(value, (str, bytes)):
        return _plain(value.tolist(), name, key)
    if isinstance(value, float) and not math.isfinite(value):
        raise ValueError("%s: '%s' must be a finite number, not %r" % (name, key, value))
    return value


def _dumps(value, name):
    """A model or controller dict as the host's JSON text (_plain)."""
    return json.dumps(_plain(value, name), allow_nan=False)


def _json_given(value, name):
    """A model or controller as a dict (the keys of the CLI's JSON file) or
    a path to that file: (its JSON text, the name messages use). A file that
    is not JSON is refused naming it, as the CLI does."""
    if value is None:
        return "", ""
    if isinstance(value, (str, os.PathLike)):
        with open(value) as f:
            text = f.read()
        try:
            json.loads(text)
        except ValueError as e:
            raise ValueError("%s: not valid JSON: %s" % (os.fspath(value), e)) from None
        return text, os.fspath(value)
    return _dumps(value, name), name


def _given(model, controller):
    if model is None:
        if controller is not None:
            raise ValueError("controller needs model (the model to replay), as diagnose --controller needs --model")
        return None
    return _feedid.GivenFiles(*_json_given(model, "model"), *_json_given(controller, "controller"))


def _warned(text_and_warnings):
    """The warnings and notes the CLI prints on stderr, as Python warnings; the result dict."""
    text, notes = text_and_warnings
    for note in notes:
        warnings.warn(note, stacklevel=3)
    return _failed_on_error(text)


def diagnose(t, x=None, u=None, *, v=None, axis="linear", force_unit=None, model=None, controller=None, columns=None,
             **options):
    """``feedid diagnose`` on signals (as identify()'s): the gap between the
    identified model and the trace, and the effect that explains it. options:
    identify's, plus folds and block (s). The dict of ``diagnose --json``;
    Error with the host's message where the CLI exits 2.

    model (``diagnose --model``): a dict with the keys of the CLI's model
    file (identify's dict, or m, pos, neg and offset_N), or a path to one;
    it is the base model, not refitted. controller (``--controller``, needs
    model): replay's controller as a dict or a path; the arrays its
    reference and extra_command name are given in columns (name -> array).
    An unknown key is a Python warning, as the CLI's on stderr."""
    options.update(axis=axis, force_unit=force_unit)
    given = _given(model, controller)
    if given is None:
        return _failed_on_error(_feedid.run_arrays("diagnose", *_signals(t, x, u, v), options)[0])
    return _warned(_feedid.model_gap_arrays(*_signals(t, x, u, v), options, given, columns or {}))


def _model_for_validate(model):
    """validate's model as JSON text; None is a TypeError (it was a JSON parse error)."""
    if model is None:
        raise TypeError("validate needs a model: identify's dict, a truth dict, or a path to its JSON file")
    return _json_given(model, "model")[0]


def _validated(text_and_warnings):
    """validate's dict, with what the CLI prints beside it (an unknown model key, a filter beyond the log's
    reach) as Python warnings."""
    text, notes = text_and_warnings
    for note in notes:
        warnings.warn(note, stacklevel=3)
    return json.loads(text)


def validate(model, t, x=None, u=None, *, v=None, axis="linear", force_unit=None, **options):
    """``feedid validate``: model (identify's dict, or a truth dict, or a path to its JSON file) predicts
    the force of these signals (as identify()'s). options: filter (Hz),
    decimate, drop_first and the input options. The dict of ``validate
    --json``; a model in other units than axis and force_unit give is a
    ValueError."""
    options.update(axis=axis, force_unit=force_unit)
    return _validated(_feedid.run_arrays("validate", *_signals(t, x, u, v), options, _model_for_validate(model)))


def replay(model, controller, t, x, u, *, columns=None, axis="linear", force_unit=None, **options):
    """``feedid replay``: the model simulated inside the drive's own loop
    (controller), driven by the logged reference, and compared with the run
    given as arrays (t in s, x the measured position, u the force, one
    continuous recording with no row left out). model and controller: dicts
    with the keys of the CLI's files, or paths to them. columns: the arrays
    the controller's reference and extra_command name (name -> array).
    options: substeps, filter (Hz), drop_first, fit_gains and the input
    options. The dict of ``replay --json``; the model's and controller's
    warnings are Python warnings, as the CLI's on stderr."""
    if model is None or controller is None:
        raise TypeError("replay needs a model and a controller")
    options.update(axis=axis, force_unit=force_unit)
    return _warned(_feedid.replay_arrays(t, x, u, options, _given(model, controller), columns or {}))


def replay_file(model, controller, path, axis="linear", force_unit=None, **options):
    """replay() on one trace file (CSV or .mat) read by the host reader, the
    controller's columns from it; options as replay()'s plus the column names."""
    if model is None or controller is None:
        raise TypeError("replay needs a model and a controller")
    options.update(axis=axis, force_unit=force_unit)
    return _warned(_feedid.replay_file(os.fspath(path), options, _given(model, controller)))


def _paths(paths):
    return [os.fspath(paths)] if isinstance(paths, (str, os.PathLike)) else [os.fspath(p) for p in paths]


def identify_files(paths, axis="linear", force_unit=None, **options):
    """identify() on a trace file (CSV or .mat) read by the host reader, or a
    list of files pooled as runs (``feedid identify --in a --in b``).

    options: as identify()'s, plus the column (or .mat variable) names time,
    position, velocity and force (default t, x, v, u).
    """
    options.update(axis=axis, force_unit=force_unit)
    return _identified(_feedid.run_files("identify", _paths(paths), options))


def diagnose_files(paths, axis="linear", force_unit=None, model=None, controller=None, **options):
    """diagnose() on trace files (as identify_files()); model and controller
    as diagnose()'s, the controller's columns read from the one file."""
    options.update(axis=axis, force_unit=force_unit)
    given = _given(model, controller)
    if given is None:
        return _failed_on_error(_feedid.run_files("diagnose", _paths(paths), options)[0])
    return _warned(_feedid.model_gap_files(_paths(paths), options, given))


def validate_files(model, paths, axis="linear", force_unit=None, **options):
    """validate() on trace files (as identify_files())."""
    options.update(axis=axis, force_unit=force_unit)
    return _validated(_feedid.run_files("validate", _paths(paths), options, _model_for_validate(model)))


def monitor(path, axis="linear", force_unit=None, **options):
    """``feedid monitor`` on one log (a CSV read row by row in constant
    memory, a .mat or .wpilog read whole and handed on row by row):
    each epoch's parameters and the change alarms. options: epoch_s,
    reference_epochs, threshold and the input options. The dict of
    ``monitor --json``; Error (with the epochs so far in ``result``) where
    reading stopped."""
    options.update(axis=axis, force_unit=force_unit)
    return _failed_on_error(_feedid.monitor_file(os.fspath(path), options))


def compensate(model, points=20, max_speed=0.0, force_scale=1.0, force_unit=None, format="json"):
    """``feedid compensate``: the speed -> friction table per direction a
    drive can load, from identify's dict (or a path to its JSON file). max_speed 0: the model's
    config.velocity_max_m_s. The table's dict (``--format json``), or its
    CSV text with format="csv". A model that cannot be compensated with
    (not ok, not physical) is a ValueError with the CLI's message; what
    the CLI warns of (a flagged model, the table's range) is a Python warning."""
    text, notes = _feedid.compensate(_json_given(model, "model")[0], dict(points=points, max_speed=max_speed, force_scale=force_scale,
                                                            force_unit=force_unit, format=format))
    for note in notes:
        warnings.warn(note, stacklevel=2)
    return text if format == "csv" else json.loads(text)


def read(path, **columns):
    """A trace file's signals (CSV, .mat or .wpilog) through the host reader, as numpy arrays:
    a dict with t, x, v, u (SI after position_scale, force_scale and
    time_scale; x or v None when not logged) and rows_skipped,
    rows_repeated, skipped_rows. columns: time, position, velocity, force
    (names), the scales and bad_rows."""
    return _feedid.read(os.fspath(path), columns)
