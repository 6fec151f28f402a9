/**
 * @file visual_servo_clients.cpp
 * @brief What the visual_servo loop asks of the rest of the robot (VisualServoCycleNode, see
 *        visual_servo_cycle_node.h): the sub-goals (image_processing feature request, kinematics IK request,
 *        move_robot moves waited for in step mode or replaced in continuous mode, each cancelled on preempt or
 *        timeout), the tf lookups and the left arm joints from joint_states.
 */
#include "cooperation_pkg/visual_servo_cycle_node.h"

#include <cmath>
#include <cstdio>
#include <iterator>

#include "cooperation_pkg/names.h"

namespace cooperation_pkg
{
void VisualServoCycleNode::jointStatesCallback(const sensor_msgs::JointState::ConstPtr &msg)
{
  std::lock_guard<std::mutex> lock(joints_mutex_);
  mergeJointPositions(last_joint_state_.name, last_joint_state_.position, msg->name, msg->position);
  last_joint_state_.header = msg->header;
}

trajectory_msgs::JointTrajectoryPoint VisualServoCycleNode::currentLeftJoints() const
{
  trajectory_msgs::JointTrajectoryPoint p;
  const std::vector<std::string> left(std::begin(names::LEFT_ARM_JOINTS), std::end(names::LEFT_ARM_JOINTS));
  std::lock_guard<std::mutex> lock(joints_mutex_);
  p.positions = selectJointPositions(last_joint_state_.name, last_joint_state_.position, left);
  return p;
}

bool VisualServoCycleNode::lookup(const std::string &target, const std::string &source, const ros::Time &stamp,
                                  geometry_msgs::TransformStamped &out, std::string &why) const
{
  std::string err;
  if (!stamp.isZero())
  {
    // at that time or not at all: the latest transform may be from before the last move (tf
    // late on a busy machine), and an image paired with another time's pose misleads the law
    if (tf_buffer_.canTransform(target, source, stamp, ros::Duration(tf_timeout_), &err))
    {
      out = tf_buffer_.lookupTransform(target, source, stamp);
      return true;
    }
    why = "no transform " + target + " <- " + source + " at the image time: " + err;
    return false;
  }
  if (!tf_buffer_.canTransform(target, source, ros::Time(0), ros::Duration(tf_timeout_), &err))
  {
    why = "no transform " + target + " <- " + source + ": " + err;
    return false;
  }
  out = tf_buffer_.lookupTransform(target, source, ros::Time(0));
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
      why = timeoutMessage(name, timeout);
      return Step::FAILED;
    }
  }
  const actionlib::SimpleClientGoalState state = client.getState();
  if (state != actionlib::SimpleClientGoalState::SUCCEEDED)
  {
    why = endedMessage(name, state.toString(), state.getText());
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
  if (!std::isfinite(feature.x) || !std::isfinite(feature.y))
  {
    why = "image feature is not finite";
    return Step::LOST;
  }
  if (!feature.header.frame_id.empty() && feature.header.frame_id != camera_frame_)
  {
    ROS_WARN_THROTTLE_NAMED(10.0, VISUAL_SERVO_LOG, "visual_servo: feature frame '%s' differs from ~camera_frame '%s'",
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
    why = endedMessage(names::MOVE_ROBOT_ACTION, state.toString(), state.getText());
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

// execute() (visual_servo_cycle_node.cpp) waits for the last continuous-mode move.
template VisualServoCycleNode::Step VisualServoCycleNode::waitSubGoal<VisualServoCycleNode::MoveClient>(
    MoveClient &client, double timeout, const char *name, std::string &why);

}  // namespace cooperation_pkg
