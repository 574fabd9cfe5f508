#include <console_bridge/console.h>

#include <algorithm>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <kdl/tree.hpp>
#include <kdl_parser/kdl_parser.hpp>
#include <nlohmann/json.hpp>
#include <urdf_parser/urdf_parser.h>

#include "gipdyn/error.hpp"
#include "gipdyn/robot/robot_loader.hpp"

namespace gipdyn {
namespace {

double number(const nlohmann::json& j, const char* key, const std::string& where) {
  if (!j.contains(key)) throw Error(where + ": missing \"" + key + "\"");
  if (!j.at(key).is_number()) throw Error(where + ": \"" + key + "\" must be a number");
  return j.at(key).get<double>();
}

Eigen::Vector3d vec3(const nlohmann::json& j, const char* key, const std::string& where) {
  if (!j.contains(key) || !j.at(key).is_array() || j.at(key).size() != 3)
    throw Error(where + ": \"" + key + "\" must be a list of 3 numbers");
  Eigen::Vector3d v;
  for (int k = 0; k < 3; ++k) {
    if (!j.at(key)[static_cast<size_t>(k)].is_number()) throw Error(where + ": \"" + key + "\" must hold numbers");
    v(k) = j.at(key)[static_cast<size_t>(k)].get<double>();
  }
  return v;
}

// A misspelt optional field ("gravty", "limit") would otherwise be ignored and
// its default used without a word.
void reject_unknown_fields(const nlohmann::json& j, const std::vector<std::string>& known, const std::string& where) {
  for (const auto& [key, value] : j.items())
    if (std::find(known.begin(), known.end(), key) == known.end())
      throw Error(where + ": unknown field \"" + key + "\" (known: " + joined(known) + "); fix its spelling or remove it");
}

}  // namespace

namespace {

RobotModel parse_robot_json(const nlohmann::json& d, const std::string& source) {
  if (!d.is_object()) throw Error(source + ": the robot description must be a JSON object");
  reject_unknown_fields(d, {"name", "description", "gravity", "joints"}, source);
  const std::string name = d.value("name", std::filesystem::path(source).stem().string());
  Eigen::Vector3d gravity(0, 0, -9.81);
  if (d.contains("gravity")) gravity = vec3(d, "gravity", source);
  if (!d.contains("joints") || !d.at("joints").is_array() || d.at("joints").empty())
    throw Error(source + ": \"joints\" must be a non-empty list (see docs/robot-format.md)");
  std::vector<JointSpec> joints;
  int k = 0;
  for (const auto& e : d.at("joints")) {
    ++k;
    const std::string where = source + ", joint " + std::to_string(k);
    if (!e.is_object()) throw Error(where + ": must be a JSON object");
    reject_unknown_fields(e, {"name", "type", "dh", "mass", "com", "inertia", "limits", "friction"}, where);
    JointSpec j;
    j.name = e.value("name", "joint" + std::to_string(k));
    const std::string type = e.value("type", "");
    if (type == "R" || type == "revolute") {
      j.type = JointType::Revolute;
    } else if (type == "P" || type == "prismatic") {
      j.type = JointType::Prismatic;
    } else {
      throw Error(where + ": \"type\" must be \"R\" (revolute) or \"P\" (prismatic), got \"" + type + "\"");
    }
    if (!e.contains("dh") || !e.at("dh").is_object()) throw Error(where + ": missing \"dh\" {a, alpha, d, theta}");
    const auto& dh = e.at("dh");
    reject_unknown_fields(dh, {"a", "alpha", "d", "theta"}, where + " dh");
    j.dh = DhParameters{number(dh, "a", where + " dh"), number(dh, "alpha", where + " dh"), number(dh, "d", where + " dh"),
                        number(dh, "theta", where + " dh")};
    j.link.mass = number(e, "mass", where);
    j.link.com = vec3(e, "com", where);
    if (!e.contains("inertia") || !e.at("inertia").is_array() || e.at("inertia").size() != 3)
      throw Error(where + ": \"inertia\" must be a 3x3 list of lists (kg m^2, about the centre of mass)");
    for (int r = 0; r < 3; ++r) {
      const auto& row = e.at("inertia")[static_cast<size_t>(r)];
      if (!row.is_array() || row.size() != 3) throw Error(where + ": \"inertia\" must be 3x3");
      for (int c = 0; c < 3; ++c) {
        if (!row[static_cast<size_t>(c)].is_number()) throw Error(where + ": \"inertia\" must hold numbers");
        j.link.inertia(r, c) = row[static_cast<size_t>(c)].get<double>();
      }
    }
    if (e.contains("limits")) {
      const auto& l = e.at("limits");
      if (!l.is_object()) throw Error(where + ": \"limits\" must be an object {lower, upper, velocity}");
      reject_unknown_fields(l, {"lower", "upper", "velocity"}, where + " limits");
      j.limits = {number(l, "lower", where + " limits"), number(l, "upper", where + " limits"),
                  number(l, "velocity", where + " limits")};
    }
    if (e.contains("friction")) {
      const auto& f = e.at("friction");
      if (!f.is_object()) throw Error(where + ": \"friction\" must be an object {viscous, coulomb}");
      reject_unknown_fields(f, {"viscous", "coulomb"}, where + " friction");
      j.friction = {number(f, "viscous", where + " friction"), number(f, "coulomb", where + " friction")};
    }
    joints.push_back(j);
  }
  return RobotModel::from_dh(name, joints, gravity);
}

}  // namespace

RobotModel robot_from_json(const nlohmann::json& d, const std::string& source) {
  try {
    return parse_robot_json(d, source);
  } catch (const nlohmann::json::exception& e) {
    // A field of the wrong type ("name": {}) that no explicit check above caught.
    throw Error(source + ": a field has the wrong type (" + std::string(e.what()) + "); see docs/robot-format.md");
  }
}

RobotModel load_robot_json(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw Error("cannot open robot description '" + path + "'");
  nlohmann::json d;
  try {
    d = nlohmann::json::parse(in);
  } catch (const nlohmann::json::exception& e) {
    throw Error("robot description '" + path + "' is not valid JSON (" + std::string(e.what()) + ")");
  }
  return robot_from_json(d, path);
}

RobotModel load_robot_urdf(const std::string& path, const std::string& tip_link) {
  std::ifstream in(path);
  if (!in) throw Error("cannot open URDF '" + path + "'");
  const std::string xml((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  return robot_from_urdf(xml, path, tip_link);
}

namespace {

// The inertia of a segment and of everything below it but the child `except`
// (the chain's next segment, or none), in the segment's tip frame, with every
// joint below it at position zero.
KDL::RigidBodyInertia subtree_inertia(const KDL::SegmentMap::const_iterator& element, const std::string& except = "") {
  KDL::RigidBodyInertia inertia = GetTreeElementSegment(element->second).getInertia();
  for (const auto& child : GetTreeElementChildren(element->second))
    if (child->first != except)
      inertia = inertia + GetTreeElementSegment(child->second).pose(0.0) * subtree_inertia(child);
  return inertia;
}

}  // namespace

RobotModel robot_from_urdf(const std::string& xml, const std::string& path, const std::string& tip_link) {
  // urdfdom logs its parse errors to stderr through console_bridge; our own
  // one-line error below says what is wrong, so keep the terminal clean.
  console_bridge::setLogLevel(console_bridge::CONSOLE_BRIDGE_LOG_NONE);
  const urdf::ModelInterfaceSharedPtr model = urdf::parseURDF(xml);
  if (!model) throw Error("URDF '" + path + "' could not be parsed (malformed XML or an unknown joint type)");
  std::vector<urdf::LinkSharedPtr> links;
  model->getLinks(links);
  std::string tip = tip_link;
  if (tip.empty()) {  // the single leaf
    urdf::LinkConstSharedPtr link = model->getRoot();
    while (link->child_links.size() == 1) link = link->child_links.front();
    if (!link->child_links.empty()) {
      std::vector<std::string> leaves;
      for (const auto& l : links)
        if (l->child_links.empty()) leaves.push_back(l->name);
      throw Error("URDF '" + path + "' branches at link '" + link->name + "' (leaves: " + joined(leaves) +
                  "); name the chain's last link, as the robot '" + path + ":LINK' or the tip_link argument (the " +
                  "links beyond it ride on it rigidly)");
    }
    tip = link->name;
  } else if (!model->getLink(tip)) {
    std::vector<std::string> names;
    for (const auto& l : links) names.push_back(l->name);
    throw Error("URDF '" + path + "' has no link '" + tip + "' to end the chain at (its links: " + joined(names) + ")");
  }
  // The joints from the root to the tip.
  std::vector<urdf::JointSharedPtr> path_joints;
  for (urdf::LinkConstSharedPtr link = model->getLink(tip); link->parent_joint; link = link->getParent())
    path_joints.insert(path_joints.begin(), link->parent_joint);
  for (const auto& j : path_joints)
    if (j->type == urdf::Joint::FLOATING || j->type == urdf::Joint::PLANAR || j->type == urdf::Joint::UNKNOWN)
      throw Error("URDF '" + path + "': joint '" + j->name +
                  "' is floating/planar; gipdyn supports revolute, continuous, prismatic and fixed joints");
  // KDL ignores <mimic>: the joint would be simulated and learned as an independent one.
  for (const auto& j : path_joints)
    if (j->mimic && j->type != urdf::Joint::FIXED)
      throw Error("URDF '" + path + "': joint '" + j->name + "' mimics joint '" + j->mimic->joint_name +
                  "', and gipdyn moves every joint of the chain independently; remove its <mimic> element to "
                  "treat it as a joint of its own, or end the chain before it (ROBOT:LINK)");
  KDL::Tree tree;
  if (!kdl_parser::treeFromUrdfModel(*model, tree)) throw Error("URDF '" + path + "': KDL could not build the tree");
  KDL::Chain on_chain;
  if (!tree.getChain(model->getRoot()->name, tip, on_chain))
    throw Error("URDF '" + path + "': no chain from '" + model->getRoot()->name + "' to '" + tip + "'");
  // Every subtree off the chain rides on the chain link it hangs from.
  KDL::Chain raw;
  for (unsigned s = 0; s < on_chain.getNrOfSegments(); ++s) {
    const KDL::Segment& seg = on_chain.getSegment(s);
    const std::string next = s + 1 < on_chain.getNrOfSegments() ? on_chain.getSegment(s + 1).getName() : "";
    raw.addSegment(KDL::Segment(seg.getName(), seg.getJoint(), seg.getFrameToTip(),
                                subtree_inertia(tree.getSegment(seg.getName()), next)));
  }

  // Merge fixed segments: those before the first movable joint move the base;
  // later ones are folded into the preceding movable link.
  std::vector<KDL::Segment> segs;
  KDL::Frame base = KDL::Frame::Identity();
  for (unsigned s = 0; s < raw.getNrOfSegments(); ++s) {
    const KDL::Segment& seg = raw.getSegment(s);
    if (seg.getJoint().getType() == KDL::Joint::Fixed) {
      if (segs.empty()) {
        base = base * seg.getFrameToTip();
      } else {
        const KDL::Segment& last = segs.back();
        const KDL::Frame F = seg.getFrameToTip();
        segs.back() = KDL::Segment(last.getName(), last.getJoint(), last.getFrameToTip() * F,
                                   F.Inverse() * last.getInertia() + seg.getInertia());
      }
      continue;
    }
    KDL::Segment moved = seg;
    if (segs.empty()) {
      const KDL::Joint& j = seg.getJoint();
      const KDL::Joint::JointType type =
          (j.getType() == KDL::Joint::TransAxis || j.getType() == KDL::Joint::TransX ||
           j.getType() == KDL::Joint::TransY || j.getType() == KDL::Joint::TransZ)
              ? KDL::Joint::TransAxis
              : KDL::Joint::RotAxis;
      moved = KDL::Segment(seg.getName(), KDL::Joint(j.getName(), base * j.JointOrigin(), base.M * j.JointAxis(), type),
                           base * seg.getFrameToTip(), seg.getInertia());
    }
    segs.push_back(moved);
  }
  if (segs.empty()) throw Error("URDF '" + path + "' has no movable joint");
  KDL::Chain chain;
  for (const auto& s : segs) chain.addSegment(s);

  std::vector<JointSpec> specs;
  for (const auto& j : path_joints) {
    if (j->type == urdf::Joint::FIXED) continue;
    JointSpec spec;
    spec.name = j->name;
    if (j->limits && j->type != urdf::Joint::CONTINUOUS && j->limits->upper > j->limits->lower)
      spec.limits = {j->limits->lower, j->limits->upper, spec.limits.velocity};
    if (j->limits && j->limits->velocity > 0) spec.limits.velocity = j->limits->velocity;
    if (j->dynamics) spec.friction = {j->dynamics->damping, j->dynamics->friction};
    specs.push_back(spec);
  }
  RobotModel robot = RobotModel::from_chain(model->getName(), chain, specs);
  robot.set_urdf(xml, tip_link);
  return robot;
}

nlohmann::json robot_to_storable_json(const RobotModel& robot) {
  if (robot.is_dh()) return {{"dh", robot.to_json()}};
  if (!robot.urdf().empty()) {
    nlohmann::json stored = {{"urdf", robot.urdf()}, {"gravity", robot.to_json().at("gravity")}};
    if (!robot.urdf_tip().empty()) stored["tip"] = robot.urdf_tip();
    return stored;
  }
  throw Error("robot '" + robot.name() + "' has neither DH parameters nor URDF text to store");
}

RobotModel robot_from_storable_json(const nlohmann::json& stored, const std::string& source) {
  if (stored.contains("dh")) return robot_from_json(stored.at("dh"), source);
  if (stored.contains("urdf")) {
    const auto g = stored.at("gravity").get<std::vector<double>>();
    if (g.size() != 3) throw Error(source + ": stored gravity must have 3 entries");
    return robot_from_urdf(stored.at("urdf").get<std::string>(), source, stored.value("tip", std::string()))
        .with_gravity(Eigen::Vector3d(g[0], g[1], g[2]));
  }
  throw Error(source + ": stored robot has neither 'dh' nor 'urdf'");
}

RobotModel load_robot(const std::string& spec) {
  if (spec == "scara") return scara_robot();
  if (spec == "ur10") return ur10_robot();
  // FILE.urdf:LINK names the chain's last link.
  for (const char* suffix : {".urdf:", ".URDF:"})
    if (const size_t at = spec.rfind(suffix); at != std::string::npos) {
      const size_t colon = at + std::strlen(suffix) - 1;
      if (colon + 1 == spec.size()) throw Error("robot '" + spec + "': name a link after the ':' or drop it");
      return load_robot_urdf(spec.substr(0, colon), spec.substr(colon + 1));
    }
  const std::string ext = std::filesystem::path(spec).extension().string();
  if (ext == ".urdf" || ext == ".URDF") return load_robot_urdf(spec);
  if (ext == ".json") return load_robot_json(spec);
  throw Error("unknown robot '" + spec + "'; use scara, ur10, a .urdf file (FILE.urdf:LINK to end the chain at a "
              "link) or a .json DH description");
}

}  // namespace gipdyn
