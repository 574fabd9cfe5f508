// `gipdyn preprocess`: a raw robot log into a training CSV.
#include <cstdio>
#include <memory>

#include "commands.hpp"
#include "data_option.hpp"
#include "output_guard.hpp"
#include "gipdyn/error.hpp"
#include "gipdyn/io/csv.hpp"
#include "gipdyn/preprocess/log_preprocessing.hpp"

namespace gipdyn::cli {

Command add_preprocess(CLI::App& app) {
  struct Args {
    std::string in, out;
    PreprocessOptions options;
    std::string columns;  // --columns, parsed into options.columns
    bool quiet = false;
  };
  auto a = std::make_shared<Args>();
  app.description(
      "Turn a raw robot log into a training dataset: resample onto a uniform grid, Butterworth low-pass of q\n"
      "and qd (zero phase, or --causal as a controller runs it online; tau only with --filter-torque), qd from q\n"
      "when the log has none, qdd from the filtered qd, optionally drop stretches at rest; --segment-starts\n"
      "processes train and test stretches separately. The log needs a time column (or --log-period), q1..qn and\n"
      "tau1..taun (qd1..qn optional). Writes t, q, qd, qdd, tau columns and OUT.json, which records every step.");
  app.add_option("--data,--in", a->in, "Raw log (CSV with a header row); --in is the older name")->required()->check(CLI::ExistingFile);
  app.add_option("--out", a->out, "Output dataset CSV (+ OUT.json)")->required();
  add_columns_option(app, a->columns);
  app.add_option("--time-column", a->options.time_column, "Name of the time column in seconds (default: t, else time)");
  app.add_option("--log-period", a->options.log_period,
                 "The log has no time column: its rows are this many seconds apart (e.g. 0.008 for 125 Hz)");
  app.add_option("--dt", a->options.dt, "Resampling period in seconds (default: the log's mean step, which keeps its number of samples)");
  app.add_option("--cutoff", a->options.cutoff_hz, "Low-pass cutoff in Hz (default: no filtering)");
  app.add_option("--order", a->options.filter_order, "Butterworth order of one pass (zero phase runs two)")
      ->capture_default_str();
  app.add_flag("--drop-rest", a->options.drop_rest,
               "Drop the stretches where every joint velocity stays below --rest-velocity for --rest-duration");
  app.add_option("--rest-velocity", a->options.rest_velocity, "Velocity under which a joint is at rest (rad/s or m/s)")
      ->capture_default_str();
  app.add_option("--rest-duration", a->options.rest_duration,
                 "Shortest stretch at rest that is dropped, in seconds (turning points are shorter)")
      ->capture_default_str();
  app.add_flag("--causal", a->options.causal,
               "Forward-only filter and backward differences, as a 1 kHz controller can compute them online; the "
               "delay of q, qd and qdd is reported in OUT.json");
  app.add_flag("--filter-torque", a->options.filter_torque,
               "Low-pass the torques too (default: the targets are left as measured)");
  app.add_option("--segment-starts", a->options.segment_starts,
                 "Data rows (1-based) where a new segment starts, e.g. 6341: each segment is resampled, filtered "
                 "and differentiated on its own, so no filter carries test rows into training rows")
      ->delimiter(',');
  app.add_option("--max-gap", a->options.max_gap_steps,
                 "A step longer than this many median steps is a gap in the log: an error, unless a segment starts there")
      ->capture_default_str();
  app.add_flag("--quiet", a->quiet, "Print nothing but errors");
  return [a]() -> int {
    refuse_overwrites({{"--data", a->in}}, {{"--out", a->out}, {"--out (its .json report)", a->out + ".json"}});
    a->options.columns = parse_log_columns(a->columns);
    const PreprocessedLog log = preprocess_log(a->in, a->options);
    write_csv_with_sidecar(a->out, log.column_names(), log.table(), log.report);
    for (const auto& s : log.report["steps"])
      if (s["step"] == "unwrap")
        for (const auto& [column, jumps] : s["jumps"].items())
          std::fprintf(stderr,
                       "gipdyn: warning: %s jumps by more than pi between two rows %lld time(s): read as an angle "
                       "wrapping around and unwrapped (if it is not an angle, the log has a glitch there)\n",
                       column.c_str(), jumps.get<long long>());
    if (!a->quiet) {
      std::printf("%s: %lld rows, %d joints -> %s: %lld rows, dt %g s\n", a->in.c_str(),
                  static_cast<long long>(log.report["input_rows"].get<long long>()), log.joints(), a->out.c_str(),
                  static_cast<long long>(log.t.size()), log.report["dt_s"].get<double>());
      for (const auto& s : log.report["steps"]) std::printf("  %s\n", s.dump().c_str());
      std::printf("steps recorded in %s.json\n", a->out.c_str());
    }
    return 0;
  };
}

}  // namespace gipdyn::cli
