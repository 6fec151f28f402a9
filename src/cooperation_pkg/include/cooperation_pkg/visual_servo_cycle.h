/**
 * @file visual_servo_cycle.h
 * @brief The ROS-free part of the `visual_servo` node's loop (the paper's VisualServoCycleNode, Figure 25):
 *        the servo settings and a goal's overrides, the geometry of the desired and current features and of the
 *        next tool point, the stop criterion, the lost-target count and the texts the node reports. No ROS: the
 *        node (visual_servo_cycle_node.cpp) turns tf and messages into these types and calls them.
 */
#ifndef COOPERATION_PKG_VISUAL_SERVO_CYCLE_H
#define COOPERATION_PKG_VISUAL_SERVO_CYCLE_H

#include <string>
#include <vector>

#include <visp3/core/vpHomogeneousMatrix.h>
#include <visp3/core/vpRotationMatrix.h>
#include <visp3/core/vpTranslationVector.h>

#include "cooperation_pkg/visual_servo_control.h"

namespace cooperation_pkg
{
/** Tunables of one servo run (private params, dynamic_reconfigure, goal overrides). */
struct ServoSettings
{
  double gain = 0.5;                  ///< lambda [1/s]
  double adaptive_gain_at_infinity = 0.0;  ///< > 0 selects vpAdaptiveGain(gain, this, slope)
  double adaptive_slope_at_zero = 0.0;
  double dt = 1.0;                    ///< integration time of the velocity per iteration [s]
  double threshold = 0.002;           ///< stop when the error at the target is below [m]
  int max_iterations = 15;            ///< control moves before giving up
  double peduncle_gap = 0.01;         ///< tool centre above the fruit top [m]
  double default_radius = 0.035;      ///< fruit radius when the goal gives 0 [m]
  int max_lost = 3;                   ///< consecutive images without the target before aborting
  double max_step = 0.30;             ///< largest tool displacement per iteration [m]
  double max_gain_dt = 0.8;           ///< goals with gain * dt above this are rejected (divergence)
  bool translation_only = true;       ///< solve the law for translations only (SCARA)
  ServoMode mode = ServoMode::STEP;   ///< step (the paper's, wait for each move) or continuous
  double continuous_gain = 3.5;       ///< lambda in continuous mode [1/s]
  double horizon = 0.2;               ///< continuous mode: the velocity is held this long per command [s]
  int continuous_max_iterations = 150;  ///< continuous mode: commands before giving up
  double depth_probe = 0.0;           ///< > 0: sideways camera move [m] to range the fruit first (0 = off)
  double depth_probe_max_shift = 0.05;  ///< the probe's fruit centre farther than this from the target is refused [m]
  double depth_probe_max_side = 0.01;   ///< ... or farther than this to the side, across the camera's view [m]
};

/** Throws std::invalid_argument("invalid parameter: " + what) when !ok. */
void requireParameter(bool ok, const std::string &what);
/** Checks every setting (std::invalid_argument naming the first bad one, as requireParameter). */
void checkSettings(const ServoSettings &s);

/** The name of the time a velocity is held per command: "horizon" (continuous) or "dt" (step). */
const char *holdTimeName(ServoMode mode);

/**
 * The settings of the configured mode: in continuous mode gain, dt and max_iterations become
 * continuous_gain, horizon and continuous_max_iterations, with a constant gain (no adaptive gain).
 * Step mode: unchanged.
 */
ServoSettings modeSettings(const ServoSettings &configured);

/** The fields of a visual_servo goal the settings depend on (harvest_msgs/VisualServoGoal, no ROS). */
struct ServoGoalRequest
{
  double x = 0.0;              ///< target point [m]
  double y = 0.0;
  double z = 0.0;
  std::string frame_id;        ///< frame of the target point
  double target_radius = 0.0;  ///< [m], 0 = default_radius
  double gain = 0.0;           ///< 0 = the mode's gain
  double threshold = 0.0;      ///< [m], 0 = the configured threshold
  int max_iterations = 0;      ///< 0 = the mode's max_iterations
};

/**
 * The settings of one goal: modeSettings(configured) with the goal's overrides (a gain > 0 is a constant
 * gain, threshold > 0, max_iterations > 0) and the fruit radius (goal's, or default_radius for 0). False
 * with `why` ("invalid goal: ...") for a non-finite target, an empty frame, a radius outside [0, 0.2] m,
 * negative overrides, or gain * dt (horizon) above max_gain_dt.
 */
bool goalSettings(const ServoSettings &configured, const ServoGoalRequest &goal, ServoSettings &s, double &radius,
                  std::string &why);

/**
 * The desired point P* (fruit centre in the camera frame) when the tool centre is on the peduncle:
 * the fruit centre is (0, 0, -(radius + peduncle_gap)) below the tool centre in the base frame, rotated
 * into the tool frame with base_R_tool and then into the camera frame with the hand-eye transform
 * cam_M_tool. The arm only turns about the vertical, so P* is the same for any forearm yaw.
 */
vpTranslationVector desiredTargetPoint(const vpHomogeneousMatrix &cam_M_tool, const vpRotationMatrix &base_R_tool,
                                       double radius, double peduncle_gap);

/**
 * The current feature: the image point (x, y) with the depth of the target point in the camera frame
 * (target_cam = cam_M_base * target_base). False when the target is not in front of the camera (Z <= 0 or NaN).
 */
bool currentFeature(double x, double y, const vpTranslationVector &target_cam, PointFeature &current);

/**
 * Where the tool goes: the tool is rigidly attached to the camera, so it translates by the camera-frame
 * step too, expressed in the base frame with cam_R_base (transposed): tool_base + cam_R_base^T step.
 */
vpTranslationVector nextToolPoint(const vpRotationMatrix &cam_R_base, const vpTranslationVector &tool_base,
                                  const vpTranslationVector &step);

/** The fruit centre ranged by the hand camera from two poses (depth probe), or why not. */
struct ProbeFix
{
  bool ok = false;
  vpTranslationVector point;  ///< base frame [m]
  double gap = 0.0;           ///< distance between the two viewing rays at their closest [m]
  std::string why;            ///< when !ok
};

/**
 * Motion stereo of the eye-in-hand camera: the fruit centre seen at the normalized image points (x1, y1) and
 * (x2, y2) from two camera poses base_M_cam1, base_M_cam2 (the camera moved sideways between the two images).
 * The point is the middle of the two viewing rays' closest points. Not ok (with why) when the rays are nearly
 * parallel (less than 0.5 degree apart), the point is not in front of both cameras, the rays pass farther than
 * max_gap apart, or the point lies farther than max_shift from `expected` (the stereo head's target) or farther
 * than max_side from it across the first camera's view (perpendicular to its optical axis): the stereo head's
 * error is its depth, and both cameras look at the plant, so a centre far to the side is another fruit the hand
 * camera took for the target (a cherry truss).
 */
ProbeFix triangulateProbe(const vpHomogeneousMatrix &base_M_cam1, double x1, double y1,
                          const vpHomogeneousMatrix &base_M_cam2, double x2, double y2,
                          const vpTranslationVector &expected, double max_shift, double max_side,
                          double max_gap = 0.005);

/** The stop criterion of one image. */
enum class ServoVerdict
{
  CONVERGED,  ///< error < threshold
  GIVE_UP,    ///< not converged and max_iterations moves made
  MOVE        ///< compute the law and command the next move
};
/** error < threshold: CONVERGED; else moves >= max_iterations: GIVE_UP; else MOVE (a NaN error never converges). */
ServoVerdict judgeError(double error, double threshold, int moves, int max_iterations);
/** "converged in N iterations, error E mm < T mm". */
std::string convergedMessage(int moves, double error, double threshold);
/** "not converged after N iterations: error E mm >= T mm". */
std::string notConvergedMessage(int moves, double error, double threshold);

/** Consecutive hand camera images without the target (the node aborts at max_lost). */
class LostTargetCount
{
public:
  explicit LostTargetCount(int max_lost) : max_lost_(max_lost) {}
  /** One more image without the target; true when max_lost consecutive misses are reached. */
  bool miss() { return ++lost_ >= max_lost_; }
  /** The target was seen: the count restarts; returns the misses before it (0: none). */
  int found()
  {
    const int before = lost_;
    lost_ = 0;
    return before;
  }
  int count() const { return lost_; }

private:
  int max_lost_;
  int lost_ = 0;
};
/** "target lost: not found in N consecutive hand camera images (why)". */
std::string lostMessage(int lost, const std::string &why);

/** "NAME did not answer within T s" (a sub-goal's timeout). */
std::string timeoutMessage(const char *name, double timeout);
/** "NAME ended STATE" plus ": TEXT" when the goal's text is not empty (a sub-goal that did not succeed). */
std::string endedMessage(const std::string &name, const std::string &state, const std::string &text);

/**
 * Keeps the latest position of every joint: each (in_names[i], in_positions[i]) updates the joint of that
 * name in (names, positions) or is appended (several publishers may each send a subset). Pairs beyond
 * the shorter of in_names and in_positions are ignored.
 */
void mergeJointPositions(std::vector<std::string> &names, std::vector<double> &positions,
                         const std::vector<std::string> &in_names, const std::vector<double> &in_positions);
/** The positions of `wanted` in that order, or an empty vector when one of them is missing. */
std::vector<double> selectJointPositions(const std::vector<std::string> &names, const std::vector<double> &positions,
                                         const std::vector<std::string> &wanted);

}  // namespace cooperation_pkg

#endif  // COOPERATION_PKG_VISUAL_SERVO_CYCLE_H
