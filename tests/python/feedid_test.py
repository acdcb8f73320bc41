"""The Python module against the CLI (ctest: python.feedid; docs/python.md).

feedid.identify on the EMPS arrays must give the CLI's estimates on the same
file, and feedid.fleet.identify_many on SysId logs, on a 2-worker dask
LocalCluster, one row per log with the CLI's viscous terms. Exit 77 (ctest:
skipped) where the module was not built or numpy is missing.
"""
import json
import os
import subprocess
import sys
import tempfile
import unittest

try:
    import numpy as np
    import feedid
except ImportError as e:
    print("skipped: %s (the module is built where python3-dev and pybind11-dev are found)" % e)
    sys.exit(77)

BIN = os.environ.get("FEEDID_BIN_DIR", "build/bin")
SHARED = os.environ.get("FEEDID_SHARED_DIR", "../shared")
EMPS = os.path.join(SHARED, "data", "emps", "DATA_EMPS.csv")
SYSID = os.path.join(SHARED, "data", "sysid_team581")
CONTROLLER = os.path.join(os.environ.get("FEEDID_SOURCE_DIR", "."), "docs", "examples", "emps_controller.json")
PARAMS = [("m",)] + [(d, p) for d in ("pos", "neg") for p in ("sigma", "fc", "fs", "vs")]


def cli_identify(paths, *options):
    """`feedid identify --json` on the files: its JSON dict."""
    return cli("identify", paths, *options)


def cli(command, paths, *options):
    """`feedid <command> --json` on the files: its JSON dict."""
    with tempfile.TemporaryDirectory() as tmp:
        out = os.path.join(tmp, "r.json")
        args = [os.path.join(BIN, "feedid"), command, "--json", out, *options]
        for p in paths:
            args += ["--in", p]
        subprocess.run(args, check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        with open(out) as f:
            return json.load(f)


def value(result, key):
    return result[key[0]] if len(key) == 1 else result[key[0]][key[1]]


def sysid_log(mechanism):
    return [os.path.join(SYSID, "%s_%s.csv" % (mechanism, run)) for run in ("slow_fwd", "slow_bwd", "fast_fwd", "fast_bwd")]


def model_on_pulses(command):
    """The model identified on DATA_EMPS's arrays, the pulses run (its path
    and arrays), and `feedid <command> --model M --controller C` on that run."""
    d = np.genfromtxt(EMPS, delimiter=",", names=True)
    model = feedid.identify(d["t_s"], d["qm_m"], d["force_N"])
    pulses = EMPS.replace("DATA_EMPS.csv", "DATA_EMPS_PULSES.csv")
    with tempfile.NamedTemporaryFile("w", suffix=".json") as f:
        json.dump(model, f)
        f.flush()
        result = cli(command, [pulses], "--model", f.name, "--controller", CONTROLLER,
                     "--time", "t_s", "--position", "qm_m", "--force", "force_N")
    return model, pulses, np.genfromtxt(pulses, delimiter=",", names=True), result


@unittest.skipUnless(os.path.exists(EMPS), "no EMPS data at " + EMPS)
class EmpsArrays(unittest.TestCase):
    def test_arrays_give_the_cli_estimates(self):
        # GIVEN the EMPS columns as numpy arrays, parsed by numpy, not by the host
        d = np.genfromtxt(EMPS, delimiter=",", names=True)
        # WHEN identified from Python and by the CLI on the file
        py = feedid.identify(d["t_s"], d["qm_m"], d["force_N"])
        cli = cli_identify([EMPS], "--time", "t_s", "--position", "qm_m", "--force", "force_N")
        # THEN every parameter agrees (m to 1e-9 relative) and so do the units
        self.assertEqual(py["status"], "ok")
        self.assertAlmostEqual(py["m"] / cli["m"], 1.0, delta=1e-9)
        for key in PARAMS:
            self.assertAlmostEqual(value(py, key), value(cli, key), delta=1e-9 * abs(value(cli, key)), msg=str(key))
        self.assertEqual(py["units"], cli["units"])
        self.assertEqual(set(py), set(cli))

    def test_diagnose_and_validate_give_the_cli_results(self):
        # GIVEN the EMPS arrays, a model identified from them and the held-out pulses log
        cols = ("--time", "t_s", "--position", "qm_m", "--force", "force_N")
        d = np.genfromtxt(EMPS, delimiter=",", names=True)
        model = feedid.identify(d["t_s"], d["qm_m"], d["force_N"])
        pulses = EMPS.replace("DATA_EMPS.csv", "DATA_EMPS_PULSES.csv")
        p = np.genfromtxt(pulses, delimiter=",", names=True)
        # WHEN diagnosed and validated from Python and by the CLI
        dg = feedid.diagnose(d["t_s"], d["qm_m"], d["force_N"])
        # (on one thread as on the machine's: the same diagnosis)
        self.assertEqual(feedid.diagnose(d["t_s"], d["qm_m"], d["force_N"], threads=1), dg)
        val = feedid.validate(model, p["t_s"], p["qm_m"], p["force_N"])
        with tempfile.NamedTemporaryFile("w", suffix=".json") as f:
            json.dump(model, f)
            f.flush()
            cli_val = cli("validate", [pulses], "--model", f.name, *cols)
        cli_dg = cli("diagnose", [EMPS], *cols)
        # THEN the same effects, noise floor and force error
        self.assertEqual(dg["effect"], cli_dg["effect"])
        self.assertEqual(dg["effects"], cli_dg["effects"])
        self.assertAlmostEqual(dg["noise_floor_N"], cli_dg["noise_floor_N"], delta=1e-9 * cli_dg["noise_floor_N"])
        self.assertEqual(set(dg), set(cli_dg))
        self.assertAlmostEqual(val["relative_error_pct"], cli_val["relative_error_pct"], delta=1e-9 * cli_val["relative_error_pct"])
        self.assertEqual(set(val), set(cli_val))

    def test_diagnose_with_a_model_and_controller_gives_the_cli_results(self):
        # GIVEN the model identified on DATA_EMPS (a dict), the EMPS controller (a path) and the pulses run
        model, pulses, p, cli_dg = model_on_pulses("diagnose")
        # WHEN diagnosed from Python on the arrays and on the file, as diagnose --model --controller
        columns = {"qg_m": p["qg_m"], "pulses_N_raw": p["pulses_N_raw"]}
        dg = feedid.diagnose(p["t_s"], p["qm_m"], p["force_N"], model=model, controller=CONTROLLER, columns=columns)
        dg_file = feedid.diagnose_files(pulses, time="t_s", position="qm_m", force="force_N", model=model,
                                        controller=CONTROLLER)
        # THEN the CLI's keys, effects and held-out replay figures before and after
        for got in (dg, dg_file):
            self.assertEqual(set(got), set(cli_dg))
            self.assertEqual(got["base_model"]["refitted"], False)
            self.assertEqual([e["kind"] for e in got["effects"]], [e["kind"] for e in cli_dg["effects"]])
            for when in ("before_pct", "after_pct"):
                for k in ("position", "velocity", "acceleration", "force"):
                    self.assertAlmostEqual(got["replay"][when][k], cli_dg["replay"][when][k],
                                           delta=1e-9 * cli_dg["replay"][when][k], msg=when + " " + k)

    def test_replay_gives_the_cli_figures(self):
        # GIVEN the model identified on DATA_EMPS (a dict), the EMPS controller (a path) and the pulses run
        model, pulses, p, cli_r = model_on_pulses("replay")
        # WHEN replayed from Python on the arrays and on the file
        columns = {"qg_m": p["qg_m"], "pulses_N_raw": p["pulses_N_raw"]}
        on_arrays = feedid.replay(model, CONTROLLER, p["t_s"], p["qm_m"], p["force_N"], columns=columns)
        on_file = feedid.replay_file(model, CONTROLLER, pulses, time="t_s", position="qm_m", force="force_N")
        # THEN the CLI's keys and its four relative errors, each way of comparing
        for got in (on_arrays, on_file):
            self.assertEqual(set(got), set(cli_r))
            for figures in ("relative_error_pct", "relative_error_same_processing_pct", "processing_alone_pct"):
                for k in ("position", "velocity", "acceleration", "force"):
                    self.assertAlmostEqual(got[figures][k], cli_r[figures][k], delta=1e-9 * abs(cli_r[figures][k]),
                                           msg=figures + " " + k)
        # AND a missing reference column is a ValueError naming it, an unknown option a TypeError
        with self.assertRaisesRegex(ValueError, "no reference column 'qg_m'"):
            feedid.replay(model, CONTROLLER, p["t_s"], p["qm_m"], p["force_N"])
        # AND arrays without the controller's extra command are replayed without
        # the pulses, as the CLI does, and said (they went by without a word)
        with self.assertWarnsRegex(UserWarning, "no extra command column 'pulses_N_raw'"):
            feedid.replay(model, CONTROLLER, p["t_s"], p["qm_m"], p["force_N"], columns={"qg_m": p["qg_m"]})
        with self.assertRaisesRegex(TypeError, "unknown option 'folds'"):
            feedid.replay_file(model, CONTROLLER, pulses, folds=3)

    def test_monitor_reads_a_mat_file_as_the_cli(self):
        # GIVEN EMPS as its .mat (the force as vir, scaled) and as its CSV
        mat = EMPS.replace(".csv", ".mat")
        # WHEN monitored from Python
        from_mat = feedid.monitor(mat, time="t", position="qm", force="vir", force_scale=35.15065188248547, epoch_s=2)
        from_csv = feedid.monitor(EMPS, time="t_s", position="qm_m", force="force_N", epoch_s=2)
        # THEN the same epochs (the .mat read whole and handed on, not parsed as text)
        self.assertGreater(len(from_csv["epochs"]), 5)
        self.assertEqual(from_mat["epochs"], from_csv["epochs"])

    def test_diagnose_model_errors_and_warnings_are_the_clis(self):
        d = np.genfromtxt(EMPS, delimiter=",", names=True)
        hand = {"m": 95.1, "pos": {"sigma": 203.5, "fc": 20.4}, "neg": {"sigma": 203.5, "fc": 20.4}, "ofset_N": -3}
        # an unknown key in the model is a warning, as the CLI's on stderr
        with self.assertWarnsRegex(UserWarning, "unknown key 'ofset_N'"):
            feedid.diagnose(d["t_s"], d["qm_m"], d["force_N"], model=hand)
        # a controller without a model, and a reference column not given, are ValueErrors naming them
        with self.assertRaisesRegex(ValueError, "controller needs model"):
            feedid.diagnose(d["t_s"], d["qm_m"], d["force_N"], controller=CONTROLLER)
        with self.assertRaisesRegex(ValueError, "no reference column 'qg_m'"):
            feedid.diagnose(d["t_s"], d["qm_m"], d["force_N"], model=hand, controller=CONTROLLER)

    def test_compensate_gives_the_cli_table(self):
        # GIVEN the model identified from the EMPS arrays, and the same as a file
        d = np.genfromtxt(EMPS, delimiter=",", names=True)
        model = feedid.identify(d["t_s"], d["qm_m"], d["force_N"])
        with tempfile.TemporaryDirectory() as tmp:
            path = os.path.join(tmp, "model.json")
            with open(path, "w") as f:
                json.dump(model, f)
            out = os.path.join(tmp, "table.json")
            subprocess.run([os.path.join(BIN, "feedid"), "compensate", "--model", path, "--points", "12", "--out", out],
                           check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
            with open(out) as f:
                cli_table = json.load(f)
        # WHEN its table is made from Python; THEN it is the CLI's
        self.assertEqual(feedid.compensate(model, points=12), cli_table)
        # and what the CLI warns of is a Python warning: a table far above the
        # speeds the model was identified at
        with self.assertWarnsRegex(UserWarning, "times the fastest speed the model was identified at"):
            feedid.compensate(model, points=12, max_speed=100.0)
        # and a model that is not physical is refused with the CLI's words
        model["m"] = -1.0
        model["physical"] = False
        with self.assertRaisesRegex(ValueError, "no compensation written"):
            feedid.compensate(model)

    def test_a_model_in_other_units_is_refused(self):
        d = np.genfromtxt(EMPS, delimiter=",", names=True, max_rows=3000)
        rotary = {"m": 1, "pos": {"sigma": 1, "fc": 1, "fs": 0, "vs": 0}, "neg": {"sigma": 1, "fc": 1, "fs": 0, "vs": 0},
                  "units": {"position": "rad", "force": "N m"}}
        with self.assertRaisesRegex(ValueError, "the model is in rad and N m"):
            feedid.validate(rotary, d["t_s"], d["qm_m"], d["force_N"])

    def test_read_gives_the_arrays_the_file_holds(self):
        r = feedid.read(EMPS, time="t_s", position="qm_m", force="force_N")
        d = np.genfromtxt(EMPS, delimiter=",", names=True)
        self.assertIsNone(r["v"])
        np.testing.assert_array_equal(r["u"], d["force_N"])
        np.testing.assert_array_equal(r["x"], d["qm_m"])


class Errors(unittest.TestCase):
    def test_a_nan_row_is_refused_with_where_when_asked(self):
        t = np.arange(100) * 1e-3
        u = np.ones(100)
        u[7] = np.nan
        with self.assertRaisesRegex(ValueError, "arrays: element 7: a value is NaN/Inf"):
            feedid.identify(t, np.sin(t), u, bad_rows="error")

    def test_unknown_option_and_bad_values_are_named(self):
        t = np.arange(100) * 1e-3
        with self.assertRaisesRegex(TypeError, "unknown option 'velocity_fliter'"):
            feedid.identify(t, t, t, velocity_fliter=10)
        with self.assertRaisesRegex(ValueError, "velocity_filter: .* is negative"):
            feedid.identify(t, t, t, velocity_filter=-1)
        with self.assertRaisesRegex(ValueError, "threads: -1 is outside 0 .. 256"):
            feedid.diagnose(t, t, t, threads=-1)
        with self.assertRaisesRegex(ValueError, "differ in length"):
            feedid.identify(t, t[:50], t)
        with self.assertRaisesRegex(TypeError, "unknown option 'velocity_filter'"):
            feedid.validate({}, t, t, t, velocity_filter=10)  # identify's option, not validate's
        # An option of the wrong type is named with its value, not "Unable to cast"
        with self.assertRaisesRegex(TypeError, "velocity_filter: '100' is not a number"):
            feedid.identify(t, t, t, velocity_filter="100")
        with self.assertRaisesRegex(TypeError, "folds: 1000000000000 is not a whole number"):
            feedid.diagnose(t, t, t, folds=10**12)

    def test_model_dicts_take_numpy_values_and_name_what_is_wrong(self):
        # A review found: np.float32 in a model dict refused as "not JSON
        # serializable"; a NaN refused with a column of JSON text; a model
        # file that is not JSON unnamed; empty arrays "required" though given.
        t = np.arange(2000) * 1e-3
        x = 0.01 * np.sin(2 * np.pi * t)
        u = 100.0 * np.cos(2 * np.pi * t)
        model = {"m": np.float32(95.0), "pos": {"sigma": np.int64(200), "fc": 20.0},
                 "neg": {"sigma": 200.0, "fc": np.array(20.0)}}
        self.assertIn("relative_error_pct", feedid.validate(model, t, x, u))
        # what the CLI prints beside validate's figures is a Python warning; no model is a TypeError
        with self.assertWarnsRegex(UserWarning, "unknown key 'ofset_N'"):
            feedid.validate({**model, "ofset_N": 5.0}, t, x, u)
        with self.assertWarnsRegex(UserWarning, "beyond 0.4 of the log's rate"):
            feedid.validate(model, t, x, u, filter=1e6)
        with self.assertRaisesRegex(TypeError, "validate needs a model"):
            feedid.validate(None, t, x, u)
        # identify's warnings, which the CLI prints, are Python warnings (they
        # were only in the dict): a single tone leaves the lag to the reversals
        tt = np.arange(60000) * 5e-4
        w = 2 * np.pi
        vv = 0.05 * w * np.cos(w * tt)
        friction = np.sign(vv) * (25.0 + 8.0 * np.exp(-(vv / 0.002) ** 2)) + 700.0 * vv
        uu = 100.0 * -0.05 * w * w * np.sin(w * tt) + friction + np.random.default_rng(1).normal(0.0, 0.5, tt.size)
        with self.assertWarnsRegex(UserWarning, "told only by the reversals"):
            tone = feedid.identify(tt, np.round(0.05 * np.sin(w * tt) / 1e-8) * 1e-8, uu)
        self.assertTrue(any("told only by the reversals" in x for x in tone["warnings"]))
        # a stated lag is searched beside and warned of where the data put it
        # elsewhere (two tones separate it; the force is instant, lag 0)
        vv2 = vv + 0.02 * 5 * w * np.cos(5 * w * tt)
        friction2 = np.sign(vv2) * (25.0 + 8.0 * np.exp(-(vv2 / 0.002) ** 2)) + 700.0 * vv2
        uu2 = 100.0 * np.gradient(vv2, tt) + friction2 + np.random.default_rng(2).normal(0.0, 0.5, tt.size)
        xx2 = np.round((0.05 * np.sin(w * tt) + 0.02 * np.sin(5 * w * tt)) / 1e-8) * 1e-8
        with self.assertWarnsRegex(UserWarning, "stated force lag"):
            feedid.identify(tt, xx2, uu2, force_lag_s=1e-3)
        with self.assertRaisesRegex(ValueError, "model: 'pos.fc' must be a finite number, not nan"):
            feedid.validate({**model, "pos": {"sigma": 200.0, "fc": float("nan")}}, t, x, u)
        with tempfile.TemporaryDirectory() as tmp:
            bad = os.path.join(tmp, "bad.json")
            with open(bad, "w") as f:
                f.write("{\"m\": ")
            with self.assertRaisesRegex(ValueError, "bad.json: not valid JSON"):
                feedid.validate(bad, t, x, u)
            good = os.path.join(tmp, "model.json")
            with open(good, "w") as f:
                json.dump({"m": 95.0, "pos": {"sigma": 200.0, "fc": 20.0}, "neg": {"sigma": 200.0, "fc": 20.0}}, f)
            self.assertEqual(feedid.validate(good, t, x, u)["relative_error_pct"],
                             feedid.validate(model, t, x, u)["relative_error_pct"])
        with self.assertRaisesRegex(ValueError, "t, u have no samples"):
            feedid.identify(np.array([]), np.array([]), np.array([]))
        # complex, boolean and text arrays are refused (they were cast); narrower floats are warned of
        for bad in (t.astype(complex), t > 0, t.astype(str)):
            with self.assertRaisesRegex(TypeError, "t: an array of .* a signal is real numbers"):
                feedid.validate(model, bad, x, u)
        with self.assertWarnsRegex(UserWarning, "u is float32: .*give float64"):
            feedid.validate(model, t, x, u.astype(np.float32))

    def test_a_missing_file_is_the_readers_message(self):
        with self.assertRaises(ValueError) as e:
            feedid.identify_files("/nonexistent/log.csv")
        self.assertIn("/nonexistent/log.csv", str(e.exception))


@unittest.skipUnless(os.path.isdir(SYSID), "no SysId data at " + SYSID)
class Fleet(unittest.TestCase):
    def test_two_logs_on_two_workers_give_the_cli_viscous_terms(self):
        try:
            from dask.distributed import Client, LocalCluster
            import feedid.fleet
        except ImportError as e:
            self.skipTest("no dask.distributed or pandas: %s" % e)
        # GIVEN two mechanisms' pooled runs, one log that cannot be read, and one
        # run alone, whose model is not physical (the CLI exits 2 on it)
        logs = [sysid_log("compbot_drive_left"), sysid_log("compbot_spu"), [os.path.join(SYSID, "missing.csv")],
                sysid_log("compbot_drive_left")[:1]]
        # WHEN identified as dask tasks on a 2-worker LocalCluster (threads: no process start-up in CI)
        with LocalCluster(n_workers=2, threads_per_worker=1, processes=False, dashboard_address=None) as cluster, \
                Client(cluster) as client:
            self.assertEqual(len(client.scheduler_info()["workers"]), 2)
            frame = feedid.fleet.identify_many(logs, client=client, axis="rotary", force_unit="V")
            # a single path is one log, not a log per character; an item naming no path is its own error row
            one = feedid.fleet.identify_many(logs[3][0], client=client, axis="rotary", force_unit="V")
            bad = feedid.fleet.identify_many([None, logs[3][0]], client=client, axis="rotary", force_unit="V")
        self.assertEqual(len(one), 1)
        self.assertEqual(one["path"][0], logs[3][0])
        self.assertEqual(len(bad), 2)
        self.assertEqual(bad["status"][0], "error")
        self.assertIn("TypeError", bad["error"][0])
        self.assertEqual(bad["status"][1], one["status"][0])
        # THEN one row per log, in order; the bad one carries its error and stopped nothing
        self.assertEqual(len(frame), 4)
        self.assertIn("missing.csv", frame["error"][2])
        self.assertEqual(frame["status"][2], "error")
        self.assertEqual(frame["status"][3], "not_physical")
        self.assertIn("not physical", frame["error"][3])
        for i, paths in enumerate(logs[:2]):
            cli = cli_identify(paths, "--axis", "rotary", "--force-unit", "V")
            self.assertEqual(frame["error"][i], "")
            self.assertEqual(frame["status"][i], "ok")
            self.assertEqual(frame["path"][i], " + ".join(paths))
            for d in ("pos", "neg"):
                self.assertEqual(frame[d + "_sigma"][i], cli[d]["sigma"])
                self.assertEqual(frame[d + "_sigma_se"][i], cli[d]["sigma_se"])
            self.assertEqual(frame["m"][i], cli["m"])
            self.assertEqual(frame["units"][i]["sigma"], "V s/rad")
        # AND the fleet page sets every axis side by side: a table row per log with
        # its error, and one figure per parameter (m, sigma, fc, fs, vs)
        with tempfile.TemporaryDirectory() as tmp:
            page = feedid.fleet.report(frame, os.path.join(tmp, "fleet"))
            with open(page) as f:
                text = f.read()
        self.assertEqual(text.count("<svg"), 5)
        self.assertEqual(text.count("<tr><td>"), 4)
        self.assertIn("missing.csv: cannot open", text)
        self.assertIn("pos sigma (V s/rad)", text)
        # an estimate the data cannot tell is said to be one, cell by cell
        flags = ["m_identifiable"] + ["%s_%s_identifiable" % (d, p) for d in ("pos", "neg") for p in ("sigma", "fc", "fs", "vs")]
        not_identifiable = sum(1 for f in flags for i in range(len(frame))
                               if frame[f][i] is False or frame[f][i] is np.False_)
        self.assertGreater(not_identifiable, 0)
        self.assertEqual(text.count("(not identifiable)"), not_identifiable)
        for paths in logs:
            self.assertIn(" + ".join(paths), text)


class Monitor(unittest.TestCase):
    def test_monitor_many_gives_the_cli_alarms_one_row_per_log(self):
        try:
            from dask.distributed import Client, LocalCluster
            import feedid.fleet
        except ImportError as e:
            self.skipTest("no dask.distributed or pandas: %s" % e)
        with tempfile.TemporaryDirectory() as tmp:
            # GIVEN a simulated log whose Coulomb friction steps up by half at 150 s, and a log that is not there
            log = os.path.join(tmp, "change.csv")
            subprocess.run([os.path.join(BIN, "feedid"), "simulate", "--program", "sine", "--duration", "240",
                            "--change-time", "150", "--change-coulomb-fraction", "0.5", "--out", log],
                           check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
            # WHEN monitored as dask tasks on 2 workers, and by the CLI
            with LocalCluster(n_workers=2, threads_per_worker=1, processes=False, dashboard_address=None) as cluster, \
                    Client(cluster) as client:
                frame = feedid.fleet.monitor_many([log, os.path.join(tmp, "missing.csv")], client=client)
            cli_mon = cli("monitor", [log])
            py_mon = feedid.monitor(log)
        # THEN the CLI's alarms, in both; the missing log is a row with its error
        self.assertEqual(py_mon["alarms"], cli_mon["alarms"])
        self.assertEqual(len(frame), 2)
        self.assertEqual(frame["alarms"][0], len(cli_mon["alarms"]))
        self.assertEqual(frame["first_alarm_parameter"][0], "fc")
        self.assertEqual(frame["first_alarm_t_s"][0], cli_mon["alarms"][0]["t_s"])
        self.assertEqual(frame["epochs"][0], len(cli_mon["epochs"]))
        self.assertIn("missing.csv", frame["error"][1])


if __name__ == "__main__":
    unittest.main(verbosity=2)
