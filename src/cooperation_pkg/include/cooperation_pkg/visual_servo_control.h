/**
 * @file visual_servo_control.h
 * @brief The eye-in-hand IBVS control law (the paper's VisualServoControlNode, Figure 26), no ROS.
 *
 * Visual features (ViSP): a point s = (x, y) in normalized image coordinates (vpFeaturePoint,
 * interaction matrix evaluated with the point's depth Z) plus the depth feature
 * s_Z = log(Z / Z*) (vpFeatureDepth), i.e. three features for the fruit centre. The task is
 * vpServo::EYEINHAND_CAMERA with the interaction matrix at the current features
 * (vpServo::CURRENT) and its pseudo-inverse:  v = -lambda * pinv(L) * (s - s*).
 *
 * Degrees of freedom: the SCARA cutting arm only *translates* its tool centre; the camera
 * orientation follows from the inverse kinematics (yaw of the forearm, optical axis horizontal)
 * and cannot be commanded. In the default mode (DofMode::TRANSLATION) the law is solved for the
 * three camera translations only (vpServo::setCameraDoF(1,1,1,0,0,0)): the rotational components
 * of the returned 6-vector are exactly zero, and v_t = -lambda * inv(L_t) * e. DofMode::FULL
 * solves for all six components (the textbook minimum-norm law); a caller on a translating
 * robot must then drop the rotation (dropRotation()), which makes the closed loop slower, since
 * part of the correction was assigned to the rotations. FULL is kept for comparison.
 */
#ifndef COOPERATION_PKG_VISUAL_SERVO_CONTROL_H
#define COOPERATION_PKG_VISUAL_SERVO_CONTROL_H

#include <string>

#include <visp3/core/vpColVector.h>
#include <visp3/core/vpHomogeneousMatrix.h>
#include <visp3/core/vpTranslationVector.h>
#include <visp3/visual_features/vpFeatureDepth.h>
#include <visp3/visual_features/vpFeaturePoint.h>
#include <visp3/vs/vpServo.h>

namespace cooperation_pkg
{
/** Image feature of the fruit centre: normalized image coordinates and depth along z [m]. */
struct PointFeature
{
  double x;
  double y;
  double Z;
  PointFeature() : x(0.0), y(0.0), Z(1.0) {}
  PointFeature(double x_, double y_, double Z_) : x(x_), y(y_), Z(Z_) {}
  /** The 3D point (x Z, y Z, Z) in the camera frame [m]. */
  vpTranslationVector point() const { return vpTranslationVector(x * Z, y * Z, Z); }
  /** The feature of a 3D point given in the camera frame (Z must be > 0). */
  static PointFeature fromPoint(const vpTranslationVector &p);
  /** True when x, y, Z are finite and Z > 0. */
  bool valid() const;
};

/**
 * How the visual_servo node drives the arm with the law's velocity v (README "Modes"):
 * STEP (the paper's): the tool moves by v held for dt (1 s) and the node waits for the move to end
 * before it looks again; CONTINUOUS: at every new image the tool is sent towards where v leads over a
 * short horizon (about one camera period), replacing the running move without waiting for it.
 */
enum class ServoMode
{
  STEP = 0,
  CONTINUOUS = 1
};

/** "step" or "continuous" -> mode; false (mode unchanged) for any other text. */
bool parseServoMode(const std::string &text, ServoMode &mode);
/** "step" or "continuous". */
const char *servoModeName(ServoMode mode);

/** The tool displacement of one control command (camera frame, translation only). */
struct ToolStep
{
  vpTranslationVector translation;  ///< [m]
  double requested = 0.0;           ///< length before clipping [m]
  bool clipped = false;             ///< longer than max_step, scaled down to it
};

class VisualServoControl
{
public:
  enum DofMode
  {
    TRANSLATION = 0,  ///< only vx, vy, vz (SCARA arm); rotations are zero
    FULL = 1          ///< all six camera velocity components
  };

  explicit VisualServoControl(double gain = 0.5, DofMode mode = TRANSLATION);
  VisualServoControl(const VisualServoControl &) = delete;
  VisualServoControl &operator=(const VisualServoControl &) = delete;

  /** Constant gain lambda [1/s] (> 0). */
  void setGain(double gain);
  /** Adaptive gain (vpAdaptiveGain): lambda(|e|inf) = (l0 - linf) exp(-slope0 / (l0 - linf) |e|inf) + linf. */
  void setAdaptiveGain(double gain_at_zero, double gain_at_infinity, double slope_at_zero);
  void setDofMode(DofMode mode);
  DofMode dofMode() const { return mode_; }

  /** Desired feature (x*, y*, Z*) (Z* > 0). */
  void setDesired(const PointFeature &desired);
  const PointFeature &desired() const { return desired_; }

  /**
   * Camera velocity [vx vy vz wx wy wz] in the camera frame (m/s, rad/s) for the current
   * feature. Throws std::invalid_argument for an invalid feature (non-finite, Z <= 0).
   */
  vpColVector computeControlLaw(const PointFeature &current);

  /** Feature error s - s* = (x - x*, y - y*, log(Z / Z*)) of the last computeControlLaw(). */
  vpColVector featureError() const { return task_.getError(); }
  /** Interaction matrix (3x6) used by the last computeControlLaw(). */
  vpMatrix interactionMatrix() const { return task_.getInteractionMatrix(); }
  /** Gain used by the last computeControlLaw() [1/s]. */
  double lastGain() const { return last_gain_; }

  /**
   * Feature error expressed at the target in metres: |P - P*| with P = (x Z, y Z, Z), the
   * distance the camera (and the rigidly attached tool) still has to translate.
   */
  double errorAtTarget(const PointFeature &current) const;

  /** Displacement c_M_c' of the camera when the velocity v is held for dt seconds (exponential map). */
  static vpHomogeneousMatrix integrate(const vpColVector &v, double dt);
  /** v with the rotational components set to zero. */
  static vpColVector dropRotation(const vpColVector &v);
  /**
   * The command of either mode: the translation of the camera (and of the rigidly attached tool) when
   * the translational part of v is held for `horizon` seconds (dt in STEP mode, the short horizon in
   * CONTINUOUS mode), scaled down to `max_step` [m] when longer. Throws std::invalid_argument for
   * horizon <= 0 or max_step <= 0.
   */
  static ToolStep toolStep(const vpColVector &v, double horizon, double max_step);

private:
  void configureTask();

  vpServo task_;
  vpFeaturePoint s_point_;
  vpFeaturePoint s_point_star_;
  vpFeatureDepth s_depth_;
  vpFeatureDepth s_depth_star_;
  PointFeature desired_;
  DofMode mode_;
  double last_gain_;
};

}  // namespace cooperation_pkg

#endif  // COOPERATION_PKG_VISUAL_SERVO_CONTROL_H
