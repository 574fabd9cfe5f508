// The gipdyn._core extension: thin bindings over the C++ library. The
// scikit-learn-style estimator lives in Python (gipdyn/__init__.py).
#include <pybind11/eigen.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <memory>
#include <mutex>
#include <nlohmann/json.hpp>

#include "gipdyn/error.hpp"
#include "gipdyn/io/model_file.hpp"
#include "gipdyn/kernels/kernel_factory.hpp"
#include "gipdyn/metrics.hpp"
#include "gipdyn/model/training.hpp"
#include "gipdyn/robot/dynamics.hpp"
#include "gipdyn/robot/robot_loader.hpp"
#include "gipdyn/sim/simulate.hpp"

namespace py = pybind11;
using namespace gipdyn;
using ConstRef = Eigen::Ref<const Eigen::MatrixXd>;

namespace {

// A trained model plus a lazily built single-query workspace.
struct Model {
  InverseDynamicsModel model;
  std::unique_ptr<PredictionWorkspace> workspace;
  std::mutex mutex;
  explicit Model(InverseDynamicsModel m) : model(std::move(m)) {}
};

std::shared_ptr<Model> train(ConstRef X, ConstRef Y, const std::string& joints, const std::string& kernel,
                             const std::string& optimizer, int max_iter, int restarts, std::uint64_t seed,
                             const std::string& scaling, double min_noise, int threads, double learning_rate,
                             bool verbose, const std::string& robot, bool robot_friction, const std::string& mean,
                             const std::string& prior, double prior_width) {
  TrainOptions o;
  o.kernel = kernel;
  if (!robot.empty()) o.robot_prior = {std::make_shared<const RobotModel>(load_robot(robot)), robot_friction};
  o.optimizer.kind = parse_optimizer(optimizer);
  o.optimizer.max_iterations = max_iter;
  o.optimizer.adam_learning_rate = learning_rate;
  o.restarts = restarts;
  o.seed = seed;
  o.scaling = parse_output_scaling(scaling);
  o.mean = parse_mean_kind(mean);
  if (prior != "none" && prior != "lognormal") throw Error("prior must be 'none' or 'lognormal', not '" + prior + "'");
  o.prior.enabled = prior == "lognormal";
  o.prior.width = prior_width;
  o.min_noise_fraction = min_noise;
  o.threads = threads;
  const JointTypes jt = JointTypes::parse(joints);
  std::mutex print_mutex;
  TrainingCallback cb;
  if (verbose)
    cb = [&](const TrainingProgress& p) {
      if (!p.finished && p.iteration % 10 != 0) return;
      std::lock_guard<std::mutex> lock(print_mutex);
      std::fprintf(stderr, "  joint %d %s eval %d NLL %.6g (%.1f s)\n", p.joint + 1, p.finished ? "done" : "", p.iteration,
                   p.nll, p.seconds);
    };
  TrainResult r;
  {
    py::gil_scoped_release release;
    r = train_model(X, Y, jt, o, cb);
  }
  if (!r.ok) throw Error("training failed: " + r.message);
  return std::make_shared<Model>(std::move(r.model));
}

py::dict simulation_to_dict(const SimulationResult& r, int n) {
  py::dict d;
  d["q"] = Eigen::MatrixXd(r.X.leftCols(n));
  d["qd"] = Eigen::MatrixXd(r.X.middleCols(n, n));
  d["qdd"] = Eigen::MatrixXd(r.X.rightCols(n));
  d["X"] = r.X;
  d["tau"] = r.tau;
  d["tau_true"] = r.tau_true;
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

}  // namespace

PYBIND11_MODULE(_core, m) {
  m.doc() = "gipdyn C++ core: GP inverse dynamics with the GIP kernel";
  py::register_exception<Error>(m, "GipdynError", PyExc_ValueError);

  py::class_<Model, std::shared_ptr<Model>>(m, "Model")
      .def_property_readonly("joints", [](const Model& s) { return s.model.joints().str(); })
      .def_property_readonly("kernel", [](const Model& s) { return s.model.kernel_name(); })
      .def_property_readonly("num_training_samples", [](const Model& s) { return s.model.num_training_samples(); })
      .def("hyperparameters", [](const Model& s, int j) { return s.model.hyperparameters(j); })
      .def("nll", [](const Model& s, int j) { return s.model.joint_gp(j).nll(); })
      .def(
          "predict",
          [](const Model& s, ConstRef X) {
            py::gil_scoped_release release;
            return s.model.predict(X);
          },
          py::arg("X"))
      .def(
          "predict_with_std",
          [](Model& s, ConstRef X) {
            py::gil_scoped_release release;
            std::lock_guard<std::mutex> lock(s.mutex);  // enable_variance mutates once
            s.model.enable_variance();
            Eigen::MatrixXd mean, sd;
            s.model.predict(X, mean, &sd);
            return std::make_pair(mean, sd);
          },
          py::arg("X"))
      .def(
          "predict_one",
          [](Model& s, const Eigen::VectorXd& x) {
            if (x.size() != 3 * s.model.num_joints())
              throw Error("x must have " + std::to_string(3 * s.model.num_joints()) + " entries (q, qd, qdd)");
            std::lock_guard<std::mutex> lock(s.mutex);
            if (!s.workspace) s.workspace = std::make_unique<PredictionWorkspace>(s.model);
            Eigen::VectorXd tau(s.model.num_joints());
            s.workspace->predict(x.data(), tau.data());
            return tau;
          },
          py::arg("x"))
      .def("save", [](const Model& s, const std::string& path) { save_model(s.model, path); })
      .def("to_bytes", [](const Model& s) { return py::bytes(serialize_model(s.model)); })
      .def_static("load", [](const std::string& path) { return std::make_shared<Model>(load_model(path)); })
      .def_static("from_bytes", [](const py::bytes& b) {
        return std::make_shared<Model>(deserialize_model(std::string(b), "pickled model"));
      });

  m.def("train", &train, py::arg("X"), py::arg("Y"), py::arg("joints"), py::arg("kernel"), py::arg("optimizer"),
        py::arg("max_iter"), py::arg("restarts"), py::arg("seed"), py::arg("scaling"), py::arg("min_noise"),
        py::arg("threads"), py::arg("learning_rate"), py::arg("verbose"), py::arg("robot") = "",
        py::arg("robot_friction") = false, py::arg("mean") = "zero", py::arg("prior") = "none",
        py::arg("prior_width") = 2.0);
  m.def("kernel_names", &kernel_names);

  py::class_<RobotModel>(m, "Robot")
      .def_static("from_urdf", &load_robot_urdf, py::arg("path"), "A serial robot from a URDF file")
      .def_static("from_json", &load_robot_json, py::arg("path"), "A robot from a JSON DH description")
      .def_static("load", &load_robot, py::arg("spec"), "'scara', 'ur10', a .urdf or a .json file")
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

  m.def(
      "simulate",
      [](const RobotModel& robot, int samples, std::uint64_t seed, double noise, double dt, bool perturb, bool friction) {
        SimulationOptions o;
        o.samples = samples;
        o.seed = seed;
        o.noise_std = noise;
        o.dt = dt;
        o.perturb_kinematics = perturb;
        o.friction = friction;
        SimulationResult r;
        {
          py::gil_scoped_release release;
          r = simulate(robot, o);
        }
        return simulation_to_dict(r, robot.num_joints());
      },
      py::arg("robot"), py::arg("samples"), py::arg("seed"), py::arg("noise"), py::arg("dt"),
      py::arg("perturb_kinematics"), py::arg("friction"));
}
