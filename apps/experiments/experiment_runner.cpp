#include "experiments/experiment_runner.hpp"

#include <chrono>
#include <filesystem>
#include <fstream>

#include "gipdyn/error.hpp"
#include "gipdyn/io/detail/atomic_file.hpp"
#include "reports/plots.hpp"
#include "reports/result_table.hpp"
#include "reports/text_format.hpp"

namespace gipdyn {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

std::uint64_t mix_seed(std::uint64_t seed, std::uint64_t a, std::uint64_t b) {
  // splitmix64 of a combination: well-separated streams for (seed, run, purpose).
  std::uint64_t z = seed * 0x9E3779B97F4A7C15ULL + a * 0xBF58476D1CE4E5B9ULL + b * 0x94D049BB133111EBULL + 1;
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ULL;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBULL;
  return z ^ (z >> 31);
}

// The folder and its config.json: a restart must use the same settings.
void prepare_folder(const std::string& out, const nlohmann::json& config) {
  if (out.empty()) throw Error("--out is required: the folder for the experiment's files");
  fs::create_directories(out);
  const std::string path = (fs::path(out) / "config.json").string();
  if (fs::exists(path)) {
    nlohmann::json old;
    try {
      std::ifstream in(path);
      old = nlohmann::json::parse(in);
    } catch (const std::exception&) {
      throw Error("'" + path + "' is unreadable; delete it (and the results beside it) or use another --out");
    }
    if (old != config)
      throw Error("'" + out + "' holds an experiment with other settings (config.json differs: was " + old.dump() +
                  "); use another --out, or the same settings to resume");
    return;
  }
  write_file_atomically(path, [&](std::ostream& o) { o << config.dump(2) << "\n"; });
}

void Eta::record(const std::string& key, double seconds) {
  auto& [sum, count] = stats_[key];
  sum += seconds;
  ++count;
}

void Eta::add_pending(const std::string& key, int units) { pending_[key] += units; }

void Eta::finish(const std::string& key) { --pending_[key]; }

std::string Eta::left() const {
  double total = 0.0, known_sum = 0.0;
  int known = 0;
  for (const auto& [e, sc] : stats_) {
    known_sum += sc.first;
    known += sc.second;
  }
  for (const auto& [e, n] : pending_) {
    if (n <= 0) continue;
    auto it = stats_.find(e);
    if (it != stats_.end() && it->second.second > 0) total += n * it->second.first / it->second.second;
    else if (known > 0) total += n * known_sum / known;
    else return "time left unknown yet";
  }
  return "about " + duration(total / concurrency_) + " left";
}

FitAndPredict fit_and_predict(const EstimatorOptions& options, const Eigen::MatrixXd& X, const Eigen::MatrixXd& Y,
                              const JointTypes& joints, const Eigen::MatrixXd& Xtest) {
  FitAndPredict out;
  const auto t0 = Clock::now();
  try {
    FitResult r = fit_estimator(options, X, Y, joints);
    out.ok = r.report.ok();
    out.message = r.report.message;
    out.report = r.report;
    if (out.ok) out.prediction = r.estimator->predict(Xtest);
    if (out.ok && r.estimator->gp_model()) out.log_params = learned_log_params(*r.estimator->gp_model());
    if (out.ok && r.teaching_check) {
      out.teaching_check = r.teaching_check;
      out.teacher = options.teacher->name;
    }
    if (out.ok && !out.prediction.allFinite()) {
      out.ok = false;
      out.message = "predictions contain NaN or Inf";
    }
  } catch (const Error& e) {
    out.message = e.what();
  }
  out.seconds = std::chrono::duration<double>(Clock::now() - t0).count();
  return out;
}

WarmStarts::WarmStarts(std::string out) : path_((fs::path(out) / "warm_starts.json").string()) {
  if (!fs::exists(path_)) return;
  try {
    std::ifstream in(path_);
    const nlohmann::json j = nlohmann::json::parse(in);
    for (const auto& [estimator, joints] : j.items())
      for (const auto& v : joints) {
        const std::vector<double> x = v.get<std::vector<double>>();
        starts_[estimator].push_back(Eigen::Map<const Eigen::VectorXd>(x.data(), static_cast<Eigen::Index>(x.size())));
      }
  } catch (const std::exception&) {
    throw Error("'" + path_ + "' is unreadable; delete it (the fits after the first then start cold) or use another --out");
  }
}

const std::vector<Eigen::VectorXd>* WarmStarts::find(const std::string& estimator) const {
  const auto it = starts_.find(estimator);
  return it == starts_.end() ? nullptr : &it->second;
}

void WarmStarts::store(const std::string& estimator, const std::vector<Eigen::VectorXd>& log_params) {
  if (log_params.empty()) return;
  starts_[estimator] = log_params;
  nlohmann::json j = nlohmann::json::object();
  for (const auto& [e, joints] : starts_)
    for (const auto& x : joints) j[e].push_back(std::vector<double>(x.data(), x.data() + x.size()));
  write_file_atomically(path_, [&](std::ostream& o) { o << j.dump(2) << "\n"; });
}

StudentTeacherSpec parse_estimator_spec(const std::string& name) {
  const auto at = name.find('@');
  if (at == std::string::npos) return {name, ""};
  return {name.substr(0, at), name.substr(at + 1)};
}

EstimatorOptions options_for(const EstimatorOptions& base, const std::string& name, const RobotPrior& prior,
                             std::uint64_t seed) {
  const StudentTeacherSpec spec = parse_estimator_spec(name);
  EstimatorOptions o = base;
  o.name = spec.student;
  if (estimator_needs_robot(spec.student)) o.robot_prior = prior;
  o.search.seed = seed;
  o.nn.seed = seed;
  if (!spec.teacher.empty()) {
    o.teacher = TeacherOptions{};
    o.teacher->name = spec.teacher;
    o.teacher->seed = seed;
  }
  return o;
}

nlohmann::json base_options_json(const EstimatorOptions& b, const std::vector<std::string>& estimators) {
  nlohmann::json j = {{"optimizer", b.search.optimizer.kind == OptimizerKind::Adam ? "adam" : "lbfgs"},
          {"max_iter", b.search.optimizer.max_iterations},
          // Always written: a folder from before the option existed ran with 10 pairs and must not resume
          // with another optimiser's fits mixed into its tables.
          {"lbfgs_memory", b.search.optimizer.lbfgs_memory},
          // Unset: each estimator's own (EstimatorSpec::restarts).
          {"restarts", b.search.restarts ? nlohmann::json(*b.search.restarts) : nlohmann::json("each model's own")},
          {"warm_start_rows", b.gp.warm_start_rows},
          {"gradient_tolerance", b.search.gradient_tolerance_per_row},
          {"scaling", to_string(b.gp.scaling)},
          {"min_noise", b.search.min_noise_fraction},
          {"prior", b.gp.prior.enabled ? "lognormal" : "none"},
          {"prior_width", b.gp.prior.width},
          {"nn_hidden", b.nn.hidden},
          {"nn_epochs", b.nn.epochs},
          {"nn_batch", b.nn.batch_size},
          {"nn_lr", b.nn.learning_rate},
          // Always written: a folder from before early stopping trained its networks on every row.
          {"nn_validation", b.nn.validation_fraction},
          {"nn_patience", b.nn.patience}};
  // Only when set, so folders written before mean functions existed still resume.
  if (b.gp.mean != MeanKind::Zero) j["mean"] = to_string(b.gp.mean);
  if (b.sparse.inducing_points > 0) j["inducing"] = b.sparse.inducing_points;
  if (b.search.hyperparameter_rows > 0) j["hyperparameter_rows"] = b.search.hyperparameter_rows;
  if (b.sparse.hyperparameter_objective != HyperparameterObjective::SparseBound)
    j["hyperparameter_objective"] = to_string(b.sparse.hyperparameter_objective);
  // Only with a teacher, so folders without one still resume.
  for (const auto& e : estimators)
    if (!parse_estimator_spec(e).teacher.empty()) {
      const TeacherOptions teacher;  // what options_for uses
      j["teacher_states"] = teacher.states;
      j["teacher_hyperparameter_rows"] = teacher.hyperparameter_rows;
      j["student_hyperparameter_rows"] = teacher.student_search(b.search).hyperparameter_rows;
      break;
    }
  return j;
}

void validate_estimators(const std::vector<std::string>& estimators) {
  if (estimators.empty()) throw Error("--models: name at least one estimator");
  for (const auto& e : estimators) {
    const StudentTeacherSpec spec = parse_estimator_spec(e);
    require_known_estimator(spec.student);
    if (e.find('@') == std::string::npos) continue;
    TeacherOptions teacher;
    teacher.name = spec.teacher;
    try {
      teacher.validate();
    } catch (const Error& error) {
      throw Error("--models: '" + e + "' names a teacher it cannot use (" + error.what() +
                  "); write STUDENT@TEACHER, e.g. gip@lip");
    }
  }
}

void validate_base_options(const EstimatorOptions& base) {
  EstimatorOptions gp = base;
  gp.name = default_estimator_name();  // a GP; the model-based kernels' robot is checked per estimator
  gp.train_options().validate();
  base.nn.validate();
}

void log_line(const std::string& out, const std::string& line) {
  std::ofstream log((fs::path(out) / "experiment.log").string(), std::ios::app);
  log << line << "\n";
}

void note(const ProgressCallback& progress, const std::string& line) {
  if (!progress) return;
  ProgressEvent e;
  e.message = line;
  progress(e);
}

void finish_fit(ExperimentOutcome& outcome, Eta& eta, const std::string& eta_key, const std::string& out,
                const std::string& where, const std::string& estimator, const FitAndPredict& f,
                const std::string& metrics, const ProgressCallback& progress, const std::string& label) {
  const std::string name = label.empty() ? estimator : label;
  if (f.ok) {
    ++outcome.units_done;
  } else {
    ++outcome.units_failed;
    log_line(out, where + estimator + " failed: " + f.message);
    note(progress, "  " + name + " failed: " + f.message);
  }
  eta.record(eta_key, f.seconds);
  eta.finish(eta_key);
  note(progress, "  " + name + " done in " + duration(f.seconds) + ", " + metrics);
  if (f.teaching_check) {
    std::string pairs;
    for (Eigen::Index j = 0; j < f.teaching_check->student_nmse.size(); ++j)
      pairs += " " + format_number(f.teaching_check->teacher_nmse(j)) + "/" +
               format_number(f.teaching_check->student_nmse(j));
    log_line(out, where + estimator + " nMSE on the training rows, per joint, teacher / student:" + pairs);
    const std::string warning = f.teaching_check->warning(f.teacher);
    if (!warning.empty()) {
      log_line(out, where + estimator + " warning: " + warning);
      note(progress, "  " + name + " warning: " + warning);
    }
  }
}

void record_fit_report(const std::string& out, const std::vector<std::pair<std::string, std::string>>& key,
                       const std::string& estimator, const FitAndPredict& fit) {
  std::vector<std::string> columns;
  for (const auto& [name, value] : key) columns.push_back(name);
  for (const char* c : {"estimator", "joint", "status", "evaluations", "warm_start_evaluations", "nll", "grad_norm", "noise_variance", "jitter"})
    columns.push_back(c);
  ResultTable table((fs::path(out) / "fit_reports.csv").string(), columns);
  auto row_start = [&] {
    std::vector<std::string> row;
    for (const auto& [name, value] : key) row.push_back(value);
    row.push_back(estimator);
    return row;
  };
  std::vector<std::vector<std::string>> rows;
  for (const JointReport& j : fit.report.joints) {
    std::vector<std::string> row = row_start();
    for (const std::string& v :
         {std::to_string(j.joint + 1), to_string(j.status), std::to_string(j.evaluations),
          std::to_string(j.warm_start_evaluations), format_number(j.nll),
          format_number(j.grad_norm), format_number(j.noise_variance), format_number(j.jitter)})
      row.push_back(v);
    rows.push_back(row);
  }
  if (rows.empty()) {
    std::vector<std::string> row = row_start();
    const std::string status = fit.ok ? to_string(fit.report.status) : "failed";
    for (const std::string& v : {std::string("all"), status, std::string("nan"), std::string("nan"), std::string("nan"),
                                 std::string("nan"), std::string("nan"), std::string("nan")})
      row.push_back(v);
    rows.push_back(row);
  }
  table.append(rows);
}

void plot_into(ExperimentOutcome& outcome, const std::string& kind, const std::string& input, const std::string& png) {
  const PlotResult p = render_plot(kind, input, png);
  if (p.ok) outcome.files.push_back(png);
  else outcome.warnings.push_back(p.message);
}

}  // namespace gipdyn
