// Friction health from a log of any length (`feedid monitor`): the log is
// read row by row and cut into epochs; each epoch is identified on its own
// (bounded memory: one epoch's samples), and the core's ChangeMonitor
// (core/feedid/monitor.hpp) compares it with a reference and raises
// alarms. Host only.
#pragma once
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
  /// cut-off) are found on the first epoch that identifies and then stated
  /// to every epoch, found afresh every this many epochs (0: never again).
  int recheck_conventions_every = 60;
  std::function<void(double t_s)> progress;   ///< after each epoch, with its end time
};

struct MonitorEpoch {
  double t_start_s = 0.0, t_end_s = 0.0;
  std::size_t samples = 0;
  std::string error;             ///< set when the epoch could not be identified
  feedid::Estimate<double> estimate{};
};

/// A log's conventions as the epochs are told them (IdentifyOptions).
struct LogConventions {
  bool fixed = false;
  int force_sign = 0;
  double force_lag_s = 0.0, velocity_lag_s = 0.0, velocity_filter_hz = 0.0;
  int found_at_epoch = -1;   ///< the epoch they were last found on
  int times_found = 0;       ///< the first time and every re-check
  int times_changed = 0;     ///< re-checks that found other conventions
};

struct MonitorResult {
  std::string error;             ///< reading failed (the epochs so far are kept)
  std::vector<MonitorEpoch> epochs;
  std::vector<feedid::ChangeAlarm<double>> alarms;
  LogConventions conventions;
  /// Every tracked parameter that got a reference (false: the log never
  /// carried enough identified epochs to watch anything; error says so).
  bool referenced = false;
  std::size_t rows_skipped = 0, rows_repeated = 0;
  std::vector<std::string> skipped_rows;  ///< the first few, with file:line and why
  Units units;
};

/// Reads the stream to its end, epoch by epoch.
MonitorResult monitor(CsvStream& in, const MonitorOptions& opt);
nlohmann::json to_json(const MonitorResult& r, const MonitorOptions& opt);
/// Each parameter's trend with +-2 se bands and the alarm times, stacked panels in one SVG.
bool write_trend_svg(const MonitorResult& r, const std::string& path, std::string& error);
/// One line per epoch (t, m, sigma+-, Fc+-) with standard errors, and the alarms.
std::string trend_table(const MonitorResult& r);

}  // namespace feedid::host
