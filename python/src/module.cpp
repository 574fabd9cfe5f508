// The gipdyn._core extension: thin bindings over the C++ library. The
// options are the library's own structs; the scikit-learn-style estimator
// lives in Python (gipdyn/__init__.py) and fills them in.
#include <pybind11/eigen.h>
#include <pybind11/functional.h>
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <cstdio>
#include <memory>
#include <mutex>
#include <nlohmann/json.hpp>

#include "gipdyn/data_consistency.hpp"
#include "gipdyn/error.hpp"
#include "gipdyn/estimators/estimator_file.hpp"
#include "gipdyn/estimators/fit_estimator.hpp"
#include "gipdyn/estimators/options_record.hpp"
#include "gipdyn/estimators/per_joint_estimator.hpp"
#include "gipdyn/estimators/gp_estimator.hpp"
#include "gipdyn/estimators/model_selection.hpp"
#include "gipdyn/estimators/online_update.hpp"
#include "gipdyn/estimators/lagrangian_estimator.hpp"
#include "gipdyn/estimators/physics.hpp"
#include "gipdyn/estimators/presets.hpp"
#include "gipdyn/estimators/teacher.hpp"
#include "gipdyn/io/mat_dataset.hpp"
#include "gipdyn/kernels/kernel_factory.hpp"
#include "gipdyn/metrics.hpp"
#include "gipdyn/model/fit_report.hpp"
#include "gipdyn/model/model_file.hpp"
#include "gipdyn/model/training.hpp"
#include "gipdyn/robot/dynamics.hpp"
#include "gipdyn/robot/robot_loader.hpp"
#include "gipdyn/sensing/contact_detection.hpp"
#include "gipdyn/sim/simulate.hpp"
#include "gipdyn/training_data.hpp"
#include "gipdyn/version.hpp"
#ifdef GIPDYN_HAVE_MPI
#include "gipdyn/distributed/distributed_nll.hpp"
#include "gipdyn/io/detail/model_container.hpp"
#endif

namespace py = pybind11;
using namespace gipdyn;
using ConstRef = Eigen::Ref<const Eigen::MatrixXd>;

namespace {

// Library field names as the Python user spells them (InverseDynamicsGP's keywords).
const FieldNames& python_field_names() {
  static const FieldNames names{
      {"EstimatorOptions::robot_prior", "robot"},
      {"TrainOptions::robot_prior", "robot"},
      {"RobotPrior::robot", "robot"},
      {"SearchSettings::restarts", "restarts"},
      {"SearchSettings::min_noise_fraction", "min_noise"},
      {"SearchSettings::initial_noise_fraction", "initial_noise_fraction"},
      {"SearchSettings::threads", "threads"},
      {"SearchSettings::start_screening_evaluations", "start_screening"},
      {"GpOptions::warm_start_rows", "warm_start_rows"},
      {"LagrangianOptions::warm_start_rows", "warm_start_rows"},
      {"SearchSettings::hyperparameter_rows", "hyperparameter_rows"},
      {"SparseOptions::hyperparameter_objective", "hyperparameter_objective"},
      {"SparseOptions::inducing_points", "inducing"},
      {"TrainOptions::nll_backend", "distributed"},
      {"TeacherOptions::name", "teacher"},
      {"TeacherOptions::states", "teacher_states"},
      {"TeacherOptions::hyperparameter_rows", "teacher_hyperparameter_rows"},
      {"TeacherOptions::student_hyperparameter_rows", "student_hyperparameter_rows"},
      {"SearchSettings::gradient_tolerance_per_row", "gradient_tolerance"},
      {"GpOptions::scaling", "scaling"},
      {"GpOptions::mean", "mean"},
      {"GpOptions::prior", "prior"},
      {"HyperparameterPrior::width", "prior_width"},
      {"OptimizerOptions::kind", "optimizer"},
      {"OptimizerOptions::max_iterations", "max_iter"},
      {"OptimizerOptions::adam_learning_rate", "learning_rate"},
      {"SimulationOptions::samples", "samples"},
      {"SimulationOptions::noise_std", "noise"},
      {"SimulationOptions::dt", "dt"},
      {"SimulationOptions::friction", "friction"},
      {"NeighbourConsistencyOptions::radius", "radius"},
      {"NeighbourConsistencyOptions::joints", "joints"},
      {"NeighbourConsistencyOptions::min_separation_rows", "min_separation_rows"},
      {"NeighbourConsistencyOptions::max_queries", "max_queries"},
      {"SimulatedContacts::count", "contacts"},
      {"SimulatedContacts::size", "contact_size"},
      {"SimulatedContacts::duration", "contact_duration"},
      {"SimulatedContacts::joint", "contact_joint"},
      {"SimulatedContacts::bandwidth", "contact_bandwidth"},
      {"ContactOptions::false_alarm_rate", "false_alarm_rate"},
      {"ContactOptions::min_duration", "min_duration"},
      {"ContactOptions::sample_time", "sample_time"},
      {"ContactOptions::momentum_gain", "momentum_gain"},
      {"ContactDetector::calibrate", "ContactDetector.calibrate(X, tau)"},
      {"LogColumns::qdd", "columns[\"qdd\"]"},
      {"LogColumns::qd", "columns[\"qd\"]"},
      {"LogColumns::q", "columns[\"q\"]"},
      {"LogColumns::tau", "columns[\"tau\"]"},
      {"LogColumns", "read_log(columns=...)"},
      {"EstimatorOptions::name", "model"},
      {"UpdateOptions::refit where-misfit", "partial_fit with refit=None"},
      {"UpdateOptions::refit", "refit"},
      {"UpdateOptions::replace", "window=len(X)"},
      {"UpdateOptions::window", "window"},
      {kMatFileAdvice, "read it with gipdyn.read_log(path, joints, mat_variable=NAME)"},
      {kFewerRowsAdvice, "train on fewer rows (a constant-step subsample: subsample=N)"},
  };
  return names;
}

// The library's convergence warnings, in Python's keywords.
std::vector<std::string> python_convergence_warnings(const std::vector<JointReport>& joints) {
  std::vector<std::string> out = convergence_warnings(joints);
  for (auto& line : out) line = rename_fields(line, python_field_names());
  return out;
}

// predict_one of a trained model, which is read-only and shared: one query
// through the estimator's workspace, made on the first call; the workspace is
// mutable, so calls from several Python threads take turns on it.
class SingleQuery {
 public:
  Eigen::VectorXd predict(const Estimator& estimator, const Eigen::VectorXd& x) {
    const int n = estimator.joints().size();
    if (x.size() != 3 * n) throw Error("x must have " + std::to_string(3 * n) + " entries (q, qd, qdd)");
    std::lock_guard<std::mutex> lock(mutex_);
    if (!workspace_) workspace_ = estimator.make_query_workspace();
    Eigen::VectorXd tau(n);
    workspace_->predict(x.data(), tau.data());
    return tau;
  }

 private:
  std::unique_ptr<QueryWorkspace> workspace_;
  std::mutex mutex_;
};

// A fitted model itself where it has the factors predictive variances need,
// else its copy with them, built on the first request and kept: asking for
// variances changes neither the model nor the Python estimator holding it.
template <class Fitted>
class WithFactors {
 public:
  const Fitted& of(const Fitted& model) const {
    if (model.has_variance()) return model;
    std::lock_guard<std::mutex> lock(mutex_);
    if (!copy_) copy_ = std::make_shared<const Fitted>(model.with_variance());
    return *copy_;
  }

 private:
  mutable std::shared_ptr<const Fitted> copy_;
  mutable std::mutex mutex_;
};

struct Model {
  std::shared_ptr<const GpEstimator> estimator;  // the physics functions take an Estimator
  const InverseDynamicsModel* model;
  SingleQuery query;
  WithFactors<InverseDynamicsModel> factors;
  const InverseDynamicsModel& variance_model() const { return factors.of(*model); }
  explicit Model(InverseDynamicsModel m) : Model(std::make_shared<const GpEstimator>(std::move(m))) {}
  explicit Model(std::shared_ptr<const GpEstimator> e) : estimator(std::move(e)), model(&estimator->model()) {}
};

// A GP model file's estimator, with its teaching record; throws gipdyn::Error for another estimator's file.
std::shared_ptr<Model> gp_model_from_container(const ModelContainer& c, const std::string& what) {
  std::unique_ptr<Estimator> e = estimator_from_container(c, what);
  auto* gp = dynamic_cast<GpEstimator*>(e.get());
  if (!gp)
    throw Error(what + " holds a '" + e->name() + "' model, not a GP kernel's: load it with InverseDynamics.load, "
                "which reads every estimator's file");
  e.release();
  return std::make_shared<Model>(std::shared_ptr<const GpEstimator>(gp));
}

// (rows, n, n) NumPy array of the inertia matrices.
py::array_t<double> stack_matrices(const std::vector<Eigen::MatrixXd>& Ms, int n) {
  py::array_t<double> out({static_cast<py::ssize_t>(Ms.size()), static_cast<py::ssize_t>(n), static_cast<py::ssize_t>(n)});
  auto view = out.mutable_unchecked<3>();
  for (size_t r = 0; r < Ms.size(); ++r)
    for (int i = 0; i < n; ++i)
      for (int j = 0; j < n; ++j) view(static_cast<py::ssize_t>(r), i, j) = Ms[r](i, j);
  return out;
}

// Runs fit(progress) without the GIL; verbose prints a sample of the progress
// and the brief report. A failed fit raises.
template <class Fit>
auto fit_without_gil(bool verbose, Fit&& fit) {
  std::mutex print_mutex;
  ProgressCallback cb;
  if (verbose)
    cb = [&](const ProgressEvent& e) {
      if (!e.finished && e.iteration % 10 != 0) return;
      std::lock_guard<std::mutex> lock(print_mutex);
      std::fprintf(stderr, "  %s\n", describe(e).c_str());
    };
  decltype(fit(cb)) r;
  {
    py::gil_scoped_release release;
    r = fit(cb);
  }
  if (!r.report.ok()) throw Error("training failed: " + r.report.message);
  if (verbose) std::fprintf(stderr, "%s", r.report.brief_report().c_str());
  return r;
}

// A model file's record (teacher, options) as JSON text; '' where the model has none.
std::string record_text(const nlohmann::json* record) { return record ? record->dump() : std::string(); }

// The library's update rule (online_update.hpp): {model, check (its report, or None for a sparse model), refitted}.
py::dict update(const Model& model, ConstRef X, ConstRef Y, Eigen::Index window, bool replace, const std::string& refit,
                const EstimatorOptions& options) {
  UpdateOptions o;
  o.window = window;
  o.replace = replace;
  o.refit = parse_update_refit(refit);
  o.search = options.search;
  const Eigen::MatrixXd Xm = X, Ym = Y;
  UpdateResult r;
  {
    py::gil_scoped_release release;
    r = update_estimator(*model.estimator, Xm, Ym, o);
  }
  auto* gp = dynamic_cast<GpEstimator*>(r.estimator.get());
  if (!gp) throw Error("internal: an update did not give a GP estimator");
  r.estimator.release();
  py::dict d;
  d["model"] = std::make_shared<Model>(std::shared_ptr<const GpEstimator>(gp));
  d["check"] = r.check ? py::cast(r.check->brief_report()) : py::none();
  d["refitted"] = r.refitted;
  d["refit_report"] = r.refit_report ? py::cast(r.refit_report->brief_report()) : py::none();
  return d;
}

// gravity, inertia and velocity_terms for a model class whose `estimator` points to an Estimator.
template <class Holder>
void add_physics_methods(py::class_<Holder, std::shared_ptr<Holder>>& cls) {
  cls.def(
         "gravity",
         [](const Holder& s, ConstRef Q) {
           py::gil_scoped_release release;
           return gravity(*s.estimator, Q);
         },
         py::arg("Q"))
      .def(
          "inertia",
          [](const Holder& s, ConstRef Q, bool symmetric) {
            std::vector<Eigen::MatrixXd> Ms;
            {
              py::gil_scoped_release release;
              Ms = inertia(*s.estimator, Q, symmetric ? InertiaForm::Symmetric : InertiaForm::AsLearned);
            }
            return stack_matrices(Ms, s.estimator->joints().size());
          },
          py::arg("Q"), py::arg("symmetric") = true)
      .def(
          "velocity_terms",
          [](const Holder& s, ConstRef Q, ConstRef QD) {
            py::gil_scoped_release release;
            VelocityTerms t = velocity_terms(*s.estimator, Q, QD);
            return std::make_pair(t.coriolis, t.friction);
          },
          py::arg("Q"), py::arg("QD"));
}

py::list report_to_list(const std::vector<JointReport>& reports) {
  py::list out;
  for (const JointReport& r : reports) {
    py::dict d;
    d["joint"] = r.joint + 1;
    d["status"] = to_string(r.status);
    d["evaluations"] = r.evaluations;
    d["warm_start_evaluations"] = r.warm_start_evaluations;
    d["screening_evaluations"] = r.screening_evaluations;
    d["hyperparameter_rows"] = r.hyperparameter_rows;
    d["nll"] = r.nll;
    d["grad_norm"] = r.grad_norm;
    d["noise_variance"] = r.noise_variance;
    d["noise_share"] = r.noise_share;
    d["jitter"] = r.jitter;
    d["restart_nlls"] = r.restart_nlls;
    d["coupled"] = r.coupled;
    out.append(d);
  }
  return out;
}

// A trained LIP model (read-only) and how it was trained.
struct LagrangianModel {
  std::shared_ptr<const LagrangianEstimator> estimator;
  std::vector<JointReport> report;
  WithFactors<LagrangianEstimator> factors;  // the (N n)^2 factor
  const LagrangianEstimator& variance_estimator() const { return factors.of(*estimator); }
};

std::shared_ptr<LagrangianModel> train_lagrangian(ConstRef X, ConstRef Y, const std::string& joints,
                                                  const EstimatorOptions& options, bool verbose) {
  if (estimator_family(options.name) != EstimatorFamily::Lagrangian)
    throw Error("train_lagrangian fits lip or lip+friction, not '" + options.name + "'");
  const JointTypes jt = JointTypes::parse(joints);
  LagrangianEstimator::FitOutcome r = fit_without_gil(verbose, [&](const ProgressCallback& cb) {
    return LagrangianEstimator::fit(X, Y, jt, options.lagrangian_options(), cb);
  });
  auto m = std::make_shared<LagrangianModel>();
  if (r.estimator) r.estimator->set_options_record(options_record(options));
  m->estimator = std::move(r.estimator);
  m->report = r.report.joints;
  return m;
}

// A LIP model read back from a file or bytes (`what` names the source); throws gipdyn::Error for another estimator's.
std::shared_ptr<LagrangianModel> lagrangian_model_from(std::unique_ptr<Estimator> e, const std::string& what) {
  if (!dynamic_cast<LagrangianEstimator*>(e.get()))
    throw Error(what + " holds a '" + e->name() + "' model, not lip: load it with InverseDynamics.load, which reads "
                "every estimator's file");
  auto m = std::make_shared<LagrangianModel>();
  m->estimator = std::shared_ptr<const LagrangianEstimator>(static_cast<LagrangianEstimator*>(e.release()));
  return m;
}

py::dict teaching_check_to_dict(const TeachingCheck& c, const std::string& teacher) {
  py::dict d;
  d["teacher_nmse"] = c.teacher_nmse;
  d["student_nmse"] = c.student_nmse;
  d["warning"] = c.warning(teacher);
  d["passed"] = c.passed();
  d["teacher_far_ahead"] = c.joints_teacher_far_ahead();
  return d;
}

// InverseDynamicsGP.fit: the library's fit_estimator for a GP kernel, taught or
// not: {model, teaching, teacher (a LagrangianModel when the teacher is lip or
// lip+friction and fitted, else None), teacher_report, label_noise_std,
// teaching_check (None unless a taught model was checked), teaching_failure
// (why the teacher or the student failed, where teaching is "teacher failed"
// or "student failed"; else empty)}.
// What InverseDynamicsGP's fit asks of fit_estimator: its kernel's GP, taught by `teacher` unless none.
EstimatorOptions gp_estimator_options(const EstimatorOptions& options, const std::optional<TeacherOptions>& teacher) {
  require_known_kernel(options.name);  // InverseDynamicsGP takes GP kernels, not every estimator's name
  EstimatorOptions o = options;
  o.teacher = teacher;
  return o;
}

py::dict fit_gp(ConstRef X, ConstRef Y, const std::string& joints, const EstimatorOptions& options,
                const std::optional<TeacherOptions>& teacher, bool verbose) {
  const JointTypes jt = JointTypes::parse(joints);
  const EstimatorOptions o = gp_estimator_options(options, teacher);
  const Eigen::MatrixXd Xm = X, Ym = Y;
  FitResult r = fit_without_gil(verbose, [&](const ProgressCallback& cb) { return fit_estimator(o, Xm, Ym, jt, cb); });
  auto* gp = dynamic_cast<GpEstimator*>(r.estimator.get());
  if (!gp) throw Error("internal: kernel '" + o.name + "' did not give a GP estimator");
  r.estimator.release();
  py::dict d;
  d["model"] = std::make_shared<Model>(std::shared_ptr<const GpEstimator>(gp));
  d["teaching"] = to_string(r.teaching);
  d["label_noise_std"] = r.label_noise_std;
  d["teacher_report"] = r.teacher_report ? report_to_list(r.teacher_report->joints) : py::list();
  d["teacher"] = py::none();
  if (auto* lip = dynamic_cast<LagrangianEstimator*>(r.teacher.get())) {
    auto m = std::make_shared<LagrangianModel>();
    r.teacher.release();
    m->estimator.reset(lip);
    m->report = r.teacher_report->joints;
    d["teacher"] = m;
  }
  d["teaching_check"] = py::none();
  if (r.teaching_check) d["teaching_check"] = teaching_check_to_dict(*r.teaching_check, teacher->name);
  d["teaching_failure"] = r.teaching == TeachingOutcome::StudentFailed ? r.student_failure
                          : r.teaching == TeachingOutcome::TeacherFailed && r.teacher_report ? r.teacher_report->message
                                                                                              : std::string();
  return d;
}

py::dict simulation_to_dict(const SimulationResult& r, int n) {
  py::dict d;
  d["q"] = Eigen::MatrixXd(r.X.leftCols(n));
  d["qd"] = Eigen::MatrixXd(r.X.middleCols(n, n));
  d["qdd"] = Eigen::MatrixXd(r.X.rightCols(n));
  d["X"] = r.X;
  d["tau"] = r.tau;
  d["tau_true"] = r.tau_true;
  if (r.external.size() > 0) d["external"] = r.external;
  d["metadata"] = r.metadata.dump();
  return d;
}

Eigen::MatrixXd batch_inverse_dynamics(const RobotModel& robot, ConstRef q, ConstRef qd, ConstRef qdd, bool friction) {
  const int n = robot.num_joints();
  if (q.cols() != n || qd.cols() != n || qdd.cols() != n || q.rows() != qd.rows() || q.rows() != qdd.rows())
    throw Error("q, qd and qdd must all be (N, " + std::to_string(n) + ") for robot '" + robot.name() + "'");
  Eigen::MatrixXd X(q.rows(), 3 * n);
  X << q, qd, qdd;
  return inverse_dynamics(robot, X, friction);
}

// Options given as strings in Python are parsed by the library's own parsers.
template <class Options, class Enum>
void string_property(py::class_<Options>& cls, const char* name, Enum Options::*field, Enum (*parse)(const std::string&),
                     std::string (*print)(Enum)) {
  cls.def_property(
      name, [field, print](const Options& o) { return print(o.*field); },
      [field, parse](Options& o, const std::string& v) { o.*field = parse(v); });
}

}  // namespace

namespace {

// The robot models: built-in, URDF and JSON, their inverse dynamics and regressor.
void bind_robots(py::module_& m) {
  py::class_<RobotModel, std::shared_ptr<RobotModel>>(m, "Robot")
      .def_static("from_urdf",
                  [](const std::string& p, const std::string& tip) {
                    return std::make_shared<RobotModel>(load_robot_urdf(p, tip));
                  },
                  py::arg("path"), py::arg("tip_link") = "",
                  "A serial robot from a URDF file: the chain to tip_link (needed where the tree branches; the links "
                  "off the chain ride on it rigidly)")
      .def_static("from_json", [](const std::string& p) { return std::make_shared<RobotModel>(load_robot_json(p)); },
                  py::arg("path"), "A robot from a JSON DH description")
      .def_static("load", [](const std::string& s) { return std::make_shared<RobotModel>(load_robot(s)); },
                  py::arg("spec"), "'scara', 'ur10', a .urdf file ('FILE.urdf:LINK': the chain ends at LINK) or a .json file")
      .def_property_readonly("name", &RobotModel::name)
      .def_property_readonly("joint_types", [](const RobotModel& r) { return r.joint_types().str(); })
      .def_property_readonly("num_joints", &RobotModel::num_joints)
      .def_property_readonly("inertial_parameters", &RobotModel::inertial_parameters)
      .def_property_readonly("friction_parameters", &RobotModel::friction_parameters)
      .def(
          "inverse_dynamics",
          [](const RobotModel& r, ConstRef q, ConstRef qd, ConstRef qdd, bool friction) {
            return batch_inverse_dynamics(r, q, qd, qdd, friction);
          },
          py::arg("q"), py::arg("qd"), py::arg("qdd"), py::arg("friction") = false)
      .def(
          "regressor",
          [](const RobotModel& r, const Eigen::VectorXd& q, const Eigen::VectorXd& qd, const Eigen::VectorXd& qdd,
             bool friction) { return regressor(r, q, qd, qdd, friction); },
          py::arg("q"), py::arg("qd"), py::arg("qdd"), py::arg("friction") = false)
      .def("__repr__", [](const RobotModel& r) { return "<gipdyn.Robot '" + r.name() + "' " + r.joint_types().str() + ">"; });
}

// The library's options, presets, version and the MPI backend.
void bind_options(py::module_& m) {
  py::class_<OptimizerOptions>(m, "OptimizerOptions")
      .def(py::init<>())
      .def_property(
          "kind", [](const OptimizerOptions& o) { return to_string(o.kind); },
          [](OptimizerOptions& o, const std::string& v) { o.kind = parse_optimizer(v); })
      .def_readwrite("max_iterations", &OptimizerOptions::max_iterations)
      .def_readwrite("f_relative_tolerance", &OptimizerOptions::f_relative_tolerance)
      .def_readwrite("gradient_tolerance", &OptimizerOptions::gradient_tolerance)
      .def_readwrite("adam_learning_rate", &OptimizerOptions::adam_learning_rate)
      .def_readwrite("lbfgs_memory", &OptimizerOptions::lbfgs_memory)
      .def("validate", &OptimizerOptions::validate);

  py::class_<HyperparameterPrior>(m, "HyperparameterPrior")
      .def(py::init<>())
      .def_readwrite("enabled", &HyperparameterPrior::enabled)
      .def_readwrite("width", &HyperparameterPrior::width)
      .def("validate", &HyperparameterPrior::validate);
  m.def("parse_hyperparameter_prior", &parse_hyperparameter_prior, py::arg("name"), py::arg("width"));
  m.def("preset_names", &preset_names);
  m.attr("NOISE_SHARE_WARNING") = kNoiseShareWarning;
  m.attr("__version__") = version();
  m.def("build_info", [] {
    const BuildInfo info = gipdyn::build_info();
    py::dict d;
    d["version"] = version();
    d["instruction_set"] = info.instruction_set;
    d["eigen_version"] = info.eigen_version;
    d["eigen_simd"] = info.eigen_simd;
    d["eigen_static_align_bytes"] = info.eigen_static_align_bytes;
    d["eigen_heap_align_bytes"] = info.eigen_heap_align_bytes;
    d["running_cpu"] = running_cpu_features();
    d["summary"] = build_summary();
    return d;
  }, "How the library was compiled and where it runs, as a dict: version, instruction_set,\n"
     "eigen_version, eigen_simd, eigen_static_align_bytes, eigen_heap_align_bytes, running_cpu and\n"
     "summary (one line, what `gipdyn --version` prints; put it in bug reports).");
  m.def("preset_max_training_rows", &preset_max_training_rows, py::arg("name"));

  py::class_<NllBackend, std::shared_ptr<NllBackend>>(m, "NllBackend").def("describe", &NllBackend::describe);
#ifdef GIPDYN_HAVE_MPI
  m.attr("has_mpi") = true;
  // One MPI session and one backend per process, made on first use and
  // finalised when the interpreter's process exits.
  static std::shared_ptr<DistributedNll> backend;
  static std::unique_ptr<MpiSession> session;
  auto distributed = [] {
    if (!session) session = std::make_unique<MpiSession>(nullptr, nullptr);
    if (!backend) backend = std::make_shared<DistributedNll>(MPI_COMM_WORLD);
    return backend;
  };
  m.def("distributed_backend", [distributed] { return std::static_pointer_cast<NllBackend>(distributed()); },
        "The MPI + ScaLAPACK backend over every process of the run (initialises MPI)");
  m.def("mpi_rank", [distributed] { return distributed()->rank(); });
  m.def("mpi_size", [distributed] { return distributed()->size(); });
  py::module_::import("atexit").attr("register")(py::cpp_function([] {
    backend.reset();
    session.reset();
  }));
#else
  m.attr("has_mpi") = false;
  auto no_mpi = [] {
    throw Error("distributed training needs gipdyn built with MPI and ScaLAPACK: install libopenmpi-dev "
                "libscalapack-openmpi-dev openmpi-bin and rebuild");
  };
  m.def("distributed_backend", [no_mpi]() -> std::shared_ptr<NllBackend> { no_mpi(); return nullptr; });
  m.def("mpi_rank", [] { return 0; });
  m.def("mpi_size", [] { return 1; });
#endif
}

// The options of a fit, by what they configure (gipdyn/estimators/fit_estimator.hpp).
void bind_estimator_options(py::module_& m) {
  py::class_<SearchSettings>(m, "SearchSettings")
      .def(py::init<>())
      .def_readwrite("optimizer", &SearchSettings::optimizer)
      .def_readwrite("gradient_tolerance_per_row", &SearchSettings::gradient_tolerance_per_row)
      .def_readwrite("restarts", &SearchSettings::restarts)
      .def_readwrite("restart_spread", &SearchSettings::restart_spread)
      .def_readwrite("seed", &SearchSettings::seed)
      .def_readwrite("start_screening_evaluations", &SearchSettings::start_screening_evaluations)
      .def_readwrite("hyperparameter_rows", &SearchSettings::hyperparameter_rows)
      .def_readwrite("initial_noise_fraction", &SearchSettings::initial_noise_fraction)
      .def_readwrite("min_noise_fraction", &SearchSettings::min_noise_fraction)
      .def_readwrite("threads", &SearchSettings::threads)
      .def("restart_count", &SearchSettings::restart_count)
      .def("start_screening_or_default", &SearchSettings::start_screening_or_default)
      .def("validate", &SearchSettings::validate);
  py::class_<GpOptions> gp_options(m, "GpOptions");
  gp_options.def(py::init<>())
      .def_readwrite("prior", &GpOptions::prior)
      .def_readwrite("noise_std_floor", &GpOptions::noise_std_floor)
      .def_readwrite("warm_start_rows", &GpOptions::warm_start_rows)
      .def_readwrite("keep_factor", &GpOptions::keep_factor)
      .def("validate", &GpOptions::validate);
  string_property(gp_options, "scaling", &GpOptions::scaling, &parse_output_scaling, &to_string);
  string_property(gp_options, "mean", &GpOptions::mean, &parse_mean_kind, &to_string);
  py::class_<SparseOptions> sparse_options(m, "SparseOptions");
  sparse_options.def(py::init<>())
      .def_readwrite("inducing_points", &SparseOptions::inducing_points)
      .def("validate", &SparseOptions::validate);
  string_property(sparse_options, "hyperparameter_objective", &SparseOptions::hyperparameter_objective,
                  &parse_hyperparameter_objective, &to_string);
  py::class_<EstimatorOptions>(m, "EstimatorOptions")
      .def(py::init<>())
      .def_readwrite("name", &EstimatorOptions::name)
      .def_readwrite("search", &EstimatorOptions::search)
      .def_readwrite("gp", &EstimatorOptions::gp)
      .def_readwrite("sparse", &EstimatorOptions::sparse)
      .def_readwrite("serial_chain", &EstimatorOptions::serial_chain)
      .def_readwrite("nll_backend", &EstimatorOptions::nll_backend)
      .def_property(
          "robot", [](const EstimatorOptions& o) { return std::const_pointer_cast<RobotModel>(o.robot_prior.robot); },
          [](EstimatorOptions& o, std::shared_ptr<RobotModel> r) { o.robot_prior.robot = std::move(r); })
      .def_property(
          "robot_friction", [](const EstimatorOptions& o) { return o.robot_prior.friction; },
          [](EstimatorOptions& o, bool f) { o.robot_prior.friction = f; })
      .def("set_seed", &EstimatorOptions::set_seed, py::arg("seed"),
           "Seeds every random process of a fit (search, network, chain)")
      .def("validate", &check_estimator_options);
  m.def("preset_options", &preset_options, py::arg("name"),
        "The EstimatorOptions of a named preset (gipdyn/estimators/presets.hpp)");
}

// The fitted GP model: predictions, variances, online updates, model files.
void bind_gp_model(py::module_& m) {
  py::class_<Model, std::shared_ptr<Model>> model_class(m, "Model");
  add_physics_methods(model_class);
  model_class
      .def_property_readonly("joints", [](const Model& s) { return s.model->joints().str(); })
      .def_property_readonly("kernel", [](const Model& s) { return s.model->kernel_name(); })
      .def_property_readonly("num_training_samples", [](const Model& s) { return s.model->num_training_samples(); })
      .def_property_readonly("num_data_rows", [](const Model& s) { return static_cast<long>(s.model->num_data_rows()); })
      .def_property_readonly("is_sparse", [](const Model& s) { return s.model->is_sparse(); })
      .def_property_readonly("has_variance", [](const Model& s) { return s.model->has_variance(); })
      .def("hyperparameters", [](const Model& s, int j) { return s.model->hyperparameters(j); })
      .def("nll", [](const Model& s, int j) { return s.model->joint_gp(j).nll(); })
      .def_property_readonly(
          "training_report", [](const Model& s) { return report_to_list(s.model->training_report()); },
          "How each joint's hyperparameters were found (empty for models saved before it was recorded)")
      .def_property_readonly(
          "convergence_warnings",
          [](const Model& s) { return python_convergence_warnings(s.model->training_report()); },
          "The library's warnings about joints that stopped before converging (FitReport::warnings)")
      .def_property_readonly(
          "noise_warning", [](const Model& s) { return noise_share_warning(s.model->training_report()); },
          "The library's warning about joints whose fit calls most of the torque noise, or '' (FitReport::warnings)")
      .def(
          "with_variance",
          [](const Model& s) {
            py::gil_scoped_release release;
            return std::make_shared<Model>(s.model->with_variance());
          },
          "A copy that has the Cholesky factors for predictive standard deviations")
      .def(
          "predict",
          [](const Model& s, ConstRef X) {
            py::gil_scoped_release release;
            return s.model->predict(X);
          },
          py::arg("X"))
      .def(
          "updated",
          [](const Model& s, ConstRef X, ConstRef Y, Eigen::Index window) {
            py::gil_scoped_release release;
            return std::make_shared<Model>(s.model->updated(X, Y, window));
          },
          py::arg("X"), py::arg("Y"), py::arg("window") = 0,
          "A copy with the rows of (X, Y) added, hyperparameters fixed; window > 0 keeps the newest rows")
      .def(
          "predict_with_std",
          [](const Model& s, ConstRef X) {
            py::gil_scoped_release release;
            Eigen::MatrixXd mean, sd;
            s.variance_model().predict(X, mean, &sd);
            return std::make_pair(mean, sd);
          },
          py::arg("X"))
      .def(
          "predict_one",
          [](Model& s, const Eigen::VectorXd& x) { return s.query.predict(*s.estimator, x); },
          py::arg("x"))
      .def_property_readonly(
          "teaching_record",
          [](const Model& s) { return record_text(s.estimator->teaching_record()); },
          "The model file's teacher block as JSON (docs/model-format.md); '' where no teacher was asked for")
      .def_property_readonly(
          "options_record",
          [](const Model& s) { return record_text(s.estimator->options_record()); },
          "The options it was trained with, the model file's options block as JSON (docs/model-format.md); '' for "
          "a file written before they were recorded")
      .def("save", [](const Model& s, const std::string& path) { save_estimator(*s.estimator, path); })
      .def("to_bytes", [](const Model& s) { return py::bytes(pack_container(estimator_container(*s.estimator))); })
      .def_static("load",
                  [](const std::string& path) {
                    const std::string what = "model file '" + path + "'";
                    return gp_model_from_container(unpack_container(read_model_bytes(path), what), what);
                  })
      .def_static("from_bytes", [](const py::bytes& b) {
        return gp_model_from_container(unpack_container(std::string(b), "pickled model"), "pickled model");
      });
}

// Any estimator's trained model (read-only; the model of the choice by
// evidence among them), plus predict_one's workspace.
struct TrainedModel {
  std::shared_ptr<const Estimator> estimator;
  SingleQuery query;
  explicit TrainedModel(std::shared_ptr<const Estimator> e) : estimator(std::move(e)) {}
};

std::shared_ptr<TrainedModel> trained_model_from(const std::string& bytes, const std::string& what) {
  return std::make_shared<TrainedModel>(estimator_from_container(unpack_container(bytes, what), what));
}

// What fit_estimator or fit_selected_estimator gave, for InverseDynamics.fit: {model, report (the brief
// report), convergence_warnings and noise_warning (the library's, as InverseDynamicsGP's model gives them),
// teaching, selection_report ('' without a choice by evidence)}.
py::dict trained_to_dict(FitResult& r, const std::string& selection_report) {
  py::dict d;
  d["report"] = r.report.brief_report();
  d["convergence_warnings"] = python_convergence_warnings(r.report.joints);
  d["noise_warning"] = noise_share_warning(r.report.joints);
  d["teaching"] = to_string(r.teaching);
  d["selection_report"] = selection_report;
  d["model"] = std::make_shared<TrainedModel>(std::shared_ptr<const Estimator>(std::move(r.estimator)));
  return d;
}

py::dict fit_any(ConstRef X, ConstRef Y, const std::string& joints, const EstimatorOptions& options,
                 const std::optional<TeacherOptions>& teacher, bool verbose) {
  const JointTypes jt = JointTypes::parse(joints);
  EstimatorOptions o = options;
  o.teacher = teacher;
  const Eigen::MatrixXd Xm = X, Ym = Y;
  FitResult r = fit_without_gil(verbose, [&](const ProgressCallback& cb) { return fit_estimator(o, Xm, Ym, jt, cb); });
  return trained_to_dict(r, "");
}

py::dict fit_by_evidence(ConstRef X, ConstRef Y, const std::string& joints, const EstimatorOptions& options,
                         const TeacherOptions& teacher_settings, bool verbose) {
  const JointTypes jt = JointTypes::parse(joints);
  const Eigen::MatrixXd Xm = X, Ym = Y;
  SelectionResult chosen;
  FitResult r = fit_without_gil(verbose, [&](const ProgressCallback& cb) {
    chosen = fit_selected_estimator(options, SelectionOptions{}, Xm, Ym, jt, teacher_settings, cb);
    return std::move(chosen.fit);
  });
  if (verbose) std::fprintf(stderr, "%s", chosen.selection.brief_report().c_str());
  return trained_to_dict(r, chosen.selection.brief_report());
}

void bind_trained_model(py::module_& m) {
  py::class_<TrainedModel, std::shared_ptr<TrainedModel>> cls(m, "TrainedModel");
  add_physics_methods(cls);
  cls.def_property_readonly("name", [](const TrainedModel& s) { return s.estimator->name(); })
      .def_property_readonly("joints", [](const TrainedModel& s) { return s.estimator->joints().str(); })
      .def_property_readonly("gives_rigid_body_terms",
                             [](const TrainedModel& s) { return s.estimator->gives_rigid_body_terms(); })
      .def_property_readonly("summary", [](const TrainedModel& s) { return s.estimator->summary().dump(); },
                             "The estimator's summary as JSON (what `gipdyn inspect` shows)")
      .def_property_readonly(
          "selection_record", [](const TrainedModel& s) { return record_text(s.estimator->selection_record()); },
          "The model file's selection block as JSON (docs/model-format.md); '' where no choice by evidence made it")
      .def_property_readonly(
          "teaching_record", [](const TrainedModel& s) { return record_text(s.estimator->teaching_record()); },
          "The model file's teacher block as JSON; '' where no teacher was asked for")
      .def_property_readonly(
          "options_record", [](const TrainedModel& s) { return record_text(s.estimator->options_record()); },
          "The options it was trained with, the model file's options block as JSON; '' where the file has none")
      .def(
          "predict",
          [](const TrainedModel& s, ConstRef X) {
            py::gil_scoped_release release;
            return s.estimator->predict(X);
          },
          py::arg("X"))
      .def(
          "predict_one",
          [](TrainedModel& s, const Eigen::VectorXd& x) { return s.query.predict(*s.estimator, x); },
          py::arg("x"))
      .def("save", [](const TrainedModel& s, const std::string& path) { save_estimator(*s.estimator, path); })
      .def("to_bytes",
           [](const TrainedModel& s) { return py::bytes(pack_container(estimator_container(*s.estimator))); })
      .def_static("load",
                  [](const std::string& path) {
                    return trained_model_from(read_model_bytes(path), "model file '" + path + "'");
                  })
      .def_static("from_bytes",
                  [](const py::bytes& b) { return trained_model_from(std::string(b), "pickled model"); });
  m.def("fit_any", &fit_any, py::arg("X"), py::arg("Y"), py::arg("joints"), py::arg("options"), py::arg("teacher"),
        py::arg("verbose") = false,
        "Fits any estimator of the table (options.name), taught by `teacher` unless None "
        "(gipdyn/estimators/fit_estimator.hpp): {model, report, convergence_warnings, noise_warning, teaching, "
        "selection_report}");
  m.def("fit_by_evidence", &fit_by_evidence, py::arg("X"), py::arg("Y"), py::arg("joints"), py::arg("options"),
        py::arg("teacher_settings"), py::arg("verbose") = false,
        "The choice by evidence (gipdyn/estimators/model_selection.hpp) over the shared options: "
        "{model, report, convergence_warnings, noise_warning, teaching, selection_report}");
}

// The fitted LIP model and its training.
void bind_lagrangian_model(py::module_& m) {
  py::class_<LagrangianModel, std::shared_ptr<LagrangianModel>> lagrangian_class(m, "LagrangianModel");
  add_physics_methods(lagrangian_class);
  lagrangian_class
      .def_property_readonly("joints", [](const LagrangianModel& s) { return s.estimator->joints().str(); })
      .def_property_readonly("estimator", [](const LagrangianModel& s) { return s.estimator->name(); })
      .def_property_readonly("options_record",
                             [](const LagrangianModel& s) { return record_text(s.estimator->options_record()); },
                             "As Model.options_record")
      .def_property_readonly("num_training_samples",
                             [](const LagrangianModel& s) { return s.estimator->training_inputs().rows(); })
      .def_property_readonly("noise_variances", [](const LagrangianModel& s) { return s.estimator->noise_variances(); })
      .def_property_readonly("hyperparameters",
                             [](const LagrangianModel& s) {
                               py::dict d;
                               // Named: a range-for over a temporary's member would read a destroyed object.
                               const nlohmann::json summary = s.estimator->summary();
                               for (const auto& [name, value] : summary.at("hyperparameters").items())
                                 d[py::str(name)] = value.get<double>();
                               return d;
                             })
      .def_property_readonly("training_report", [](const LagrangianModel& s) { return report_to_list(s.report); })
      .def_property_readonly("convergence_warnings",
                             [](const LagrangianModel& s) { return python_convergence_warnings(s.report); })
      .def_property_readonly("noise_warning", [](const LagrangianModel& s) { return noise_share_warning(s.report); })
      .def(
          "predict",
          [](const LagrangianModel& s, ConstRef X) {
            py::gil_scoped_release release;
            return s.estimator->predict(X);
          },
          py::arg("X"))
      .def_property_readonly("has_variance", [](const LagrangianModel& s) { return s.estimator->has_variance(); })
      .def(
          "with_variance",
          [](const LagrangianModel& s) {
            auto m = std::make_shared<LagrangianModel>();
            {
              py::gil_scoped_release release;
              m->estimator = std::make_shared<const LagrangianEstimator>(s.estimator->with_variance());
            }
            m->report = s.report;
            return m;
          })
      .def(
          "predict_std",
          [](const LagrangianModel& s, ConstRef X) {
            py::gil_scoped_release release;
            return s.variance_estimator().predict_std(X);
          },
          py::arg("X"))
      .def(
          "kinetic_energy",
          [](const LagrangianModel& s, ConstRef X) {
            py::gil_scoped_release release;
            return s.estimator->kinetic_energy(X);
          },
          py::arg("X"))
      .def(
          "potential_energy",
          [](const LagrangianModel& s, ConstRef Q) {
            py::gil_scoped_release release;
            return s.estimator->potential_energy(Q);
          },
          py::arg("Q"))
      .def("save", [](const LagrangianModel& s, const std::string& path) { save_estimator(*s.estimator, path); })
      .def("to_bytes", [](const LagrangianModel& s) { return py::bytes(pack_container(estimator_container(*s.estimator))); })
      .def_static("load",
                  [](const std::string& path) {
                    const std::string what = "model file '" + path + "'";
                    return lagrangian_model_from(load_estimator(path), what);
                  })
      .def_static("from_bytes", [](const py::bytes& b) {
        return lagrangian_model_from(estimator_from_container(unpack_container(std::string(b), "pickled model"), "pickled model"),
                                     "pickled model");
      });
  m.def("train_lagrangian", &train_lagrangian, py::arg("X"), py::arg("Y"), py::arg("joints"), py::arg("options"),
        py::arg("verbose") = false);
}

// Fitting: teachers, the estimator table, the fit and its warnings.
void bind_fitting(py::module_& m) {
  py::enum_<TeachingMode>(m, "TeachingMode")
      .value("always", TeachingMode::Always)
      .value("automatic", TeachingMode::Automatic);
  py::class_<TeacherOptions>(m, "TeacherOptions")
      .def(py::init<>())
      .def_readwrite("mode", &TeacherOptions::mode)
      .def_readwrite("automatic_max_log_values", &TeacherOptions::automatic_max_log_values)
      .def_readwrite("name", &TeacherOptions::name)
      .def_readwrite("states", &TeacherOptions::states)
      .def_readwrite("hyperparameter_rows", &TeacherOptions::hyperparameter_rows)
      .def_readwrite("student_hyperparameter_rows", &TeacherOptions::student_hyperparameter_rows)
      .def_readwrite("seed", &TeacherOptions::seed)
      .def("validate", &TeacherOptions::validate);
  m.def(
      "exact_hyperparameter_rows",
      [](const EstimatorOptions& options, const std::optional<TeacherOptions>& teacher, Eigen::Index rows, int joints) {
        return exact_hyperparameter_rows(gp_estimator_options(options, teacher), rows, joints);
      },
      py::arg("options"), py::arg("teacher"), py::arg("rows"), py::arg("joints"),
      "The rows fit's exact GP learns its hyperparameters on, or 0 where no O(rows^3) factorisation sets the time "
      "(gipdyn/estimators/fit_estimator.hpp)");
  m.def("long_exact_fit_warning", &long_exact_fit_warning, py::arg("rows"),
        "What an exact GP's hyperparameter fit on this many rows costs; \"\" below 8000 rows");
  m.def("fit", &fit_gp, py::arg("X"), py::arg("Y"), py::arg("joints"), py::arg("options"), py::arg("teacher"),
        py::arg("verbose") = false,
        "Fits a GP estimator (options.name), taught by `teacher` unless None (gipdyn/estimators/fit_estimator.hpp): "
        "{model, teaching, teacher, teacher_report, label_noise_std, teaching_check}");
  m.def("update", &update, py::arg("model"), py::arg("X"), py::arg("Y"), py::arg("window"), py::arg("replace"),
        py::arg("refit"), py::arg("options"),
        "The library's update rule (gipdyn/estimators/online_update.hpp): {model, check, refitted, refit_report}");
  m.def(
      "training_input_warnings",
      [](ConstRef X, const std::string& joints, const std::string& source) {
        return training_input_warnings(X, JointTypes::parse(joints), source);
      },
      py::arg("X"), py::arg("joints"), py::arg("source"),
      "One line per problem of the training inputs: joints that never move, constant columns, revolute positions "
      "spanning more than two turns (usually a log in degrees)");
  m.def("kernel_names", &kernel_names, "The per-joint GP kernels, in the library's table order");
  m.def("estimator_names", &estimator_names, "Every estimator, in the library's table order");
  m.def(
      "lagrangian_estimator_name",
      [](bool friction) { return estimator_name(EstimatorFamily::Lagrangian, &EstimatorSpec::friction, friction); },
      py::arg("friction"), "The LIP estimator's name, with or without friction");
  m.def("default_teacher_name", &default_teacher_name, "The estimator that teaches by default (teacher=\"auto\")");
  m.def("joint_column_names", [](const std::string& prefix, int joints) { return joint_column_names(prefix, joints); },
        py::arg("prefix"), py::arg("joints"), "The log format's column names of a quantity: q1..qn for prefix q");
  m.def("automatic_estimator_name", [] { return std::string(kAutomaticEstimator); },
        "The name under which front ends choose the estimator by evidence (model_selection.hpp)");
  m.def(
      "choose_teacher",
      [](const std::string& choice, const EstimatorOptions& options, const TeacherOptions& settings,
         bool any_estimator) {
        return choose_teacher(choice, any_estimator ? options : gp_estimator_options(options, std::nullopt), settings);
      },
      py::arg("choice"), py::arg("options"), py::arg("settings"), py::arg("any_estimator") = false,
      "The library's rule (gipdyn/estimators/fit_estimator.hpp): the TeacherOptions a fit of these options gets "
      "for teacher=choice (\"auto\", \"none\" or an estimator's name), or None");
  m.def("estimator_search", &estimator_search, py::arg("name"), py::arg("search"),
        "The search a fit of estimator `name` runs: `search` with the starts it leaves unset (restarts, "
        "restart_spread, start_screening_evaluations) from the estimator table");
  m.def("restart_defaults_summary", &restart_defaults_summary,
        "Each estimator's own restarts where it has some, for help text: \"rbf 10 at spread 2; the others none\"");
  m.def("start_screening_defaults_summary", &start_screening_defaults_summary,
        "Each kernel method's own start screening where it differs from the default, for help text");
  m.def(
      "estimator_table",
      [] {
        py::list rows;
        for (const EstimatorSpec& e : estimator_table()) {
          py::dict d;
          d["name"] = e.name;
          d["help"] = e.help;
          d["gp_kernel"] = e.family == EstimatorFamily::Gp;
          d["needs_robot"] = e.needs_robot;
          d["friction"] = e.friction;
          d["rigid_body_terms"] = e.rigid_body_terms;
          d["default"] = e.default_estimator;
          d["default_teacher"] = e.default_teacher;
          d["restarts"] = e.restarts;
          d["restart_spread"] = e.restart_spread;
          d["start_screening"] = e.start_screening_evaluations;
          rows.append(d);
        }
        return rows;
      },
      "The library's table of estimators: one dict per estimator (name, help, gp_kernel, needs_robot, friction, "
      "rigid_body_terms, default, default_teacher, restarts, restart_spread, start_screening)");
}

// Logs: consistency checks, reading, simulation.
void bind_data(py::module_& m) {
  py::class_<NeighbourConsistencyOptions>(m, "NeighbourConsistencyOptions")
      .def(py::init<>())
      .def_readwrite("radius", &NeighbourConsistencyOptions::radius)
      .def_readwrite("joints", &NeighbourConsistencyOptions::joints)
      .def_readwrite("min_separation_rows", &NeighbourConsistencyOptions::min_separation_rows)
      .def_readwrite("use_accelerations", &NeighbourConsistencyOptions::use_accelerations)
      .def_readwrite("max_queries", &NeighbourConsistencyOptions::max_queries)
      .def_readwrite("min_pairs", &NeighbourConsistencyOptions::min_pairs);
  auto consistency_to_dict = [](const NeighbourConsistency& c) {
    py::dict d;
    d["status"] = to_string(c.status);
    d["message"] = rename_fields(c.message, python_field_names());
    d["queries"] = c.queries;
    d["pairs"] = c.pairs;
    d["neighbour_nmse"] = Eigen::VectorXd(c.neighbour_nmse);
    d["correlation"] = Eigen::VectorXd(c.correlation);
    return d;
  };
  m.def(
      "neighbour_consistency",
      [consistency_to_dict](const Eigen::MatrixXd& X, const Eigen::MatrixXd& tau, const NeighbourConsistencyOptions& o) {
        return consistency_to_dict(neighbour_consistency(X, tau, o));
      },
      py::arg("X"), py::arg("tau"), py::arg("options"));
  m.def(
      "neighbour_consistency",
      [consistency_to_dict](const Eigen::MatrixXd& X, const Eigen::MatrixXd& tau, const Eigen::MatrixXd& X_test,
                            const Eigen::MatrixXd& tau_test, const NeighbourConsistencyOptions& o) {
        return consistency_to_dict(neighbour_consistency(X, tau, X_test, tau_test, o));
      },
      py::arg("X"), py::arg("tau"), py::arg("X_test"), py::arg("tau_test"), py::arg("options"));

  m.def(
      "read_log",
      [](const std::string& path, const std::string& joints, const std::string& mat_variable, bool require_tau,
         const std::string& columns) {
        const JointTypes types = JointTypes::parse(joints);
        const LogColumns log_columns = parse_log_columns(columns);
        Dataset d;
        {
          py::gil_scoped_release release;
          d = read_robot_log(path, mat_variable, types, require_tau, "", log_columns);
        }
        const int n = types.size();
        py::dict out;
        out["q"] = Eigen::MatrixXd(d.X.leftCols(n));
        out["qd"] = Eigen::MatrixXd(d.X.middleCols(n, n));
        out["qdd"] = Eigen::MatrixXd(d.X.rightCols(n));
        out["X"] = d.X;
        out["tau"] = d.tau.size() ? py::cast(d.tau) : py::none();
        out["tau_true"] = d.tau_true.size() ? py::cast(d.tau_true) : py::none();
        out["joints"] = types.str();
        return out;
      },
      py::arg("path"), py::arg("joints"), py::arg("mat_variable") = "", py::arg("require_tau") = true,
      py::arg("columns") = "");
  m.def(
      "sidecar_joint_types",
      [](const std::string& path) -> std::optional<std::string> {
        if (const std::optional<JointTypes> t = sidecar_joint_types(path)) return t->str();
        return std::nullopt;
      },
      py::arg("path"),
      "The joint types the log's PATH.json sidecar records (gipdyn simulate writes them), or None "
      "(gipdyn/io/dataset.hpp)");

  py::class_<SimulationOptions>(m, "SimulationOptions")
      .def(py::init<>())
      .def_readwrite("samples", &SimulationOptions::samples)
      .def_readwrite("seed", &SimulationOptions::seed)
      .def_readwrite("noise_std", &SimulationOptions::noise_std)
      .def_readwrite("dt", &SimulationOptions::dt)
      .def_readwrite("perturb_kinematics", &SimulationOptions::perturb_kinematics)
      .def_readwrite("friction", &SimulationOptions::friction)
      .def_readwrite("contacts", &SimulationOptions::contacts);
  py::class_<SimulatedContacts>(m, "SimulatedContacts")
      .def(py::init<>())
      .def_readwrite("count", &SimulatedContacts::count)
      .def_readwrite("size", &SimulatedContacts::size)
      .def_readwrite("duration", &SimulatedContacts::duration)
      .def_readwrite("joint", &SimulatedContacts::joint)
      .def_readwrite("bandwidth", &SimulatedContacts::bandwidth);
  m.def(
      "simulate",
      [](const RobotModel& robot, const SimulationOptions& o) {
        SimulationResult r;
        {
          py::gil_scoped_release release;
          r = simulate(robot, o);
        }
        return simulation_to_dict(r, robot.num_joints());
      },
      py::arg("robot"), py::arg("options"));
}

// A detector over a fitted model, which it keeps alive.
struct PyContactDetector {
  std::shared_ptr<const Estimator> estimator;
  ContactDetector detector;
  PyContactDetector(std::shared_ptr<const Estimator> e, const ContactOptions& o)
      : estimator(std::move(e)), detector(*estimator, o) {}
};

void bind_contact_detection(py::module_& m) {
  py::class_<ContactOptions> options(m, "ContactOptions");
  options.def(py::init<>())
      .def_readwrite("false_alarm_rate", &ContactOptions::false_alarm_rate)
      .def_readwrite("min_duration", &ContactOptions::min_duration)
      .def_readwrite("sample_time", &ContactOptions::sample_time)
      .def_readwrite("momentum_gain", &ContactOptions::momentum_gain)
      .def_readwrite("predictive_variance", &ContactOptions::predictive_variance)
      .def("validate", &ContactOptions::validate)
      .def("threshold_factor", &ContactOptions::threshold_factor)
      .def("observer_gain", &ContactOptions::observer_gain);
  string_property(options, "method", &ContactOptions::method, &parse_contact_method,
                  static_cast<std::string (*)(ContactMethod)>(&to_string));
  py::class_<ContactDetection>(m, "ContactDetection")
      .def_property_readonly("method", [](const ContactDetection& d) { return to_string(d.method); })
      .def_readonly("external_torque", &ContactDetection::external_torque)
      .def_readonly("threshold", &ContactDetection::threshold)
      .def_readonly("contact", &ContactDetection::contact)
      .def_readonly("margin", &ContactDetection::margin)
      .def_readonly("threshold_factor", &ContactDetection::threshold_factor)
      .def_readonly("noise_source", &ContactDetection::noise_source)
      .def_readonly("noise_std", &ContactDetection::noise_std)
      .def_readonly("contact_count", &ContactDetection::contact_count)
      .def("brief_report", &ContactDetection::brief_report)
      .def("__repr__", [](const ContactDetection& d) { return "<ContactDetection\n" + d.brief_report() + ">"; });
  py::class_<ContactScore>(m, "ContactScore")
      .def_readonly("contacts", &ContactScore::contacts)
      .def_readonly("detected", &ContactScore::detected)
      .def_readonly("mean_delay", &ContactScore::mean_delay)
      .def_readonly("max_delay", &ContactScore::max_delay)
      .def_readonly("false_alarms", &ContactScore::false_alarms)
      .def_readonly("contact_free_seconds", &ContactScore::contact_free_seconds)
      .def_readonly("torque_error", &ContactScore::torque_error)
      .def_property_readonly("detection_rate", &ContactScore::detection_rate)
      .def_property_readonly("false_alarms_per_minute", &ContactScore::false_alarms_per_minute);
  m.def("score_contacts", &score_contacts, py::arg("detection"), py::arg("true_external"), py::arg("sample_time"));
  py::class_<PyContactDetector, std::shared_ptr<PyContactDetector>>(m, "ContactDetector")
      .def(py::init([](const Model& model, const ContactOptions& o) {
             py::gil_scoped_release release;  // a loaded model's factors are computed here
             return std::make_shared<PyContactDetector>(model.estimator, o);
           }),
           py::arg("model"), py::arg("options"))
      .def(py::init([](const LagrangianModel& model, const ContactOptions& o) {
             py::gil_scoped_release release;
             return std::make_shared<PyContactDetector>(model.estimator, o);
           }),
           py::arg("model"), py::arg("options"))
      .def(py::init([](const TrainedModel& model, const ContactOptions& o) {
             py::gil_scoped_release release;
             return std::make_shared<PyContactDetector>(model.estimator, o);
           }),
           py::arg("model"), py::arg("options"))
      .def(
          "calibrate",
          [](PyContactDetector& s, ConstRef X, ConstRef tau) {
            py::gil_scoped_release release;
            s.detector.calibrate(X, tau);
          },
          py::arg("X"), py::arg("tau"))
      .def_property_readonly("calibrated", [](const PyContactDetector& s) { return s.detector.calibrated(); })
      .def(
          "detect",
          [](const PyContactDetector& s, ConstRef X, ConstRef tau) {
            py::gil_scoped_release release;
            return s.detector.detect(X, tau);
          },
          py::arg("X"), py::arg("tau"))
      .def(
          "external_torque",
          [](const PyContactDetector& s, ConstRef X, ConstRef tau) {
            py::gil_scoped_release release;
            return s.detector.external_torque(X, tau);
          },
          py::arg("X"), py::arg("tau"));
}

}  // namespace

PYBIND11_MODULE(_core, m) {
  m.doc() = "gipdyn C++ core: GP inverse dynamics with the GIP kernel";
  static py::exception<Error> gipdyn_error(m, "GipdynError", PyExc_ValueError);
  py::register_exception_translator([](std::exception_ptr p) {
    try {
      if (p) std::rethrow_exception(p);
    } catch (const Error& e) {
      gipdyn_error(rename_fields(e.what(), python_field_names()).c_str());
    }
  });

  bind_robots(m);
  bind_options(m);
  bind_estimator_options(m);
  bind_gp_model(m);
  bind_lagrangian_model(m);
  bind_trained_model(m);
  bind_fitting(m);
  bind_data(m);
  bind_contact_detection(m);
}
