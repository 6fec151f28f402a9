/**
 * @file visual_servo_cycle_node.cpp
 * @brief The visual servo loop (Figure 25): feature -> error -> ViSP law -> integrate -> IK -> move.
 */
#include "cooperation_pkg/visual_servo_cycle_node.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <stdexcept>

#include <boost/bind/bind.hpp>
#include <tf2/LinearMath/Transform.h>
#include <tf2_geometry_msgs/tf2_geometry_msgs.h>

#include "cooperation_pkg/names.h"

namespace cooperation_pkg
{
namespace
{
const char LOG[] = "visual_servo";

bool finite(double v)
{
  return std::isfinite(v);
}

/** Checks one setting and explains a bad value. */
void require(bool ok, const std::string &what)
{
  if (!ok)
  {
    throw std::invalid_argument("invalid parameter: " + what);
  }
}

void checkSettings(const ServoSettings &s)
{
  require(finite(s.gain) && s.gain > 0.0, "~gain must be > 0 [1/s]");
  require(finite(s.dt) && s.dt > 0.0, "~dt must be > 0 [s]");
  require(finite(s.threshold) && s.threshold > 0.0, "~threshold must be > 0 [m]");
  require(s.max_iterations > 0, "~max_iterations must be > 0");
  require(finite(s.peduncle_gap) && s.peduncle_gap >= 0.0, "~peduncle_gap must be >= 0 [m]");
  require(finite(s.default_radius) && s.default_radius > 0.0, "~default_radius must be > 0 [m]");
  require(s.max_lost > 0, "~max_lost must be > 0");
  require(finite(s.max_step) && s.max_step > 0.0, "~max_step must be > 0 [m]");
  require(finite(s.max_gain_dt) && s.max_gain_dt > 0.0, "~max_gain_dt must be > 0");
  require(finite(s.continuous_gain) && s.continuous_gain > 0.0, "~continuous_gain must be > 0 [1/s]");
  require(finite(s.horizon) && s.horizon > 0.0, "~horizon must be > 0 [s]");
  require(s.continuous_max_iterations > 0, "~continuous_max_iterations must be > 0");
  require(s.adaptive_gain_at_infinity == 0.0 ||
              (s.adaptive_gain_at_infinity > 0.0 && s.adaptive_gain_at_infinity < s.gain && s.adaptive_slope_at_zero > 0.0),
          "adaptive gain needs 0 < ~adaptive_gain_at_infinity < ~gain and ~adaptive_slope_at_zero > 0");
}

geometry_msgs::Twist toTwist(const vpColVector &v)
{
  geometry_msgs::Twist t;
  t.linear.x = v[0];
  t.linear.y = v[1];
  t.linear.z = v[2];
  t.angular.x = v[3];
  t.angular.y = v[4];
  t.angular.z = v[5];
  return t;
}
}  // namespace

VisualServoCycleNode::VisualServoCycleNode(ros::NodeHandle nh, ros::NodeHandle pnh)
  : nh_(nh)
  , pnh_(pnh)
  , tf_listener_(tf_buffer_)
  , image_client_(nh, names::IMAGE_PROCESSING_ACTION, true)
  , kinematics_client_(nh, names::KINEMATICS_ACTION, true)
  , move_client_(nh, names::MOVE_ROBOT_ACTION, true)
  , server_(nh, names::VISUAL_SERVO_ACTION, boost::bind(&VisualServoCycleNode::execute, this, boost::placeholders::_1),
            false)
{
  pnh_.param<std::string>("base_frame", base_frame_, "base_link");
  pnh_.param<std::string>("camera_frame", camera_frame_, "hand_camera_optical");
  pnh_.param<std::string>("tool_frame", tool_frame_, "left_shear_tcp");
  pnh_.param("image_timeout", image_timeout_, 5.0);
  pnh_.param("kinematics_timeout", kinematics_timeout_, 5.0);
  pnh_.param("move_timeout", move_timeout_, 30.0);
  pnh_.param("server_timeout", server_timeout_, 5.0);
  pnh_.param("tf_timeout", tf_timeout_, 0.5);

  ServoSettings s;
  pnh_.param("gain", s.gain, s.gain);
  pnh_.param("adaptive_gain_at_infinity", s.adaptive_gain_at_infinity, s.adaptive_gain_at_infinity);
  pnh_.param("adaptive_slope_at_zero", s.adaptive_slope_at_zero, s.adaptive_slope_at_zero);
  pnh_.param("dt", s.dt, s.dt);
  pnh_.param("threshold", s.threshold, s.threshold);
  pnh_.param("max_iterations", s.max_iterations, s.max_iterations);
  pnh_.param("peduncle_gap", s.peduncle_gap, s.peduncle_gap);
  pnh_.param("default_radius", s.default_radius, s.default_radius);
  pnh_.param("max_lost", s.max_lost, s.max_lost);
  pnh_.param("max_step", s.max_step, s.max_step);
  pnh_.param("max_gain_dt", s.max_gain_dt, s.max_gain_dt);
  pnh_.param("continuous_gain", s.continuous_gain, s.continuous_gain);
  pnh_.param("horizon", s.horizon, s.horizon);
  pnh_.param("continuous_max_iterations", s.continuous_max_iterations, s.continuous_max_iterations);
  std::string mode;
  pnh_.param<std::string>("mode", mode, "step");
  require(parseServoMode(mode, s.mode), "~mode must be 'step' or 'continuous'");
  std::string dof_mode;
  pnh_.param<std::string>("dof_mode", dof_mode, "translation");
  require(dof_mode == "translation" || dof_mode == "full", "~dof_mode must be 'translation' or 'full'");
  s.translation_only = (dof_mode == "translation");
  require(image_timeout_ > 0.0 && kinematics_timeout_ > 0.0 && move_timeout_ > 0.0 && server_timeout_ > 0.0 &&
              tf_timeout_ > 0.0,
          "timeouts (~image_timeout, ~kinematics_timeout, ~move_timeout, ~server_timeout, ~tf_timeout) must be > 0 [s]");
  checkSettings(s);
  settings_ = s;

  joint_sub_ = nh_.subscribe(names::JOINT_STATES_TOPIC, 10, &VisualServoCycleNode::jointStatesCallback, this);
  // Initialised from the private params (YAML); the callback overrides gain, dt, threshold, ...
  reconfigure_server_.reset(new dynamic_reconfigure::Server<VisualServoConfig>(pnh_));
  reconfigure_server_->setCallback(
      boost::bind(&VisualServoCycleNode::reconfigure, this, boost::placeholders::_1, boost::placeholders::_2));
  server_.start();
  ROS_INFO_NAMED(LOG, "visual_servo: ready (camera %s, tool %s, base %s, %s law, %s mode)", camera_frame_.c_str(),
                 tool_frame_.c_str(), base_frame_.c_str(), s.translation_only ? "translation-only" : "6-DOF",
                 servoModeName(settings_.mode));
}

VisualServoCycleNode::~VisualServoCycleNode()
{
  server_.shutdown();
}

void VisualServoCycleNode::reconfigure(VisualServoConfig &config, uint32_t /*level*/)
{
  std::lock_guard<std::mutex> lock(settings_mutex_);
  ServoSettings s = settings_;
  s.gain = config.gain;
  s.dt = config.dt;
  s.threshold = config.threshold;
  s.max_iterations = config.max_iterations;
  s.peduncle_gap = config.peduncle_gap;
  s.max_step = config.max_step;
  s.continuous_gain = config.continuous_gain;
  s.horizon = config.horizon;
  s.continuous_max_iterations = config.continuous_max_iterations;
  try
  {
    require(parseServoMode(config.mode, s.mode), "mode must be 'step' or 'continuous'");
    checkSettings(s);
    settings_ = s;
    ROS_INFO_NAMED(LOG, "visual_servo: settings for the next goal: %s mode, gain %.3f, dt %.3f s, threshold %.4f m, "
                        "max_iterations %d, peduncle_gap %.3f m, max_step %.3f m, continuous_gain %.3f, "
                        "horizon %.3f s, continuous_max_iterations %d",
                   servoModeName(s.mode), s.gain, s.dt, s.threshold, s.max_iterations, s.peduncle_gap, s.max_step,
                   s.continuous_gain, s.horizon, s.continuous_max_iterations);
  }
  catch (const std::invalid_argument &e)
  {
    ROS_WARN_NAMED(LOG, "visual_servo: reconfigure rejected: %s", e.what());
  }
}

void VisualServoCycleNode::jointStatesCallback(const sensor_msgs::JointState::ConstPtr &msg)
{
  std::lock_guard<std::mutex> lock(joints_mutex_);
  // Keep the latest position of every joint (several publishers may each send a subset).
  for (size_t i = 0; i < msg->name.size() && i < msg->position.size(); ++i)
  {
    auto it = std::find(last_joint_state_.name.begin(), last_joint_state_.name.end(), msg->name[i]);
    if (it == last_joint_state_.name.end())
    {
      last_joint_state_.name.push_back(msg->name[i]);
      last_joint_state_.position.push_back(msg->position[i]);
    }
    else
    {
      last_joint_state_.position[it - last_joint_state_.name.begin()] = msg->position[i];
    }
  }
  last_joint_state_.header = msg->header;
}

trajectory_msgs::JointTrajectoryPoint VisualServoCycleNode::currentLeftJoints() const
{
  trajectory_msgs::JointTrajectoryPoint p;
  std::lock_guard<std::mutex> lock(joints_mutex_);
  for (const char *name : names::LEFT_ARM_JOINTS)
  {
    auto it = std::find(last_joint_state_.name.begin(), last_joint_state_.name.end(), name);
    if (it == last_joint_state_.name.end())
    {
      return trajectory_msgs::JointTrajectoryPoint();
    }
    p.positions.push_back(last_joint_state_.position[it - last_joint_state_.name.begin()]);
  }
  return p;
}

bool VisualServoCycleNode::makeSettings(const harvest_msgs::VisualServoGoal &goal, ServoSettings &s, double &radius,
                                        std::string &why) const
{
  {
    std::lock_guard<std::mutex> lock(settings_mutex_);
    s = settings_;
  }
  if (s.mode == ServoMode::CONTINUOUS)
  {
    // From here on gain, dt and max_iterations are those of the mode (the goal's overrides apply to them).
    s.gain = s.continuous_gain;
    s.dt = s.horizon;
    s.max_iterations = s.continuous_max_iterations;
    s.adaptive_gain_at_infinity = 0.0;  // constant gain in continuous mode
  }
  const geometry_msgs::Point &p = goal.target.point;
  if (!finite(p.x) || !finite(p.y) || !finite(p.z))
  {
    why = "invalid goal: target point is not finite";
    return false;
  }
  if (goal.target.header.frame_id.empty())
  {
    why = "invalid goal: target.header.frame_id is empty";
    return false;
  }
  if (!finite(goal.target_radius) || goal.target_radius < 0.0 || goal.target_radius > 0.2)
  {
    why = "invalid goal: target_radius must be in [0, 0.2] m (0 = default)";
    return false;
  }
  if (!finite(goal.gain) || goal.gain < 0.0)
  {
    why = "invalid goal: gain must be >= 0 (0 = default)";
    return false;
  }
  if (!finite(goal.threshold) || goal.threshold < 0.0)
  {
    why = "invalid goal: threshold must be >= 0 m (0 = default)";
    return false;
  }
  if (goal.max_iterations < 0)
  {
    why = "invalid goal: max_iterations must be >= 0 (0 = default)";
    return false;
  }
  if (goal.gain > 0.0)
  {
    s.gain = goal.gain;
    s.adaptive_gain_at_infinity = 0.0;  // an explicit gain is a constant gain
  }
  if (goal.threshold > 0.0)
  {
    s.threshold = goal.threshold;
  }
  if (goal.max_iterations > 0)
  {
    s.max_iterations = goal.max_iterations;
  }
  if (s.gain * s.dt > s.max_gain_dt)
  {
    char buf[200];
    std::snprintf(buf, sizeof(buf), "invalid goal: gain * %s = %.2f exceeds %.2f (the loop overshoots and diverges)",
                  s.mode == ServoMode::CONTINUOUS ? "horizon" : "dt", s.gain * s.dt, s.max_gain_dt);
    why = buf;
    return false;
  }
  radius = goal.target_radius > 0.0 ? goal.target_radius : s.default_radius;
  return true;
}

bool VisualServoCycleNode::waitForServers(std::string &why)
{
  const ros::Duration timeout(server_timeout_);
  if (!image_client_.waitForServer(timeout))
  {
    why = std::string("action server '") + names::IMAGE_PROCESSING_ACTION + "' is not available";
    return false;
  }
  if (!kinematics_client_.waitForServer(timeout))
  {
    why = std::string("action server '") + names::KINEMATICS_ACTION + "' is not available";
    return false;
  }
  if (!move_client_.waitForServer(timeout))
  {
    why = std::string("action server '") + names::MOVE_ROBOT_ACTION + "' is not available";
    return false;
  }
  return true;
}

bool VisualServoCycleNode::lookup(const std::string &target, const std::string &source, const ros::Time &stamp,
                                  geometry_msgs::TransformStamped &out, std::string &why) const
{
  std::string err;
  if (!stamp.isZero())
  {
    if (tf_buffer_.canTransform(target, source, stamp, ros::Duration(tf_timeout_), &err))
    {
      out = tf_buffer_.lookupTransform(target, source, stamp);
      return true;
    }
    ROS_WARN_THROTTLE_NAMED(5.0, LOG, "visual_servo: no transform %s <- %s at the image time (%s); using the latest",
                            target.c_str(), source.c_str(), err.c_str());
  }
  if (!tf_buffer_.canTransform(target, source, ros::Time(0), ros::Duration(tf_timeout_), &err))
  {
    why = "no transform " + target + " <- " + source + ": " + err;
    return false;
  }
  out = tf_buffer_.lookupTransform(target, source, ros::Time(0));
  return true;
}

template <class Client, class Goal>
VisualServoCycleNode::Step VisualServoCycleNode::runSubGoal(Client &client, const Goal &goal, double timeout,
                                                            const char *name, std::string &why)
{
  client.sendGoal(goal);
  return waitSubGoal(client, timeout, name, why);
}

template <class Client>
VisualServoCycleNode::Step VisualServoCycleNode::waitSubGoal(Client &client, double timeout, const char *name,
                                                             std::string &why)
{
  const ros::Time deadline = ros::Time::now() + ros::Duration(timeout);
  while (!client.waitForResult(ros::Duration(0.05)))
  {
    if (!ros::ok())
    {
      client.cancelGoal();
      why = std::string(name) + " interrupted: node shutting down";
      return Step::FAILED;
    }
    if (server_.isPreemptRequested())
    {
      client.cancelGoal();  // move_robot halts its axes on cancel
      client.waitForResult(ros::Duration(2.0));
      why = std::string(name) + " goal cancelled";
      return Step::PREEMPTED;
    }
    if (ros::Time::now() > deadline)
    {
      client.cancelGoal();
      char buf[160];
      std::snprintf(buf, sizeof(buf), "%s did not answer within %.1f s", name, timeout);
      why = buf;
      return Step::FAILED;
    }
  }
  const actionlib::SimpleClientGoalState state = client.getState();
  if (state != actionlib::SimpleClientGoalState::SUCCEEDED)
  {
    why = std::string(name) + " ended " + state.toString() + (state.getText().empty() ? "" : ": " + state.getText());
    return Step::FAILED;
  }
  return Step::OK;
}

VisualServoCycleNode::Step VisualServoCycleNode::requestFeature(const geometry_msgs::PointStamped &target,
                                                                harvest_msgs::ServoFeature &feature, std::string &why)
{
  harvest_msgs::ImageProcessingGoal goal;
  goal.request = harvest_msgs::ImageProcessingGoal::SERVO_FEATURE;
  goal.target_hint = target;
  const Step st = runSubGoal(image_client_, goal, image_timeout_, names::IMAGE_PROCESSING_ACTION, why);
  if (st != Step::OK)
  {
    return st;
  }
  const harvest_msgs::ImageProcessingResultConstPtr result = image_client_.getResult();
  if (!result || !result->success || !result->feature.found)
  {
    why = result && !result->message.empty() ? result->message : "no tomato in the hand camera image";
    return Step::LOST;
  }
  feature = result->feature;
  if (!finite(feature.x) || !finite(feature.y))
  {
    why = "image feature is not finite";
    return Step::LOST;
  }
  if (!feature.header.frame_id.empty() && feature.header.frame_id != camera_frame_)
  {
    ROS_WARN_THROTTLE_NAMED(10.0, LOG, "visual_servo: feature frame '%s' differs from ~camera_frame '%s'",
                            feature.header.frame_id.c_str(), camera_frame_.c_str());
  }
  return Step::OK;
}

VisualServoCycleNode::Step VisualServoCycleNode::solveIk(const geometry_msgs::PointStamped &tool_point,
                                                         trajectory_msgs::JointTrajectoryPoint &joints,
                                                         std::string &why)
{
  harvest_msgs::KinematicsGoal goal;
  goal.target = tool_point;
  goal.arm = true;  // left, cutting arm
  goal.standoff = 0.0;
  const Step st = runSubGoal(kinematics_client_, goal, kinematics_timeout_, names::KINEMATICS_ACTION, why);
  if (st != Step::OK)
  {
    return st;
  }
  const harvest_msgs::KinematicsResultConstPtr result = kinematics_client_.getResult();
  char buf[256];
  if (!result || !result->reachable)
  {
    std::snprintf(buf, sizeof(buf), "tool point (%.3f, %.3f, %.3f) in %s is unreachable: %s", tool_point.point.x,
                  tool_point.point.y, tool_point.point.z, tool_point.header.frame_id.c_str(),
                  result ? result->reason.c_str() : "no result");
    why = buf;
    return Step::FAILED;
  }
  if (result->joint_goal.positions.size() != 3)
  {
    std::snprintf(buf, sizeof(buf), "kinematics returned %zu joint positions, expected 3 (lift, boom, forearm)",
                  result->joint_goal.positions.size());
    why = buf;
    return Step::FAILED;
  }
  joints = result->joint_goal;
  return Step::OK;
}

VisualServoCycleNode::Step VisualServoCycleNode::move(const trajectory_msgs::JointTrajectoryPoint &joints,
                                                      std::string &why)
{
  harvest_msgs::MoveRobotGoal goal;
  goal.target_joint = joints;
  goal.arm = true;
  const Step st = runSubGoal(move_client_, goal, move_timeout_, names::MOVE_ROBOT_ACTION, why);
  if (st != Step::OK)
  {
    return st;
  }
  return moveResult(why);
}

VisualServoCycleNode::Step VisualServoCycleNode::moveResult(std::string &why)
{
  const actionlib::SimpleClientGoalState state = move_client_.getState();
  if (state != actionlib::SimpleClientGoalState::SUCCEEDED)
  {
    why = std::string(names::MOVE_ROBOT_ACTION) + " ended " + state.toString() +
          (state.getText().empty() ? "" : ": " + state.getText());
    return Step::FAILED;
  }
  const harvest_msgs::MoveRobotResultConstPtr result = move_client_.getResult();
  if (!result || result->succeed <= 0)
  {
    why = "move_robot reported failure (succeed = " + std::to_string(result ? result->succeed : 0) + ")";
    return Step::FAILED;
  }
  return Step::OK;
}

VisualServoCycleNode::Step VisualServoCycleNode::sendMove(const trajectory_msgs::JointTrajectoryPoint &joints,
                                                          bool &running, std::string &why)
{
  // The previous command may have ended on its own: a failure (halt, fault, timeout) ends the servo.
  if (running && move_client_.getState().isDone() && moveResult(why) != Step::OK)
  {
    running = false;
    return Step::FAILED;
  }
  harvest_msgs::MoveRobotGoal goal;
  goal.target_joint = joints;
  goal.arm = true;
  // A new goal replaces the running one: move_robot (SimpleActionServer) preempts it and retargets the
  // moving axes from where they are, without halting them; this client follows only the new goal.
  move_client_.sendGoal(goal);
  running = true;
  return Step::OK;
}

void VisualServoCycleNode::stopMove(bool &running)
{
  if (!running)
  {
    return;
  }
  running = false;
  if (!move_client_.getState().isDone())
  {
    move_client_.cancelGoal();  // move_robot halts the arm's axes
    move_client_.waitForResult(ros::Duration(2.0));
  }
}

void VisualServoCycleNode::finish(bool success, int iterations, double error, const std::string &message,
                                  const trajectory_msgs::JointTrajectoryPoint &last_commanded)
{
  harvest_msgs::VisualServoResult result;
  result.success = success;
  result.iterations = iterations;
  result.final_error = error;
  result.message = message;
  result.final_joint = currentLeftJoints();
  if (result.final_joint.positions.empty())
  {
    result.final_joint = last_commanded;
    ROS_WARN_THROTTLE_NAMED(10.0, LOG, "visual_servo: no left arm joints on '%s'; final_joint = last commanded",
                            names::JOINT_STATES_TOPIC);
  }
  if (success)
  {
    ROS_INFO_NAMED(LOG, "visual_servo: succeeded: %s", message.c_str());
    server_.setSucceeded(result, message);
  }
  else
  {
    ROS_INFO_NAMED(LOG, "visual_servo: aborted: %s", message.c_str());
    server_.setAborted(result, message);
  }
}

void VisualServoCycleNode::execute(const harvest_msgs::VisualServoGoalConstPtr &goal)
{
  ServoSettings s;
  double radius = 0.0;
  std::string why;
  const double nan = std::numeric_limits<double>::quiet_NaN();
  trajectory_msgs::JointTrajectoryPoint last_cmd;
  if (!makeSettings(*goal, s, radius, why))
  {
    finish(false, 0, nan, why, last_cmd);
    return;
  }
  ROS_INFO_NAMED(LOG, "visual_servo: goal: target (%.3f, %.3f, %.3f) in %s, radius %.3f m, %s mode, gain %.2f, "
                      "%s %.2f s, threshold %.1f mm, max %d iterations",
                 goal->target.point.x, goal->target.point.y, goal->target.point.z,
                 goal->target.header.frame_id.c_str(), radius, servoModeName(s.mode), s.gain,
                 s.mode == ServoMode::CONTINUOUS ? "horizon" : "dt", s.dt, s.threshold * 1e3, s.max_iterations);
  if (!waitForServers(why))
  {
    finish(false, 0, nan, why, last_cmd);
    return;
  }

  // Fixed geometry of this goal: the target in the base frame, the hand-eye transform camera <- tool.
  geometry_msgs::TransformStamped base_from_target, cam_from_tool, base_from_tool;
  if (!lookup(base_frame_, goal->target.header.frame_id, ros::Time(0), base_from_target, why) ||
      !lookup(camera_frame_, tool_frame_, ros::Time(0), cam_from_tool, why) ||
      !lookup(base_frame_, tool_frame_, ros::Time(0), base_from_tool, why))
  {
    finish(false, 0, nan, why, last_cmd);
    return;
  }
  tf2::Transform T_base_target, T_cam_tool, T_base_tool;
  tf2::fromMsg(base_from_target.transform, T_base_target);
  tf2::fromMsg(cam_from_tool.transform, T_cam_tool);
  tf2::fromMsg(base_from_tool.transform, T_base_tool);
  const tf2::Vector3 target_base = T_base_target * tf2::Vector3(goal->target.point.x, goal->target.point.y,
                                                                goal->target.point.z);
  // Desired pose: the tool centre on the peduncle, target + (0, 0, radius + gap) in the base frame. The
  // arm only turns about the vertical, so the fruit seen from the tool is the same for any forearm yaw.
  const tf2::Vector3 fruit_in_tool =
      T_base_tool.getBasis().transpose() * tf2::Vector3(0.0, 0.0, -(radius + s.peduncle_gap));
  const tf2::Vector3 p_star = T_cam_tool * fruit_in_tool;

  VisualServoControl law(s.gain, s.translation_only ? VisualServoControl::TRANSLATION : VisualServoControl::FULL);
  try
  {
    if (s.adaptive_gain_at_infinity > 0.0)
    {
      law.setAdaptiveGain(s.gain, s.adaptive_gain_at_infinity, s.adaptive_slope_at_zero);
    }
    law.setDesired(PointFeature::fromPoint(vpTranslationVector(p_star.x(), p_star.y(), p_star.z())));
  }
  catch (const std::invalid_argument &e)
  {
    finish(false, 0, nan, std::string("desired feature: ") + e.what() + " (check the hand-eye transform)", last_cmd);
    return;
  }
  ROS_INFO_NAMED(LOG, "visual_servo: desired feature x* %.4f, y* %.4f, Z* %.3f m", law.desired().x, law.desired().y,
                 law.desired().Z);

  const bool continuous = s.mode == ServoMode::CONTINUOUS;
  bool move_running = false;  // continuous mode: a move_robot goal was sent and is not waited for
  int moves = 0;
  int lost = 0;
  double error = nan;
  // every failure in the loop halts a move still running (continuous mode) before the goal ends
  auto fail = [&](const std::string &message) {
    stopMove(move_running);
    finish(false, moves, error, message, last_cmd);
  };
  while (true)
  {
    if (server_.isPreemptRequested() || !ros::ok())
    {
      stopMove(move_running);
      harvest_msgs::VisualServoResult result;
      result.iterations = moves;
      result.final_error = error;
      result.final_joint = currentLeftJoints();
      result.message = "preempted";
      ROS_INFO_NAMED(LOG, "visual_servo: preempted after %d iterations", moves);
      server_.setPreempted(result, result.message);
      return;
    }

    // 1. image feature of the target (the control law is gated on it)
    harvest_msgs::ServoFeature feature;
    Step st = requestFeature(goal->target, feature, why);
    if (st == Step::PREEMPTED)
    {
      continue;  // handled at the top of the loop
    }
    if (st == Step::FAILED)
    {
      fail("image processing failed: " + why);
      return;
    }
    if (st == Step::LOST)
    {
      ++lost;
      ROS_WARN_THROTTLE_NAMED(2.0, LOG, "visual_servo: target lost (%d/%d): %s", lost, s.max_lost, why.c_str());
      if (lost >= s.max_lost)
      {
        fail("target lost: not found in " + std::to_string(lost) + " consecutive hand camera images (" + why + ")");
        return;
      }
      continue;  // no new command while the target is not seen (continuous: the last one ends)
    }
    if (lost > 0)
    {
      ROS_INFO_NAMED(LOG, "visual_servo: target found again after %d misses", lost);
    }
    lost = 0;

    // 2. depth of the target in the hand camera and the camera pose at the image time
    geometry_msgs::TransformStamped cam_from_base_msg, base_from_tool_msg;
    if (!lookup(camera_frame_, base_frame_, feature.header.stamp, cam_from_base_msg, why) ||
        !lookup(base_frame_, tool_frame_, feature.header.stamp, base_from_tool_msg, why))
    {
      fail(why);
      return;
    }
    tf2::Transform T_cam_base, T_base_tool_now;
    tf2::fromMsg(cam_from_base_msg.transform, T_cam_base);
    tf2::fromMsg(base_from_tool_msg.transform, T_base_tool_now);
    const tf2::Vector3 target_cam = T_cam_base * target_base;
    if (!(target_cam.z() > 0.0))
    {
      fail("the target point is behind the hand camera (check the target and the tf tree)");
      return;
    }
    const PointFeature current(feature.x, feature.y, target_cam.z());

    // 3. compare with the desired feature, error expressed at the target
    error = law.errorAtTarget(current);
    harvest_msgs::VisualServoFeedback fb;
    fb.iteration = moves;
    fb.error = error;
    if (error < s.threshold)
    {
      server_.publishFeedback(fb);
      if (move_running)
      {
        // continuous: the last command (a fraction of this error away) ends before the goal does
        move_running = false;
        st = waitSubGoal(move_client_, move_timeout_, names::MOVE_ROBOT_ACTION, why);
        if (st == Step::PREEMPTED)
        {
          continue;
        }
        if (st == Step::OK)
        {
          st = moveResult(why);
        }
        if (st != Step::OK)
        {
          fail(why);
          return;
        }
      }
      char buf[160];
      std::snprintf(buf, sizeof(buf), "converged in %d iterations, error %.2f mm < %.2f mm", moves, error * 1e3,
                    s.threshold * 1e3);
      finish(true, moves, error, buf, last_cmd);
      return;
    }
    if (moves >= s.max_iterations)
    {
      server_.publishFeedback(fb);
      char buf[160];
      std::snprintf(buf, sizeof(buf), "not converged after %d iterations: error %.2f mm >= %.2f mm", moves,
                    error * 1e3, s.threshold * 1e3);
      fail(buf);
      return;
    }

    // 4. ViSP control law -> camera velocity, integrated over dt (translation only, see README)
    vpColVector v;
    try
    {
      v = law.computeControlLaw(current);
    }
    catch (const std::exception &e)
    {
      fail(std::string("control law failed: ") + e.what());
      return;
    }
    fb.iteration = moves + 1;
    fb.camera_velocity = toTwist(v);
    server_.publishFeedback(fb);
    // translation held for dt (step) or the horizon (continuous), clipped to max_step
    const ToolStep tool_step = VisualServoControl::toolStep(v, s.dt, s.max_step);
    const vpTranslationVector &step = tool_step.translation;
    if (tool_step.clipped)
    {
      ROS_WARN_THROTTLE_NAMED(2.0, LOG, "visual_servo: step %.3f m clipped to ~max_step %.3f m", tool_step.requested,
                              s.max_step);
    }
    ROS_DEBUG_NAMED(LOG, "visual_servo: iteration %d error %.2f mm v (%.4f %.4f %.4f | %.4f %.4f %.4f)", moves + 1,
                    error * 1e3, v[0], v[1], v[2], v[3], v[4], v[5]);

    // 5. the tool is rigidly attached to the camera: it translates by the same vector (base frame)
    const tf2::Vector3 step_base = T_cam_base.getBasis().transpose() * tf2::Vector3(step[0], step[1], step[2]);
    geometry_msgs::PointStamped tool_goal;
    tool_goal.header.frame_id = base_frame_;
    tool_goal.header.stamp = ros::Time::now();
    const tf2::Vector3 tool_next = T_base_tool_now.getOrigin() + step_base;
    tool_goal.point.x = tool_next.x();
    tool_goal.point.y = tool_next.y();
    tool_goal.point.z = tool_next.z();

    // 6. joint goal of the left arm, then move and wait (step) or send it and look again (continuous)
    trajectory_msgs::JointTrajectoryPoint joints;
    st = solveIk(tool_goal, joints, why);
    if (st == Step::FAILED)
    {
      fail("kinematics: " + why);
      return;
    }
    if (st == Step::PREEMPTED)
    {
      continue;
    }
    st = continuous ? sendMove(joints, move_running, why) : move(joints, why);
    if (st == Step::FAILED)
    {
      fail(why);
      return;
    }
    if (st == Step::PREEMPTED)
    {
      continue;
    }
    last_cmd = joints;
    ++moves;
  }
}

}  // namespace cooperation_pkg
