/**
 * @file names.h
 * @brief Relative names of the topics and actions used by the visual_servo node (wired by launch remaps).
 */
#ifndef COOPERATION_PKG_NAMES_H
#define COOPERATION_PKG_NAMES_H

namespace cooperation_pkg
{
namespace names
{
constexpr char VISUAL_SERVO_ACTION[] = "visual_servo";
constexpr char IMAGE_PROCESSING_ACTION[] = "image_processing";
constexpr char KINEMATICS_ACTION[] = "kinematics";
constexpr char MOVE_ROBOT_ACTION[] = "move_robot";
constexpr char JOINT_STATES_TOPIC[] = "joint_states";
/** Left (cutting) arm joints in the order of Kinematics/MoveRobot joint points: lift, boom, forearm. */
constexpr const char *LEFT_ARM_JOINTS[3] = { "left_lift_joint", "left_boom_joint", "left_forearm_joint" };
}  // namespace names
}  // namespace cooperation_pkg

#endif  // COOPERATION_PKG_NAMES_H
