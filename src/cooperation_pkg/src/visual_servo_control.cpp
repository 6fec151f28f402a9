/**
 * @file visual_servo_control.cpp
 * @brief IBVS point + depth control law on vpServo (see visual_servo_control.h).
 */
#include "cooperation_pkg/visual_servo_control.h"

#include <cmath>
#include <stdexcept>
#include <string>

#include <visp3/core/vpExponentialMap.h>
#include <visp3/vs/vpAdaptiveGain.h>

namespace cooperation_pkg
{
namespace
{
bool finite(double v)
{
  return std::isfinite(v);
}
}  // namespace

bool parseServoMode(const std::string &text, ServoMode &mode)
{
  if (text == "step")
  {
    mode = ServoMode::STEP;
    return true;
  }
  if (text == "continuous")
  {
    mode = ServoMode::CONTINUOUS;
    return true;
  }
  return false;
}

const char *servoModeName(ServoMode mode)
{
  return mode == ServoMode::CONTINUOUS ? "continuous" : "step";
}

PointFeature PointFeature::fromPoint(const vpTranslationVector &p)
{
  if (!(p[2] > 0.0) || !finite(p[0]) || !finite(p[1]) || !finite(p[2]))
  {
    throw std::invalid_argument("point must be finite and in front of the camera (Z > 0)");
  }
  return PointFeature(p[0] / p[2], p[1] / p[2], p[2]);
}

bool PointFeature::valid() const
{
  return finite(x) && finite(y) && finite(Z) && Z > 0.0;
}

VisualServoControl::VisualServoControl(double gain, DofMode mode)
  : desired_(0.0, 0.0, 1.0), mode_(mode), last_gain_(gain)
{
  configureTask();
  setGain(gain);
  setDesired(desired_);
}

void VisualServoControl::configureTask()
{
  task_.setServo(vpServo::EYEINHAND_CAMERA);
  task_.setInteractionMatrixType(vpServo::CURRENT, vpServo::PSEUDO_INVERSE);
  // s = (x, y) and s_Z = log(Z / Z*); the desired depth feature is log(1) = 0.
  task_.addFeature(s_point_, s_point_star_);
  task_.addFeature(s_depth_, s_depth_star_);
  setDofMode(mode_);
}

void VisualServoControl::setGain(double gain)
{
  if (!(gain > 0.0) || !finite(gain))
  {
    throw std::invalid_argument("servo gain must be finite and > 0");
  }
  task_.setLambda(gain);
  last_gain_ = gain;
}

void VisualServoControl::setAdaptiveGain(double gain_at_zero, double gain_at_infinity, double slope_at_zero)
{
  if (!(gain_at_zero > 0.0) || !(gain_at_infinity > 0.0) || !(slope_at_zero > 0.0) ||
      !(gain_at_zero > gain_at_infinity) || !finite(gain_at_zero) || !finite(slope_at_zero))
  {
    throw std::invalid_argument("adaptive gain needs gain_at_zero > gain_at_infinity > 0 and slope_at_zero > 0");
  }
  task_.setLambda(vpAdaptiveGain(gain_at_zero, gain_at_infinity, slope_at_zero));
  last_gain_ = gain_at_zero;
}

void VisualServoControl::setDofMode(DofMode mode)
{
  mode_ = mode;
  vpColVector dof(6, 1.0);
  if (mode == TRANSLATION)
  {
    dof[3] = dof[4] = dof[5] = 0.0;
  }
  task_.setCameraDoF(dof);
}

void VisualServoControl::setDesired(const PointFeature &desired)
{
  if (!desired.valid())
  {
    throw std::invalid_argument("desired feature must be finite with Z* > 0");
  }
  desired_ = desired;
  s_point_star_.buildFrom(desired.x, desired.y, desired.Z);
  s_depth_star_.buildFrom(desired.x, desired.y, desired.Z, 0.0);
}

vpColVector VisualServoControl::computeControlLaw(const PointFeature &current)
{
  if (!current.valid())
  {
    throw std::invalid_argument("current feature must be finite with Z > 0");
  }
  s_point_.buildFrom(current.x, current.y, current.Z);
  s_depth_.buildFrom(current.x, current.y, current.Z, std::log(current.Z / desired_.Z));
  vpColVector v = task_.computeControlLaw();
  // vpServo evaluates an adaptive gain at the infinity norm of e1 = J1^+ e (velocity before gain).
  last_gain_ = task_.lambda.value_const((task_.J1p * task_.error).infinityNorm());
  return v;
}

double VisualServoControl::errorAtTarget(const PointFeature &current) const
{
  const vpTranslationVector d = current.point() - desired_.point();
  return d.frobeniusNorm();
}

vpHomogeneousMatrix VisualServoControl::integrate(const vpColVector &v, double dt)
{
  if (v.size() != 6)
  {
    throw std::invalid_argument("camera velocity must have 6 components, got " + std::to_string(v.size()));
  }
  return vpExponentialMap::direct(v, dt);
}

vpColVector VisualServoControl::dropRotation(const vpColVector &v)
{
  vpColVector out(v);
  for (unsigned int i = 3; i < out.size(); ++i)
  {
    out[i] = 0.0;
  }
  return out;
}

ToolStep VisualServoControl::toolStep(const vpColVector &v, double horizon, double max_step)
{
  if (!(horizon > 0.0) || !finite(horizon) || !(max_step > 0.0) || !finite(max_step))
  {
    throw std::invalid_argument("tool step needs a finite horizon > 0 and max_step > 0");
  }
  ToolStep step;
  step.translation = integrate(dropRotation(v), horizon).getTranslationVector();
  step.requested = step.translation.frobeniusNorm();
  if (step.requested > max_step)
  {
    step.translation = step.translation * (max_step / step.requested);
    step.clipped = true;
  }
  return step;
}

}  // namespace cooperation_pkg
