// Friction health from a log of any length (`feedid monitor`): the log is
// read row by row and cut into epochs; each epoch is identified on its own
// (bounded memory: one epoch's samples), and the core's ChangeMonitor
// (core/feedid/monitor.hpp) compares it with a reference and raises
// alarms. Host only.
#pragma once
#include <array>
#include <cstdint>
#include <cmath>
#include <functional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "io/csv_trace.hpp"
#include "feedid/monitor.hpp"
#include "identify/identify.hpp"

namespace feedid::host {

struct MonitorOptions {
  feedid::MonitorConfig<double> detector{};   ///< epoch length, reference epochs, CUSUM k and h
  IdentifyOptions identify;                   ///< how each epoch is identified
  /// The log's conventions (force sign, force and velocity lags, velocity
  /// cut-off) are found on the head (kConventionsHead_s: its epochs wait
  /// for them) and then stated to every epoch, with the lag's standard
  /// error; found afresh on the head of every this many epochs (0: never
  /// again). Where a head does not identify, the first epoch that does sets them.
  int recheck_conventions_every = 60;
  std::function<void(double t_s)> progress;   ///< after each epoch, with its end time
};

struct MonitorEpoch {
  double t_start_s = 0.0, t_end_s = 0.0;
  std::size_t samples = 0;
  std::string error;             ///< set when the epoch could not be identified (the epoch is skipped)
  feedid::Estimate<double> estimate{};
  std::array<bool, 2> stribeck{};  ///< [pos, neg]: model selection kept the Stribeck law in this epoch
  /// [pos, neg]: the epoch's law is not the log's (LogLaw), so its Fc and
  /// sigma are not compared: a Coulomb + viscous fit of a drive with a
  /// Stribeck dip puts part of the dip into Fc (20 % on a sine log).
  std::array<bool, 2> law_differs{};
  /// Epoch means of the temperature and load columns (--temperature,
  /// --load); NaN when the column is not read.
  double temperature = NAN, load = NAN;
  /// Bit i: tracked index i (feedid::tracked_value) went to the change monitor from this epoch.
  std::uint16_t compared_mask = 0;
};

/// Each direction's friction law, fixed once per log like the conventions:
/// the law most of the first reference epochs that identified the
/// direction's friction chose (Stribeck on a tie).
struct LogLaw {
  std::array<bool, 2> fixed{}, stribeck{};
  std::array<int, 2> votes_stribeck{}, votes_cv{};
};

/// How many epochs carried a tracked parameter, and why the others did not.
struct TrackedCount {
  int carried = 0;       ///< carried by the epoch: compared with the reference (or forming it) where watched
  int flagged = 0;       ///< identified, but flagged (standard error over a quarter, negative, an Fc whose slope is unresolved, ...)
  int law_differs = 0;   ///< the epoch's friction law was not the log's
  bool referenced = false;
  bool watched = true;   ///< compared at all (Fs and vs: only with --watch-stribeck)
};

/// A log's conventions as the epochs are told them (IdentifyOptions).
struct LogConventions {
  bool fixed = false;
  /// The epochs' options with the found conventions stated
  /// (with_conventions_of): force_sign, force_lag_s, velocity_lag_s (NaN:
  /// none found), velocity_filter_hz (0: the velocity column) and
  /// velocity_source.
  IdentifyOptions stated;
  int found_at_epoch = -1;   ///< the epoch they were last found on
  int times_found = 0;       ///< the first time and every re-check
  int times_changed = 0;     ///< re-checks that found other conventions
};

struct MonitorResult {
  std::string error;             ///< reading failed (the epochs so far are kept)
  std::vector<MonitorEpoch> epochs;
  std::vector<feedid::ChangeAlarm<double>> alarms;
  /// Per alarm: the start of the last epoch before its run that carried
  /// the parameter to the change monitor. The change lies after it (that
  /// epoch may hold its start, mixed in below the allowance) and by the end
  /// of the run's first epoch (ChangeAlarm::t_s is that epoch's start).
  /// With short epochs few carry Fc or sigma (an epoch must fix the
  /// slope), and t_s alone, read as the change's time, was up to 30 s late
  /// at 5 s epochs. The run's first epoch's start where none carried it before.
  /// A step's bound: a drift below the allowance began before it.
  std::vector<double> alarm_earliest_t_s;
  LogConventions conventions;
  LogLaw law;
  std::size_t epochs_skipped = 0;   ///< epochs that could not be identified at all
  std::array<TrackedCount, feedid::kTrackedCount> tracked{};
  /// Every tracked parameter that got a reference (false: the log never
  /// carried enough identified epochs to watch anything; error says so).
  bool referenced = false;
  std::size_t rows_skipped = 0, rows_repeated = 0;
  /// What the log's stamps count from (Trace::time_origin_s); the epochs'
  /// times have it added back, so that they are the log's own clock.
  double time_origin_s = 0.0;
  std::vector<std::string> skipped_rows;  ///< the first few, with file:line and why
  Units units;
};

/// Reads the stream to its end, epoch by epoch.
MonitorResult monitor(CsvStream& in, const MonitorOptions& opt);
/// What the monitor watched: "watching" (m, sigma+-, Fc+- all have a
/// reference), "partly_watching" (some do) or "not_watching" (none: the
/// absence of alarms means nothing).
std::string watch_status(const MonitorResult& r);
/// Whether tracked index i of an epoch was compared (the core's rule, the
/// epoch identified, and its law the log's).
bool carried(const MonitorEpoch& ep, int i);
/// One JSON object per line: each epoch ("type": "epoch") and each alarm
/// ("type": "alarm"), in time order (docs/monitor.md, "Time series").
std::string jsonl_lines(const MonitorResult& r, const std::string& source);
nlohmann::json to_json(const MonitorResult& r, const MonitorOptions& opt);
/// Each parameter's trend with +-2 se bands and the alarm times, stacked panels in one SVG.
bool write_trend_svg(const MonitorResult& r, const std::string& path, std::string& error);
/// One line per epoch (t, m, sigma+-, Fc+-) with standard errors, and the alarms.
std::string trend_table(const MonitorResult& r);

}  // namespace feedid::host
