/**
 * @file visual_servo_cycle_node.cpp
 * @brief The visual servo loop (Figure 25): feature -> error -> ViSP law -> integrate -> IK -> move.
 */
#include "cooperation_pkg/visual_servo_cycle_node.h"

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
const char *const LOG = VISUAL_SERVO_LOG;
/// depth probe: tf at an image time within this of tf now (m): the tool stood still for the image
const double PROBE_STILL_TOLERANCE = 0.0005;
/// depth probe: after the sideways move the tool at the image time within this of its goal (m)
const double PROBE_GOAL_TOLERANCE = 0.0025;
/// depth probe: images taken for one view before the probe is skipped
const int PROBE_IMAGE_TRIES = 3;
/// step mode: tf at an image time within this of tf now (m), as the arm is at rest for every image
const double STEP_STILL_TOLERANCE = 0.001;

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

/** The transform of a tf message as a ViSP homogeneous matrix (tf2's rotation matrix, copied). */
vpHomogeneousMatrix toHomogeneous(const geometry_msgs::TransformStamped &msg)
{
  tf2::Transform T;
  tf2::fromMsg(msg.transform, T);
  vpHomogeneousMatrix M;
  for (int i = 0; i < 3; ++i)
  {
    for (int j = 0; j < 3; ++j)
    {
      M[i][j] = T.getBasis()[i][j];
    }
    M[i][3] = T.getOrigin()[i];
  }
  return M;
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
  pnh_.param("depth_probe", s.depth_probe, s.depth_probe);
  pnh_.param("depth_probe_max_shift", s.depth_probe_max_shift, s.depth_probe_max_shift);
  pnh_.param("depth_probe_max_side", s.depth_probe_max_side, s.depth_probe_max_side);
  std::string mode;
  pnh_.param<std::string>("mode", mode, "step");
  requireParameter(parseServoMode(mode, s.mode), "~mode must be 'step' or 'continuous'");
  std::string dof_mode;
  pnh_.param<std::string>("dof_mode", dof_mode, "translation");
  requireParameter(dof_mode == "translation" || dof_mode == "full", "~dof_mode must be 'translation' or 'full'");
  s.translation_only = (dof_mode == "translation");
  requireParameter(image_timeout_ > 0.0 && kinematics_timeout_ > 0.0 && move_timeout_ > 0.0 &&
                       server_timeout_ > 0.0 && tf_timeout_ > 0.0,
                   "timeouts (~image_timeout, ~kinematics_timeout, ~move_timeout, ~server_timeout, ~tf_timeout) "
                   "must be > 0 [s]");
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
  s.depth_probe = config.depth_probe;
  try
  {
    requireParameter(parseServoMode(config.mode, s.mode), "mode must be 'step' or 'continuous'");
    checkSettings(s);
    settings_ = s;
    ROS_INFO_NAMED(LOG, "visual_servo: settings for the next goal: %s mode, gain %.3f, dt %.3f s, threshold %.4f m, "
                        "max_iterations %d, peduncle_gap %.3f m, max_step %.3f m, continuous_gain %.3f, "
                        "horizon %.3f s, continuous_max_iterations %d, depth_probe %.3f m",
                   servoModeName(s.mode), s.gain, s.dt, s.threshold, s.max_iterations, s.peduncle_gap, s.max_step,
                   s.continuous_gain, s.horizon, s.continuous_max_iterations, s.depth_probe);
  }
  catch (const std::invalid_argument &e)
  {
    ROS_WARN_NAMED(LOG, "visual_servo: reconfigure rejected: %s", e.what());
  }
}

bool VisualServoCycleNode::makeSettings(const harvest_msgs::VisualServoGoal &goal, ServoSettings &s, double &radius,
                                        std::string &why) const
{
  ServoSettings configured;
  {
    std::lock_guard<std::mutex> lock(settings_mutex_);
    configured = settings_;
  }
  ServoGoalRequest request;
  request.x = goal.target.point.x;
  request.y = goal.target.point.y;
  request.z = goal.target.point.z;
  request.frame_id = goal.target.header.frame_id;
  request.target_radius = goal.target_radius;
  request.gain = goal.gain;
  request.threshold = goal.threshold;
  request.max_iterations = goal.max_iterations;
  return goalSettings(configured, request, s, radius, why);
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

geometry_msgs::PointStamped VisualServoCycleNode::toolGoal(const vpTranslationVector &tool_base) const
{
  geometry_msgs::PointStamped goal;
  goal.header.frame_id = base_frame_;
  goal.header.stamp = ros::Time::now();
  goal.point.x = tool_base[0];
  goal.point.y = tool_base[1];
  goal.point.z = tool_base[2];
  return goal;
}

VisualServoCycleNode::Step VisualServoCycleNode::probeDepth(const harvest_msgs::VisualServoGoal &goal,
                                                             const ServoSettings &s, vpTranslationVector &target_base,
                                                             trajectory_msgs::JointTrajectoryPoint &last_cmd,
                                                             std::string &why)
{
  // two hand camera images, the camera moved ~depth_probe to its side in between; a probe that cannot
  // range the fruit (not seen, refused) leaves the target as it was: only a failed move ends the goal
  harvest_msgs::ServoFeature seen[2];
  vpHomogeneousMatrix base_M_cam[2];
  bool moved = false;         // the sideways move is done: the second image is after it
  vpTranslationVector sideways;  // the tool point it was sent to
  for (int k = 0; k < 2; ++k)
  {
    geometry_msgs::TransformStamped base_from_cam, base_from_tool;
    // Each image must show the tool standing still: tf at the image time must agree with tf now
    // (and, after the sideways move, with its goal). A millimetre of pose error is several of
    // depth over the short baseline, and on a busy machine tf at an image time just after a move
    // can still hold the move (joint states stamped late); then the next image is taken.
    for (int attempt = 1;; ++attempt)
    {
      Step st = requestFeature(goal.target, seen[k], why);
      if (st != Step::OK)
      {
        ROS_WARN_NAMED(LOG, "visual_servo: depth probe skipped (image %d: %s)", k + 1,
                       st == Step::LOST ? "target not seen" : why.c_str());
        return st == Step::PREEMPTED ? st : Step::OK;
      }
      double off_now = 0.0;
      if (!lookup(base_frame_, camera_frame_, seen[k].header.stamp, base_from_cam, why) ||
          !lookup(base_frame_, tool_frame_, seen[k].header.stamp, base_from_tool, why) ||
          !toolOffsetFromNow(base_from_tool, off_now, why))
      {
        ROS_WARN_NAMED(LOG, "visual_servo: depth probe skipped (%s)", why.c_str());
        return Step::OK;
      }
      const vpTranslationVector at = toHomogeneous(base_from_tool).getTranslationVector();
      const double off_goal = moved ? (at - sideways).frobeniusNorm() : 0.0;
      if (off_now <= PROBE_STILL_TOLERANCE && off_goal <= PROBE_GOAL_TOLERANCE)
      {
        break;
      }
      if (attempt >= PROBE_IMAGE_TRIES)
      {
        ROS_WARN_NAMED(LOG, "visual_servo: depth probe skipped (image %d: the tool not standing still at the "
                            "image time in %d images: %.1f mm from where it stands, %.1f mm from its goal)",
                       k + 1, attempt, off_now * 1e3, off_goal * 1e3);
        return Step::OK;
      }
      ROS_INFO_NAMED(LOG, "visual_servo: depth probe image %d: at the image time the tool is %.1f mm from where it "
                          "stands, %.1f mm from its goal; another image", k + 1, off_now * 1e3, off_goal * 1e3);
    }
    base_M_cam[k] = toHomogeneous(base_from_cam);
    if (k == 1)
    {
      break;
    }
    // sideways: along the camera's x axis (horizontal), the tool rigidly with it
    sideways = nextToolPoint(base_M_cam[0].getRotationMatrix().t(),
                             toHomogeneous(base_from_tool).getTranslationVector(),
                             vpTranslationVector(s.depth_probe, 0.0, 0.0));
    const geometry_msgs::PointStamped tool_goal = toolGoal(sideways);
    trajectory_msgs::JointTrajectoryPoint joints;
    Step st = solveIk(tool_goal, joints, why);
    if (st == Step::PREEMPTED)
    {
      return st;
    }
    if (st != Step::OK)
    {
      ROS_WARN_NAMED(LOG, "visual_servo: depth probe skipped (no sideways move: %s)", why.c_str());
      return Step::OK;
    }
    st = move(joints, why);
    if (st != Step::OK)
    {
      return st;  // a failed move: the arm is not where it was asked to go
    }
    last_cmd = joints;
    moved = true;
  }
  const ProbeFix fix = triangulateProbe(base_M_cam[0], seen[0].x, seen[0].y, base_M_cam[1], seen[1].x, seen[1].y,
                                        target_base, s.depth_probe_max_shift, s.depth_probe_max_side);
  if (!fix.ok)
  {
    ROS_WARN_NAMED(LOG, "visual_servo: depth probe refused (%s); the target's depth is kept", fix.why.c_str());
    return Step::OK;
  }
  const vpTranslationVector shift = fix.point - target_base;
  ROS_INFO_NAMED(LOG, "visual_servo: depth probe: the fruit centre is (%.1f, %.1f, %.1f) mm from the target "
                      "(rays %.1f mm apart)",
                 shift[0] * 1e3, shift[1] * 1e3, shift[2] * 1e3, fix.gap * 1e3);
  target_base = fix.point;
  return Step::OK;
}

bool VisualServoCycleNode::toolOffsetFromNow(const geometry_msgs::TransformStamped &base_from_tool_at_image,
                                             double &off, std::string &why) const
{
  geometry_msgs::TransformStamped base_from_tool_now;
  if (!lookup(base_frame_, tool_frame_, ros::Time(0), base_from_tool_now, why))
  {
    return false;
  }
  off = (toHomogeneous(base_from_tool_at_image).getTranslationVector() -
         toHomogeneous(base_from_tool_now).getTranslationVector())
            .frobeniusNorm();
  return true;
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
                 holdTimeName(s.mode), s.dt, s.threshold * 1e3, s.max_iterations);
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
  const vpHomogeneousMatrix T_base_target = toHomogeneous(base_from_target);
  const vpHomogeneousMatrix T_cam_tool = toHomogeneous(cam_from_tool);
  const vpHomogeneousMatrix T_base_tool = toHomogeneous(base_from_tool);
  vpTranslationVector target_base =
      T_base_target * vpTranslationVector(goal->target.point.x, goal->target.point.y, goal->target.point.z);
  // Desired pose: the tool centre on the peduncle, target + (0, 0, radius + gap) in the base frame.
  const vpTranslationVector p_star =
      desiredTargetPoint(T_cam_tool, T_base_tool.getRotationMatrix(), radius, s.peduncle_gap);

  VisualServoControl law(s.gain, s.translation_only ? VisualServoControl::TRANSLATION : VisualServoControl::FULL);
  try
  {
    if (s.adaptive_gain_at_infinity > 0.0)
    {
      law.setAdaptiveGain(s.gain, s.adaptive_gain_at_infinity, s.adaptive_slope_at_zero);
    }
    law.setDesired(PointFeature::fromPoint(p_star));
  }
  catch (const std::invalid_argument &e)
  {
    finish(false, 0, nan, std::string("desired feature: ") + e.what() + " (check the hand-eye transform)", last_cmd);
    return;
  }
  ROS_INFO_NAMED(LOG, "visual_servo: desired feature x* %.4f, y* %.4f, Z* %.3f m", law.desired().x, law.desired().y,
                 law.desired().Z);

  if (s.depth_probe > 0.0)
  {
    // the stereo head's depth of the fruit is the loop's depth: range it with the hand camera first
    const Step st = probeDepth(*goal, s, target_base, last_cmd, why);
    if (st == Step::FAILED)
    {
      finish(false, 0, nan, "depth probe: " + why, last_cmd);
      return;
    }
  }

  const bool continuous = s.mode == ServoMode::CONTINUOUS;
  bool move_running = false;  // continuous mode: a move_robot goal was sent and is not waited for
  int moves = 0;
  LostTargetCount lost(s.max_lost);
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
    // 2. the hand camera's pose at the image time (the depth of the target in it)
    geometry_msgs::TransformStamped cam_from_base_msg, base_from_tool_msg;
    if (st == Step::OK &&
        (!lookup(camera_frame_, base_frame_, feature.header.stamp, cam_from_base_msg, why) ||
         !lookup(base_frame_, tool_frame_, feature.header.stamp, base_from_tool_msg, why)))
    {
      // tf has no pose at the image time yet (a busy machine): this image counts as one without
      // the target and the next one is taken; a pose of another time would be wrong (one from
      // before the approach move put the target behind the camera)
      st = Step::LOST;
    }
    double off_now = 0.0;
    if (st == Step::OK && !continuous)
    {
      // step mode takes every image with the arm at rest, so tf at the image time must agree with
      // tf now; on a busy machine it can still hold the last move (joint states stamped late)
      if (!toolOffsetFromNow(base_from_tool_msg, off_now, why))
      {
        st = Step::LOST;
      }
      else if (off_now > STEP_STILL_TOLERANCE)
      {
        char buf[200];
        std::snprintf(buf, sizeof(buf),
                      "tf at the image time still holds a move: the tool %.1f mm from where it stands", off_now * 1e3);
        why = buf;
        st = Step::LOST;
      }
    }
    PointFeature current;
    vpHomogeneousMatrix T_cam_base, T_base_tool_now;
    if (st == Step::OK)
    {
      T_cam_base = toHomogeneous(cam_from_base_msg);
      T_base_tool_now = toHomogeneous(base_from_tool_msg);
      if (!currentFeature(feature.x, feature.y, T_cam_base * target_base, current))
      {
        // the image shows the fruit, so the camera's pose at its time puts the target where
        // the camera cannot see it: that pose is another time's (or the target or the tf tree
        // is wrong, and every image says so until the lost limit)
        why = "the target point is behind the hand camera at the image time (check the target and the tf tree)";
        st = Step::LOST;
      }
    }
    if (st == Step::LOST)
    {
      const bool give_up = lost.miss();
      ROS_WARN_THROTTLE_NAMED(2.0, LOG, "visual_servo: target lost (%d/%d): %s", lost.count(), s.max_lost,
                              why.c_str());
      if (give_up)
      {
        fail(lostMessage(lost.count(), why));
        return;
      }
      continue;  // no new command while the target is not seen (continuous: the last one ends)
    }
    const int misses = lost.found();
    if (misses > 0)
    {
      ROS_INFO_NAMED(LOG, "visual_servo: target found again after %d misses", misses);
    }

    // 3. compare with the desired feature, error expressed at the target
    error = law.errorAtTarget(current);
    harvest_msgs::VisualServoFeedback fb;
    fb.iteration = moves;
    fb.error = error;
    const ServoVerdict verdict = judgeError(error, s.threshold, moves, s.max_iterations);
    if (verdict == ServoVerdict::CONVERGED)
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
      finish(true, moves, error, convergedMessage(moves, error, s.threshold), last_cmd);
      return;
    }
    if (verdict == ServoVerdict::GIVE_UP)
    {
      server_.publishFeedback(fb);
      fail(notConvergedMessage(moves, error, s.threshold));
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
    const geometry_msgs::PointStamped tool_goal =
        toolGoal(nextToolPoint(T_cam_base.getRotationMatrix(), T_base_tool_now.getTranslationVector(), step));

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
