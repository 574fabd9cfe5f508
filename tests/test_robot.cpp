// Robot models and rigid-body dynamics: our regressor against KDL's RNEA, KDL's
// RNEA against an energy balance, base parameters, trajectories, simulation and
// bad robot descriptions.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <kdl/chainfksolvervel_recursive.hpp>
#include <kdl/chainidsolver_recursive_newton_euler.hpp>
#include <kdl/treeidsolver_recursive_newton_euler.hpp>
#include <kdl_parser/kdl_parser.hpp>
#include <map>
#include <random>

#include "gipdyn/error.hpp"
#include "gipdyn/robot/dynamics.hpp"
#include "gipdyn/robot/robot_loader.hpp"
#include "gipdyn/sim/simulate.hpp"
#include "test_util.hpp"

#ifndef GIPDYN_TEST_DATA
#error "GIPDYN_TEST_DATA must point to tests/data"
#endif

namespace gipdyn {
namespace {

using test::error_of;
const std::string kData = GIPDYN_TEST_DATA;

std::vector<RobotModel> test_robots() {
  return {scara_robot(), ur10_robot(), load_robot_urdf(kData + "/rpr_arm.urdf"),
          load_robot_json(kData + "/two_link.json"), load_robot_json(kData + "/../../examples/robots/puma560.json"),
          load_robot_json(kData + "/../../examples/robots/arm7.json"),
          load_robot_json(kData + "/../../examples/robots/cylindrical_rpr.json"),
          load_robot_urdf(kData + "/../../examples/robots/panda_like.urdf")};
}

// A random state within the joint limits.
void random_state(const RobotModel& r, std::mt19937_64& rng, Eigen::VectorXd& q, Eigen::VectorXd& qd,
                  Eigen::VectorXd& qdd) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  const int n = r.num_joints();
  q.resize(n);
  qd.resize(n);
  qdd.resize(n);
  for (int i = 0; i < n; ++i) {
    const JointLimits& l = r.joint(i).limits;
    q(i) = 0.5 * (l.lower + l.upper) + 0.5 * (l.upper - l.lower) * u(rng);
    qd(i) = l.velocity * u(rng);
    qdd(i) = 5.0 * u(rng);
  }
}

TEST(Robots, JointTypesAndSizes) {
  EXPECT_EQ(scara_robot().joint_types().str(), "RRPR");
  EXPECT_EQ(ur10_robot().joint_types().str(), "RRRRRR");
  const RobotModel urdf = load_robot_urdf(kData + "/rpr_arm.urdf");
  EXPECT_EQ(urdf.joint_types().str(), "RPR");  // fixed joints merged away
  EXPECT_EQ(urdf.joint(0).name, "j1");
  EXPECT_DOUBLE_EQ(urdf.joint(1).limits.upper, 0.25);
  EXPECT_DOUBLE_EQ(urdf.joint(0).friction.coulomb, 0.8);
  EXPECT_EQ(ur10_robot().inertial_parameters()(10), 12.7);  // mass of link 2 from UR's table
  EXPECT_EQ(load_robot("scara").name(), "scara");
}

TEST(Urdf, LinksOffTheChainRideOnItAsKdlsTreeDynamicsSay) {
  // A camera on l1 and a two-finger gripper on the tool: the chain ends at "tool" and the rest rides on it,
  // fingers closed. KDL's inverse dynamics of the whole tree, fingers held at zero, is the reference.
  const std::string file = kData + "/gripper_arm.urdf";
  const RobotModel arm = load_robot(file + ":tool");
  ASSERT_EQ(arm.joint_types().str(), "RPR");
  KDL::Tree tree;
  ASSERT_TRUE(kdl_parser::treeFromFile(file, tree));
  std::map<std::string, unsigned> index;  // joint name -> KDL's joint number
  for (const auto& [name, element] : tree.getSegments()) {
    const KDL::Joint& j = GetTreeElementSegment(element).getJoint();
    if (j.getType() != KDL::Joint::None) index[j.getName()] = GetTreeElementQNr(element);
  }
  ASSERT_EQ(index.size(), 5u);
  KDL::TreeIdSolver_RNE solver(tree, KDL::Vector(0, 0, -9.81));
  std::mt19937_64 rng(61);
  const RobotModel plain = load_robot_urdf(kData + "/rpr_arm.urdf");  // the same chain without the extra links
  double plain_difference = 0.0;
  for (int trial = 0; trial < 20; ++trial) {
    Eigen::VectorXd q, qd, qdd;
    random_state(arm, rng, q, qd, qdd);
    KDL::JntArray kq(tree.getNrOfJoints()), kqd(tree.getNrOfJoints()), kqdd(tree.getNrOfJoints()),
        torque(tree.getNrOfJoints());
    const char* names[] = {"j1", "j2", "j3"};
    for (int i = 0; i < 3; ++i) {
      kq(index.at(names[i])) = q(i);
      kqd(index.at(names[i])) = qd(i);
      kqdd(index.at(names[i])) = qdd(i);
    }
    ASSERT_EQ(solver.CartToJnt(kq, kqd, kqdd, KDL::WrenchMap(), torque), 0);
    const Eigen::VectorXd ours = inverse_dynamics(arm, q, qd, qdd);
    for (int i = 0; i < 3; ++i)
      EXPECT_NEAR(ours(i), torque(index.at(names[i])), 1e-9 * (1.0 + std::abs(ours(i)))) << "joint " << i + 1;
    plain_difference = std::max(plain_difference, (inverse_dynamics(plain, q, qd, qdd) - ours).cwiseAbs().maxCoeff());
  }
  EXPECT_GT(plain_difference, 0.1);  // the camera and the gripper weigh: leaving them out is visible
  // Model files store the tip with the text and rebuild the same chain.
  const RobotModel stored = robot_from_storable_json(robot_to_storable_json(arm), "stored");
  Eigen::VectorXd q, qd, qdd;
  random_state(arm, rng, q, qd, qdd);
  EXPECT_EQ(inverse_dynamics(stored, q, qd, qdd), inverse_dynamics(arm, q, qd, qdd));
  // Without a tip, the branching tree is named with its leaves; an unknown tip with the links.
  const std::string branching = error_of([&] { load_robot(file); });
  EXPECT_NE(branching.find("branches at link 'l1' (leaves: camera, finger_left, finger_right)"), std::string::npos)
      << branching;
  EXPECT_NE(error_of([&] { load_robot(file + ":gripper"); }).find("has no link 'gripper'"), std::string::npos);
  EXPECT_NE(error_of([&] { load_robot(file + ":"); }).find("name a link after the ':'"), std::string::npos);
}

// Vendors' URDFs hold links without <inertial> (frames between joints) and
// point masses (a mass, no inertia): both load, and their dynamics are KDL's.
TEST(Urdf, MasslessLinksAndPointMassesAreKdlsDynamics) {
  const auto urdf = [](const std::string& l1, const std::string& l2, const std::string& j2_extra) {
    return "<robot name='frames'><link name='base'/>"
           "<joint name='j1' type='revolute'><parent link='base'/><child link='l1'/><axis xyz='0 0 1'/>"
           "<limit lower='-2' upper='2' velocity='2' effort='10'/></joint><link name='l1'>" + l1 + "</link>"
           "<joint name='j2' type='revolute'><parent link='l1'/><child link='l2'/><axis xyz='0 1 0'/>"
           "<origin xyz='0.3 0 0.1'/><limit lower='-2' upper='2' velocity='2' effort='10'/>" + j2_extra +
           "</joint><link name='l2'>" + l2 + "</link></robot>";
  };
  const std::string point_mass = "<inertial><origin xyz='0.25 0 0'/><mass value='1.5'/>"
                                 "<inertia ixx='0' iyy='0' izz='0' ixy='0' ixz='0' iyz='0'/></inertial>";
  const std::filesystem::path dir = std::filesystem::temp_directory_path();
  const std::string file = (dir / "gipdyn_frames.urdf").string();
  std::ofstream(file) << urdf("", point_mass, "");
  const RobotModel arm = load_robot_urdf(file);
  ASSERT_EQ(arm.joint_types().str(), "RR");
  KDL::Tree tree;
  ASSERT_TRUE(kdl_parser::treeFromFile(file, tree));
  KDL::Chain chain;
  ASSERT_TRUE(tree.getChain("base", "l2", chain));
  KDL::ChainIdSolver_RNE solver(chain, KDL::Vector(0, 0, -9.81));
  std::mt19937_64 rng(7);
  for (int trial = 0; trial < 10; ++trial) {
    Eigen::VectorXd q, qd, qdd;
    random_state(arm, rng, q, qd, qdd);
    KDL::JntArray kq(2), kqd(2), kqdd(2), torque(2);
    for (int i = 0; i < 2; ++i) kq(i) = q(i), kqd(i) = qd(i), kqdd(i) = qdd(i);
    KDL::Wrenches no_wrench(chain.getNrOfSegments(), KDL::Wrench::Zero());
    ASSERT_EQ(solver.CartToJnt(kq, kqd, kqdd, no_wrench, torque), 0);
    const Eigen::VectorXd ours = inverse_dynamics(arm, q, qd, qdd);
    ASSERT_TRUE(ours.allFinite());
    for (int i = 0; i < 2; ++i) EXPECT_NEAR(ours(i), torque(i), 1e-9 * (1.0 + std::abs(ours(i)))) << "joint " << i + 1;
  }
  // A joint with nothing after it to move, and a joint KDL would move independently of the one it mimics.
  std::ofstream(file) << urdf(point_mass, "", "");
  const std::string moves_nothing = error_of([&] { load_robot_urdf(file); });
  EXPECT_NE(moves_nothing.find("joint 2 ('j2') moves no mass: its link and every link after it are massless"),
            std::string::npos)
      << moves_nothing;
  std::ofstream(file) << urdf("", point_mass, "<mimic joint='j1'/>");
  const std::string mimics = error_of([&] { load_robot_urdf(file); });
  EXPECT_NE(mimics.find("joint 'j2' mimics joint 'j1', and gipdyn moves every joint of the chain independently"),
            std::string::npos)
      << mimics;
}

TEST(Regressor, TimesParametersEqualsKdlInverseDynamics) {
  std::mt19937_64 rng(1);
  for (const RobotModel& base : test_robots()) {
    for (const Eigen::Vector3d& g : {Eigen::Vector3d(0, 0, -9.81), Eigen::Vector3d::Zero().eval()}) {
      const RobotModel robot = base.with_gravity(g);
      for (bool friction : {false, true}) {
        Eigen::VectorXd w(robot.num_joints() * (friction ? 12 : 10));
        w.head(10 * robot.num_joints()) = robot.inertial_parameters();
        if (friction) w.tail(2 * robot.num_joints()) = robot.friction_parameters();
        for (int trial = 0; trial < 20; ++trial) {
          Eigen::VectorXd q, qd, qdd;
          random_state(robot, rng, q, qd, qdd);
          const Eigen::VectorXd tau = inverse_dynamics(robot, q, qd, qdd, friction);
          const Eigen::VectorXd phi_w = regressor(robot, q, qd, qdd, friction) * w;
          EXPECT_LT((phi_w - tau).norm(), 1e-9 * tau.norm()) << robot.name() << " g=" << g.norm() << " friction "
                                                              << friction << "\n" << tau.transpose() << "\n"
                                                              << phi_w.transpose();
        }
      }
    }
  }
}

TEST(Regressor, DoesNotDependOnInertialValues) {
  std::mt19937_64 rng(2);
  const RobotModel a = scara_robot();
  std::vector<JointSpec> heavier = a.joints();
  for (auto& j : heavier) j.link.mass *= 2.0;
  const RobotModel b = RobotModel::from_dh("heavier", heavier);
  Eigen::VectorXd q, qd, qdd;
  random_state(a, rng, q, qd, qdd);
  EXPECT_EQ(regressor(a, q, qd, qdd), regressor(b, q, qd, qdd));
  EXPECT_GT((inverse_dynamics(a, q, qd, qdd) - inverse_dynamics(b, q, qd, qdd)).norm(), 1e-3);
}

// KDL's RNEA against the power balance d/dt (kinetic + potential) = qd . tau,
// with energies computed independently from the link velocities (KDL forward
// velocity kinematics) along an analytic trajectory.
double total_energy(const RobotModel& r, const Eigen::VectorXd& q, const Eigen::VectorXd& qd) {
  KDL::ChainFkSolverVel_recursive fk(r.chain());
  KDL::JntArrayVel state(static_cast<unsigned>(q.size()));
  state.q.data = q;
  state.qdot.data = qd;
  double E = 0.0;
  for (int i = 0; i < r.num_joints(); ++i) {
    KDL::FrameVel fv;
    fk.JntToCart(state, fv, i + 1);
    const KDL::Frame F = fv.GetFrame();
    const KDL::Twist t = fv.GetTwist();
    const Eigen::Matrix3d R = Eigen::Map<const Eigen::Matrix<double, 3, 3, Eigen::RowMajor>>(F.M.data);
    const Eigen::Vector3d p(F.p.x(), F.p.y(), F.p.z()), v(t.vel.x(), t.vel.y(), t.vel.z()),
        w(t.rot.x(), t.rot.y(), t.rot.z());
    const LinkInertial& l = r.joint(i).link;
    const Eigen::Vector3d rc = R * l.com;
    const Eigen::Vector3d vc = v + w.cross(rc);
    E += 0.5 * l.mass * vc.squaredNorm() + 0.5 * w.dot(R * l.inertia * R.transpose() * w);
    E -= l.mass * r.gravity().dot(p + rc);
  }
  return E;
}

TEST(InverseDynamics, KdlSatisfiesThePowerBalance) {
  for (const RobotModel& robot : test_robots()) {
    const SinusoidTrajectory traj = SinusoidTrajectory::random(robot, 500, 0.01, 3);
    const int n = robot.num_joints();
    Eigen::VectorXd q(n), qd(n), qdd(n), qa(n), qda(n), qdda(n), qb(n), qdb(n), qddb(n);
    const double h = 1e-5;
    for (double t : {0.3, 1.7, 2.9, 4.1}) {
      traj.evaluate(t, q, qd, qdd);
      traj.evaluate(t + h, qa, qda, qdda);
      traj.evaluate(t - h, qb, qdb, qddb);
      const double dE = (total_energy(robot, qa, qda) - total_energy(robot, qb, qdb)) / (2 * h);
      const double power = qd.dot(inverse_dynamics(robot, q, qd, qdd));
      const double scale = (qd.cwiseAbs().array() * inverse_dynamics(robot, q, qd, qdd).cwiseAbs().array()).sum();
      EXPECT_NEAR(dE, power, 1e-6 * scale + 1e-9) << robot.name() << " t=" << t;
    }
  }
}

TEST(BaseParameters, FullColumnRankAndReproduceTorques) {
  for (const RobotModel& robot : test_robots()) {
    for (bool friction : {false, true}) {
      const BaseParameters b = compute_base_parameters(robot, friction, 150, 4);
      const int p = robot.num_joints() * (friction ? 12 : 10);
      EXPECT_GT(b.rank, 0);
      EXPECT_LT(b.rank, p) << robot.name();  // the standard parameters are never all identifiable
      Eigen::VectorXd w(p);
      w.head(10 * robot.num_joints()) = robot.inertial_parameters();
      if (friction) w.tail(2 * robot.num_joints()) = robot.friction_parameters();
      const Eigen::VectorXd wb = b.from_full(w);
      // Fresh states, not those the reduction was computed on.
      std::mt19937_64 rng(5);
      Eigen::MatrixXd stacked(30 * robot.num_joints(), b.rank);
      for (int s = 0; s < 30; ++s) {
        Eigen::VectorXd q, qd, qdd;
        random_state(robot, rng, q, qd, qdd);
        const Eigen::MatrixXd Phi_b = b.select(regressor(robot, q, qd, qdd, friction));
        stacked.middleRows(s * robot.num_joints(), robot.num_joints()) = Phi_b;
        const Eigen::VectorXd tau = inverse_dynamics(robot, q, qd, qdd, friction);
        EXPECT_LT((Phi_b * wb - tau).norm(), 1e-8 * tau.norm()) << robot.name();
      }
      const Eigen::VectorXd sv = Eigen::JacobiSVD<Eigen::MatrixXd>(stacked).singularValues();
      EXPECT_GT(sv(sv.size() - 1) / sv(0), 1e-9) << robot.name() << " base regressor is rank deficient";
    }
  }
}

TEST(Trajectory, DerivativesMatchFiniteDifferencesAndLimitsHold) {
  for (const RobotModel& robot : test_robots()) {
    const int samples = 2000;
    const SinusoidTrajectory traj = SinusoidTrajectory::random(robot, samples, 0.01, 6);
    const int n = robot.num_joints();
    Eigen::VectorXd q(n), qd(n), qdd(n), qa(n), qda(n), qdda(n), qb(n), qdb(n), qddb(n);
    const double h = 1e-5;
    for (double t : {0.0, 3.3, 12.5}) {
      traj.evaluate(t, q, qd, qdd);
      traj.evaluate(t + h, qa, qda, qdda);
      traj.evaluate(t - h, qb, qdb, qddb);
      EXPECT_LT(((qa - qb) / (2 * h) - qd).norm(), 1e-6 * (1 + qd.norm())) << robot.name();
      EXPECT_LT(((qda - qdb) / (2 * h) - qdd).norm(), 1e-6 * (1 + qdd.norm())) << robot.name();
    }
    const Eigen::MatrixXd X = traj.sample(samples, 0.01);
    for (int i = 0; i < n; ++i) {
      const JointLimits& l = robot.joint(i).limits;
      EXPECT_GE(X.col(i).minCoeff(), l.lower) << robot.name() << " joint " << i + 1;
      EXPECT_LE(X.col(i).maxCoeff(), l.upper) << robot.name() << " joint " << i + 1;
      EXPECT_LE(X.col(n + i).cwiseAbs().maxCoeff(), l.velocity * (1 + 1e-12)) << robot.name();
      // The scaling fills the range rather than leaving the joint still.
      const double used = std::max((X.col(i).maxCoeff() - X.col(i).minCoeff()) / (l.upper - l.lower),
                                   X.col(n + i).cwiseAbs().maxCoeff() / l.velocity);
      EXPECT_GT(used, 0.3) << robot.name() << " joint " << i + 1;
    }
  }
  const RobotModel scara = scara_robot();
  EXPECT_EQ(SinusoidTrajectory::random(scara, 100, 0.01, 7).sample(100, 0.01),
            SinusoidTrajectory::random(scara, 100, 0.01, 7).sample(100, 0.01));
  EXPECT_NE(SinusoidTrajectory::random(scara, 100, 0.01, 7).sample(100, 0.01),
            SinusoidTrajectory::random(scara, 100, 0.01, 8).sample(100, 0.01));
}

TEST(Simulation, SeededNoisyAndPerturbedAsAsked) {
  const RobotModel scara = scara_robot();
  SimulationOptions o;
  o.samples = 1500;
  o.seed = 9;
  const SimulationResult a = simulate(scara, o), b = simulate(scara, o);
  EXPECT_EQ(a.X, b.X);
  EXPECT_EQ(a.tau, b.tau);
  const Eigen::MatrixXd noise = a.tau - a.tau_true;
  for (int j = 0; j < 4; ++j) {
    const double sd = std::sqrt(noise.col(j).squaredNorm() / 1500.0);
    EXPECT_NEAR(sd, 0.01, 0.001) << "joint " << j + 1;
  }
  EXPECT_LT((a.tau_true - inverse_dynamics(scara, a.X)).norm(), 1e-12 * a.tau_true.norm());
  // The prismatic joint carries the weight of joints 3 and 4 (about 34 N).
  EXPECT_NEAR(a.tau_true.col(2).mean(), -3.5 * 9.81, 3.0);

  o.perturb_kinematics = true;
  const SimulationResult p = simulate(scara, o);
  EXPECT_EQ(p.metadata["perturbation"].size(), 4u);
  EXPECT_GT((p.tau_true - inverse_dynamics(scara, p.X)).norm(), 1e-3 * p.tau_true.norm());
  const double da = p.metadata["perturbation"][0]["da"].get<double>();
  EXPECT_LE(std::abs(da), 0.05);

  o.perturb_kinematics = false;
  o.friction = true;
  const SimulationResult f = simulate(scara, o);
  EXPECT_LT((f.tau_true - inverse_dynamics(scara, f.X, true)).norm(), 1e-12 * f.tau_true.norm());
  // URDF robots can be perturbed too.
  const RobotModel urdf = load_robot_urdf(kData + "/rpr_arm.urdf");
  o.perturb_kinematics = true;
  const SimulationResult u = simulate(urdf, o);
  EXPECT_GT((u.tau_true - inverse_dynamics(urdf, u.X, true)).norm(), 1e-4 * u.tau_true.norm());
}

TEST(RobotInput, BadDescriptionsGiveClearErrors) {
  EXPECT_NE(error_of([] { load_robot_urdf(kData + "/floating_arm.urdf"); }).find("floating"), std::string::npos);
  // URDF has no spherical joint type: urdfdom refuses the file, and we say so.
  EXPECT_NE(error_of([] { load_robot_urdf(kData + "/spherical_arm.urdf"); }).find("unknown joint type"),
            std::string::npos);
  EXPECT_NE(error_of([] { load_robot_json(kData + "/bad_robot_negative_mass.json"); }).find("mass"), std::string::npos);
  EXPECT_NE(error_of([] { load_robot("puma"); }).find("unknown robot 'puma'"), std::string::npos);
  EXPECT_NE(error_of([] { load_robot_json(kData + "/missing.json"); }).find("cannot open"), std::string::npos);

  const std::filesystem::path dir = std::filesystem::temp_directory_path();
  auto write = [&](const std::string& name, const std::string& text) {
    std::ofstream(dir / name) << text;
    return (dir / name).string();
  };
  EXPECT_NE(error_of([&] { load_robot_json(write("gipdyn_bad1.json", "{\"joints\": [ {\"type\": \"R\"")); })
                .find("not valid JSON"),
            std::string::npos);
  // Found by tests/test_fuzz.cpp: a field of the wrong type used to escape as a JSON library exception.
  EXPECT_NE(error_of([&] { load_robot_json(write("gipdyn_bad_name.json", R"({"name": {}, "joints": [{}]})")); })
                .find("a field has the wrong type"),
            std::string::npos);
  EXPECT_NE(error_of([&] {
              load_robot_json(write("gipdyn_bad2.json", R"({"joints": [{"type": "X", "dh": {}}]})"));
            }).find("\"type\" must be"),
            std::string::npos);
  EXPECT_NE(error_of([&] {
              load_robot_json(write("gipdyn_bad3.json",
                                    R"({"joints": [{"type": "R", "dh": {"a": 0.1, "alpha": 0, "d": 0},
                                         "mass": 1, "com": [0,0,0], "inertia": [[1,0,0],[0,1,0],[0,0,1]]}]})"));
            }).find("missing \"theta\""),
            std::string::npos);
  EXPECT_NE(error_of([&] {
              load_robot_json(write("gipdyn_bad4.json",
                                    R"({"joints": [{"type": "R", "dh": {"a": 0.1, "alpha": 0, "d": 0, "theta": 0},
                                         "mass": 1, "com": [0,0,0], "inertia": [[0.1,0,0],[0,0.1,0],[0,0,-0.1]]}]})"));
            }).find("not positive semidefinite"),
            std::string::npos);
  // Corke's tabulated Puma 560 link 3 (Iyy 0.086 > Ixx + Izz): named with its moments, not accepted.
  const std::string triangle = error_of([&] {
    load_robot_json(write("gipdyn_bad8.json", R"({"joints": [{"type": "R", "dh": {"a": 0.1, "alpha": 0, "d": 0, "theta": 0},
        "mass": 1, "com": [0,0,0], "inertia": [[0.066,0,0],[0,0.086,0],[0,0,0.0125]]}]})"));
  });
  EXPECT_NE(triangle.find("principal moments 0.012500, 0.066000, 0.086000 kg m^2 violate the triangle inequality"),
            std::string::npos) << triangle;
  // A misspelt optional field is named, not ignored with its default used instead.
  const std::string misspelt_gravity = error_of([&] {
    load_robot_json(write("gipdyn_bad6.json", R"({"gravty": [0, 0, 9.81], "joints": [{"type": "R",
        "dh": {"a": 0.1, "alpha": 0, "d": 0, "theta": 0}, "mass": 1, "com": [0,0,0], "inertia": [[1,0,0],[0,1,0],[0,0,1]]}]})"));
  });
  EXPECT_NE(misspelt_gravity.find("unknown field \"gravty\" (known: name, description, gravity, joints)"), std::string::npos)
      << misspelt_gravity;
  const std::string misspelt_limit = error_of([&] {
    load_robot_json(write("gipdyn_bad7.json", R"({"joints": [{"type": "R", "dh": {"a": 0.1, "alpha": 0, "d": 0, "theta": 0},
        "mass": 1, "com": [0,0,0], "inertia": [[1,0,0],[0,1,0],[0,0,1]], "limits": {"lower": -1, "upper": 1, "velocity": 2, "vel": 3}}]})"));
  });
  EXPECT_NE(misspelt_limit.find("joint 1 limits: unknown field \"vel\""), std::string::npos) << misspelt_limit;
  EXPECT_NE(error_of([&] { load_robot_urdf(write("gipdyn_bad5.urdf", "<robot name='x'><link name='a'>")); })
                .find("could not be parsed"),
            std::string::npos);
}

}  // namespace
}  // namespace gipdyn
