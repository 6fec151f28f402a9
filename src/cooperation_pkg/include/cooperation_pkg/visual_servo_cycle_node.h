/**
 * @file visual_servo_cycle_node.h
 * @brief The `visual_servo` action server: the eye-hand coordination loop of the paper's Figure 25
 *        (class VisualServoCycleNode of Figure 26). The control law lives in VisualServoControl, the loop's
 *        settings, geometry and stop policy in visual_servo_cycle.h (ServoSettings is declared there). The
 *        server side (parameters, goal, loop) is src/visual_servo_cycle_node.cpp, the client side (sub-goals,
 *        tf, joint_states) src/visual_servo_clients.cpp.
 */
#ifndef COOPERATION_PKG_VISUAL_SERVO_CYCLE_NODE_H
#define COOPERATION_PKG_VISUAL_SERVO_CYCLE_NODE_H

#include <memory>
#include <mutex>
#include <string>

#include <actionlib/client/simple_action_client.h>
#include <actionlib/server/simple_action_server.h>
#include <dynamic_reconfigure/server.h>
#include <geometry_msgs/PointStamped.h>
#include <ros/ros.h>
#include <sensor_msgs/JointState.h>
#include <tf2_ros/buffer.h>
#include <tf2_ros/transform_listener.h>
#include <trajectory_msgs/JointTrajectoryPoint.h>

#include <harvest_msgs/ImageProcessingAction.h>
#include <harvest_msgs/KinematicsAction.h>
#include <harvest_msgs/MoveRobotAction.h>
#include <harvest_msgs/VisualServoAction.h>

#include "cooperation_pkg/VisualServoConfig.h"
#include "cooperation_pkg/visual_servo_control.h"
#include "cooperation_pkg/visual_servo_cycle.h"

namespace cooperation_pkg
{
/** The logger name of the node's messages (ROS_*_NAMED). */
constexpr char VISUAL_SERVO_LOG[] = "visual_servo";

class VisualServoCycleNode
{
public:
  VisualServoCycleNode(ros::NodeHandle nh, ros::NodeHandle pnh);
  ~VisualServoCycleNode();

private:
  typedef actionlib::SimpleActionServer<harvest_msgs::VisualServoAction> Server;
  typedef actionlib::SimpleActionClient<harvest_msgs::ImageProcessingAction> ImageClient;
  typedef actionlib::SimpleActionClient<harvest_msgs::KinematicsAction> KinematicsClient;
  typedef actionlib::SimpleActionClient<harvest_msgs::MoveRobotAction> MoveClient;

  /** Outcome of one step of the loop. */
  enum class Step
  {
    OK,
    LOST,       ///< image processing answered, but without the target
    FAILED,     ///< a sub-action failed / timed out or a transform is missing (message set)
    PREEMPTED   ///< the visual_servo goal was preempted (sub-goal cancelled)
  };

  void execute(const harvest_msgs::VisualServoGoalConstPtr &goal);
  void jointStatesCallback(const sensor_msgs::JointState::ConstPtr &msg);
  void reconfigure(VisualServoConfig &config, uint32_t level);

  bool makeSettings(const harvest_msgs::VisualServoGoal &goal, ServoSettings &s, double &radius,
                    std::string &why) const;
  bool waitForServers(std::string &why);
  /** The tool point (base frame) as a kinematics target, stamped now. */
  geometry_msgs::PointStamped toolGoal(const vpTranslationVector &tool_base) const;
  /** depth_probe: ranges the fruit centre with the hand camera from two poses ~depth_probe apart sideways and
   *  puts it in target_base (kept when the probe cannot range it); FAILED only when the sideways move failed. */
  Step probeDepth(const harvest_msgs::VisualServoGoal &goal, const ServoSettings &s, vpTranslationVector &target_base,
                  trajectory_msgs::JointTrajectoryPoint &last_cmd, std::string &why);
  /** How far (m, in `off`) tf's tool at an image time (base_from_tool_at_image) is from tf's tool
   *  now: the arm stood still for the image when it is near 0 (the depth probe, step mode). False
   *  with `why` when tf has no latest pose. */
  bool toolOffsetFromNow(const geometry_msgs::TransformStamped &base_from_tool_at_image, double &off,
                         std::string &why) const;
  Step requestFeature(const geometry_msgs::PointStamped &target, harvest_msgs::ServoFeature &feature,
                      std::string &why);
  Step solveIk(const geometry_msgs::PointStamped &tool_point, trajectory_msgs::JointTrajectoryPoint &joints,
               std::string &why);
  Step move(const trajectory_msgs::JointTrajectoryPoint &joints, std::string &why);
  /** Sends a sub-goal and waits for it, cancelling it on preempt or timeout. */
  template <class Client, class Goal>
  Step runSubGoal(Client &client, const Goal &goal, double timeout, const char *name, std::string &why);
  /** Waits for the client's current goal (cancelling it on preempt or timeout). */
  template <class Client>
  Step waitSubGoal(Client &client, double timeout, const char *name, std::string &why);
  /** Checks the result of a finished move_robot goal. */
  Step moveResult(std::string &why);
  /** Continuous mode: sends the joint goal without waiting; it replaces the running one. */
  Step sendMove(const trajectory_msgs::JointTrajectoryPoint &joints, bool &running, std::string &why);
  /** Cancels a running move_robot goal (move_robot halts the arm) and waits briefly for its end. */
  void stopMove(bool &running);
  bool lookup(const std::string &target, const std::string &source, const ros::Time &stamp,
              geometry_msgs::TransformStamped &out, std::string &why) const;
  trajectory_msgs::JointTrajectoryPoint currentLeftJoints() const;
  void finish(bool success, int iterations, double error, const std::string &message,
              const trajectory_msgs::JointTrajectoryPoint &last_commanded);

  ros::NodeHandle nh_;
  ros::NodeHandle pnh_;
  std::string base_frame_;
  std::string camera_frame_;
  std::string tool_frame_;
  double image_timeout_;
  double kinematics_timeout_;
  double move_timeout_;
  double server_timeout_;
  double tf_timeout_;

  mutable std::mutex settings_mutex_;
  ServoSettings settings_;

  mutable std::mutex joints_mutex_;
  sensor_msgs::JointState last_joint_state_;

  tf2_ros::Buffer tf_buffer_;
  tf2_ros::TransformListener tf_listener_;
  ImageClient image_client_;
  KinematicsClient kinematics_client_;
  MoveClient move_client_;
  ros::Subscriber joint_sub_;
  std::unique_ptr<dynamic_reconfigure::Server<VisualServoConfig>> reconfigure_server_;
  Server server_;
};

}  // namespace cooperation_pkg

#endif  // COOPERATION_PKG_VISUAL_SERVO_CYCLE_NODE_H
