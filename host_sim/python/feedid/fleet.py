"""A fleet's logs on dask.distributed: one task per log, one row per log
(identify_many, monitor_many).

Each task runs on a worker, reads its file(s) with the host reader and
identifies them there (feedid must be importable on the workers). A log
that fails gives a row with its ``error``; it never stops the others.
"""
import os
import time

import feedid

# The estimates each row carries, as the JSON's keys: m, and per direction
# the Stribeck law's four terms, each with its standard error.
_DIRECTION_TERMS = ("sigma", "fc", "fs", "vs")


def _log_name(paths):
    if not isinstance(paths, list):  # an item that named no path, refused in its own row
        return repr(paths)
    return paths[0] if len(paths) == 1 else " + ".join(paths)


def row(paths, result, error=""):
    """One log's row: path, status, the estimates with standard errors and
    identifiability flags, the symmetric model where the directions agree,
    and the error (empty when none)."""
    r = {"path": _log_name(paths), "status": result.get("status", "error") if result else "error"}
    r["m"] = result.get("m") if result else None
    r["m_se"] = result.get("m_se") if result else None
    r["m_identifiable"] = result.get("m_identifiable") if result else None
    for d in ("pos", "neg"):
        de = result.get(d, {}) if result else {}
        for p in _DIRECTION_TERMS:
            r["%s_%s" % (d, p)] = de.get(p)
            r["%s_%s_se" % (d, p)] = de.get(p + "_se")
            r["%s_%s_identifiable" % (d, p)] = de.get("identifiable", {}).get(p)
        r["%s_flags" % d] = " ".join(de.get("flags", []))
    sym = ((result or {}).get("model") or {}).get("friction", {}).get("symmetric") or {}
    for p in ("sigma", "fc"):
        r["symmetric_" + p] = sym.get(p)
        r["symmetric_%s_se" % p] = sym.get(p + "_se")
    r["physical"] = result.get("physical") if result else None
    r["units"] = result.get("units") if result else None
    r["error"] = error
    return r


def identify_log(paths, options):
    """The task: one log (a list of files pooled as runs) identified on the
    worker that runs it; its row, with the error where it failed."""
    try:
        return row(paths, feedid.identify_files(paths, **options))
    except ValueError as e:  # feedid.Error (with its result) or the reader's message
        return row(paths, getattr(e, "result", None), str(e))
    except Exception as e:  # a bad log is a row, never the end of the fleet
        return row(paths, None, "%s: %s" % (type(e).__name__, e))


def monitor_row(path, result, error=""):
    """One log's health row: path, epochs, epochs identified, alarms, the
    first alarm's parameter, direction and time, and the error."""
    epochs = (result or {}).get("epochs", [])
    alarms = (result or {}).get("alarms", [])
    first = alarms[0] if alarms else {}
    return {"path": path, "epochs": len(epochs), "epochs_identified": sum(1 for e in epochs if not e.get("error")),
            "alarms": len(alarms), "first_alarm_parameter": first.get("parameter"),
            "first_alarm_direction": first.get("direction"), "first_alarm_t_s": first.get("t_s"),
            "first_alarm_change_pct": first.get("change_pct"), "units": (result or {}).get("units"), "error": error}


def monitor_log(path, options):
    """The task: one log's friction health on the worker that runs it."""
    try:
        return monitor_row(path, feedid.monitor(path, **options))
    except ValueError as e:
        return monitor_row(path, getattr(e, "result", None), str(e))
    except Exception as e:  # a bad log is a row, never the end of the fleet
        return monitor_row(path, None, "%s: %s" % (type(e).__name__, e))


def _logs(paths_or_groups):
    """The logs given: one path (a str or os.PathLike) is one log, not a list of its characters."""
    if isinstance(paths_or_groups, (str, bytes, os.PathLike)):
        return [paths_or_groups]
    return list(paths_or_groups)


def _group(g):
    """One log's paths; an item that names no path (None, a number) is left for its task to refuse as its own row."""
    try:
        return feedid._paths(g)
    except TypeError:
        return g


def _groups(paths_or_groups):
    """Each item is a log: a path, or a list of paths pooled as runs."""
    return [_group(g) for g in _logs(paths_or_groups)]


def identify_many(paths_or_groups, client=None, **options):
    """Identifies every log as its own dask task and returns a pandas
    DataFrame with one row per log, in the order given.

    paths_or_groups: paths, or lists of paths each pooled as one log
    (``feedid identify --in a --in b``). client: a dask.distributed Client,
    a scheduler address ("tcp://host:8786"), or None for a LocalCluster
    started for the call and closed after it. options: those of
    feedid.identify_files (axis, force_unit, columns, ...), the same for
    every log.

    Columns: path, status, m, m_se, pos_/neg_ sigma, fc, fs, vs each with
    _se and _identifiable, pos_flags, neg_flags, symmetric_sigma/_fc (when
    the directions agree), physical, units (the JSON's units dict), error.
    """
    return _on_cluster(identify_log, _groups(paths_or_groups), client, options)


def monitor_many(paths, client=None, **options):
    """feedid.monitor on every log (one file each) as its own dask task; a
    pandas DataFrame, one row per log in the order given: path, epochs,
    epochs_identified, alarms, first_alarm_parameter, _direction, _t_s,
    _change_pct, units, error. client and options as identify_many's
    (epoch_s, reference_epochs, threshold and the input options)."""
    return _on_cluster(monitor_log, [feedid._paths(p)[0] for p in _logs(paths)], client, options)


def _on_cluster(task, logs, client, options):
    """task(log, options) for every log, one dask task each, on client (a
    Client, a scheduler address, or None: a LocalCluster for the call); the
    rows as a DataFrame in the order given."""
    import pandas
    from dask.distributed import Client, LocalCluster

    own = None
    if client is None:
        own = Client(LocalCluster())
        client = own
    elif isinstance(client, str):
        own = Client(client)
        client = own
    try:
        rows = client.gather(client.map(task, logs, options=options, pure=False))
    finally:
        if own is not None:
            cluster = own.cluster
            own.close()
            if cluster is not None:
                cluster.close()
    return pandas.DataFrame(rows)


def report(frame, directory, command="feedid.fleet.report"):
    """Writes ``report.html`` into directory (created if missing): every
    axis's parameters side by side, from identify_many's DataFrame. A table
    (m and each direction's sigma, fc, fs, vs with their standard errors,
    status and error per log) and one figure per parameter with every
    axis's estimate and its +-1 standard error, drawn by the host's report
    code (the HTML and SVG of ``feedid diagnose --report``). command: the
    text shown as what made the page. Returns the page's path."""
    directory = os.fspath(directory)
    feedid._feedid.fleet_report(frame.to_json(orient="records", double_precision=15), directory, command)
    return os.path.join(directory, "report.html")


def logs_per_second(paths_or_groups, workers=(1, 2), repeat=1, rounds=3, **options):
    """Fleet throughput: for each worker count, a LocalCluster of that many
    single-threaded worker processes runs identify_many over the logs
    (repeat times the list), after feedid is imported on every worker;
    logs per second of wall time. The counts take turns over `rounds`
    rounds, so that load from elsewhere falls on each alike; the median
    round per count. A dict {workers: logs/s}."""
    from dask.distributed import Client, LocalCluster

    groups = _groups(paths_or_groups) * repeat
    runs = {n: [] for n in workers}
    for _ in range(rounds):
        for n in workers:
            with LocalCluster(n_workers=n, threads_per_worker=1, processes=True, dashboard_address=None) as cluster, \
                    Client(cluster) as client:
                client.run(lambda: __import__("feedid"))  # imports on every worker before the clock starts
                start = time.perf_counter()
                frame = identify_many(groups, client=client, **options)
                runs[n].append(len(frame) / (time.perf_counter() - start))
    return {n: sorted(r)[len(r) // 2] for n, r in runs.items()}
