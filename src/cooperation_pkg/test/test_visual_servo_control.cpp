/**
 * @file test_visual_servo_control.cpp
 * @brief gtest of the ViSP control law: feature maths, DOF selection, convergence of a simulated camera.
 */
#include <cmath>
#include <random>
#include <stdexcept>

#include <gtest/gtest.h>

#include "cooperation_pkg/visual_servo_control.h"
#include "servo_sim.h"

using cooperation_pkg::PointFeature;
using cooperation_pkg::ServoMode;
using cooperation_pkg::ToolStep;
using cooperation_pkg::VisualServoControl;
using cooperation_pkg::test::desiredPoint;
using cooperation_pkg::test::simulate;
using cooperation_pkg::test::simulateTimed;
using cooperation_pkg::test::TimedSimConfig;
using cooperation_pkg::test::TimedSimResult;

namespace
{
/** About 300 mm from the goal: behind, to the side and below, as after the stereo approach. */
vpTranslationVector startPoint()
{
  return desiredPoint() + vpTranslationVector(0.06, 0.04, 0.28);
}
}  // namespace

TEST(PointFeature, RoundTripAndValidation)
{
  const PointFeature f = PointFeature::fromPoint(vpTranslationVector(0.02, -0.03, 0.4));
  EXPECT_NEAR(f.x, 0.05, 1e-12);
  EXPECT_NEAR(f.y, -0.075, 1e-12);
  EXPECT_NEAR(f.point()[1], -0.03, 1e-12);
  EXPECT_THROW(PointFeature::fromPoint(vpTranslationVector(0.0, 0.0, -0.1)), std::invalid_argument);
  EXPECT_FALSE(PointFeature(0.0, 0.0, 0.0).valid());
  EXPECT_FALSE(PointFeature(NAN, 0.0, 1.0).valid());
}

TEST(VisualServoControl, RejectsBadInput)
{
  EXPECT_THROW(VisualServoControl(0.0), std::invalid_argument);
  VisualServoControl law(0.5);
  EXPECT_THROW(law.setDesired(PointFeature(0.0, 0.0, -1.0)), std::invalid_argument);
  EXPECT_THROW(law.computeControlLaw(PointFeature(0.0, 0.0, 0.0)), std::invalid_argument);
  EXPECT_THROW(law.setAdaptiveGain(0.2, 0.5, 1.0), std::invalid_argument);
}

TEST(VisualServoControl, DepthOnlyErrorOnAxis)
{
  // Point on the optical axis, too far: pure forward motion vz = lambda Z log(Z / Z*).
  VisualServoControl law(0.5);
  law.setDesired(PointFeature(0.0, 0.0, 0.13));
  const vpColVector v = law.computeControlLaw(PointFeature(0.0, 0.0, 0.4));
  ASSERT_EQ(v.size(), 6u);
  EXPECT_NEAR(v[0], 0.0, 1e-12);
  EXPECT_NEAR(v[1], 0.0, 1e-12);
  EXPECT_NEAR(v[2], 0.5 * 0.4 * std::log(0.4 / 0.13), 1e-12);
  EXPECT_NEAR(law.errorAtTarget(PointFeature(0.0, 0.0, 0.4)), 0.27, 1e-12);
  EXPECT_NEAR(law.errorAtTarget(law.desired()), 0.0, 1e-15);
}

TEST(VisualServoControl, TranslationModeHasNoRotation)
{
  VisualServoControl law(0.5, VisualServoControl::TRANSLATION);
  law.setDesired(PointFeature::fromPoint(desiredPoint()));
  const vpColVector v = law.computeControlLaw(PointFeature::fromPoint(startPoint()));
  EXPECT_EQ(v[3], 0.0);
  EXPECT_EQ(v[4], 0.0);
  EXPECT_EQ(v[5], 0.0);
  // Moving towards the point: positive vz, and right/down where the point is.
  EXPECT_GT(v[0], 0.0);
  EXPECT_GT(v[1], 0.0);
  EXPECT_GT(v[2], 0.0);

  law.setDofMode(VisualServoControl::FULL);
  const vpColVector w = law.computeControlLaw(PointFeature::fromPoint(startPoint()));
  EXPECT_GT(std::fabs(w[3]) + std::fabs(w[4]), 1e-6);
  EXPECT_EQ(VisualServoControl::dropRotation(w)[4], 0.0);
}

TEST(VisualServoControl, IntegrateTranslation)
{
  vpColVector v(6, 0.0);
  v[0] = 0.1;
  v[2] = -0.2;
  const vpHomogeneousMatrix m = VisualServoControl::integrate(v, 0.5);
  EXPECT_NEAR(m[0][3], 0.05, 1e-12);
  EXPECT_NEAR(m[2][3], -0.1, 1e-12);
  EXPECT_NEAR(m[0][0], 1.0, 1e-12);
  EXPECT_THROW(VisualServoControl::integrate(vpColVector(3, 0.0), 1.0), std::invalid_argument);
}

TEST(VisualServoControl, ConvergesGain05Dt1)
{
  VisualServoControl law(0.5);
  law.setDesired(PointFeature::fromPoint(desiredPoint()));
  const auto r = simulate(law, startPoint(), 1.0, 0.002, 15, false);
  ASSERT_TRUE(r.converged);
  EXPECT_LE(r.iterations, 7);
  EXPECT_LT(r.errors.back(), 0.002);
  // Monotonic decrease at gain * dt = 0.5 (no overshoot).
  for (size_t i = 1; i < r.errors.size(); ++i)
  {
    EXPECT_LT(r.errors[i], r.errors[i - 1]);
  }
}

TEST(VisualServoControl, ConvergesGain03Dt1)
{
  VisualServoControl law(0.3);
  law.setDesired(PointFeature::fromPoint(desiredPoint()));
  const auto r = simulate(law, startPoint(), 1.0, 0.002, 15, false);
  ASSERT_TRUE(r.converged);
  EXPECT_LE(r.iterations, 13);
  EXPECT_GT(r.iterations, 7);  // slower than gain 0.5
}

TEST(VisualServoControl, FullLawConvergesWithIdealCameraAndWithRotationDropped)
{
  VisualServoControl law(0.5, VisualServoControl::FULL);
  law.setDesired(PointFeature::fromPoint(desiredPoint()));
  const auto ideal = simulate(law, startPoint(), 1.0, 0.002, 15, true);
  EXPECT_TRUE(ideal.converged);
  const auto dropped = simulate(law, startPoint(), 1.0, 0.002, 15, false);
  EXPECT_TRUE(dropped.converged);
}

TEST(VisualServoControl, AdaptiveGainConverges)
{
  VisualServoControl law(0.5);
  law.setAdaptiveGain(0.6, 0.3, 2.0);
  law.setDesired(PointFeature::fromPoint(desiredPoint()));
  const auto r = simulate(law, startPoint(), 1.0, 0.002, 15, false);
  EXPECT_TRUE(r.converged);
  EXPECT_GE(law.lastGain(), 0.3);
  EXPECT_LE(law.lastGain(), 0.6);
}

TEST(ServoMode, ParseAndName)
{
  ServoMode m = ServoMode::CONTINUOUS;
  EXPECT_TRUE(cooperation_pkg::parseServoMode("step", m));
  EXPECT_EQ(m, ServoMode::STEP);
  EXPECT_TRUE(cooperation_pkg::parseServoMode("continuous", m));
  EXPECT_EQ(m, ServoMode::CONTINUOUS);
  EXPECT_FALSE(cooperation_pkg::parseServoMode("Continuous", m));
  EXPECT_FALSE(cooperation_pkg::parseServoMode("", m));
  EXPECT_EQ(m, ServoMode::CONTINUOUS);  // unchanged on a bad text
  EXPECT_STREQ(cooperation_pkg::servoModeName(ServoMode::STEP), "step");
  EXPECT_STREQ(cooperation_pkg::servoModeName(ServoMode::CONTINUOUS), "continuous");
}

TEST(VisualServoControl, ToolStepIntegratesTranslationAndClips)
{
  vpColVector v(6, 0.0);
  v[0] = 0.1;
  v[2] = -0.2;
  v[4] = 0.3;  // rotation: dropped
  const ToolStep s = VisualServoControl::toolStep(v, 0.5, 0.30);
  EXPECT_FALSE(s.clipped);
  EXPECT_NEAR(s.translation[0], 0.05, 1e-12);
  EXPECT_NEAR(s.translation[1], 0.0, 1e-12);
  EXPECT_NEAR(s.translation[2], -0.1, 1e-12);
  EXPECT_NEAR(s.requested, std::sqrt(0.05 * 0.05 + 0.1 * 0.1), 1e-12);
  const ToolStep c = VisualServoControl::toolStep(v, 0.5, 0.02);
  EXPECT_TRUE(c.clipped);
  EXPECT_NEAR(c.translation.frobeniusNorm(), 0.02, 1e-12);
  EXPECT_NEAR(c.translation[0] / c.translation[2], -0.5, 1e-12);  // same direction
  EXPECT_THROW(VisualServoControl::toolStep(v, 0.0, 0.3), std::invalid_argument);
  EXPECT_THROW(VisualServoControl::toolStep(v, 0.2, 0.0), std::invalid_argument);
}

namespace
{
TimedSimConfig timedConfig(ServoMode mode)
{
  TimedSimConfig c;
  c.mode = mode;
  if (mode == ServoMode::CONTINUOUS)
  {
    // config/visual_servo.yaml: continuous_gain 3.5, horizon 0.2 s (one period of the 5 Hz hand camera)
    c.gain = 3.5;
    c.horizon = 0.2;
    c.max_iterations = 100;
  }
  return c;
}

TimedSimResult runTimed(const TimedSimConfig &c, const vpTranslationVector &start = startPoint())
{
  VisualServoControl law(c.gain);
  law.setDesired(PointFeature::fromPoint(desiredPoint()));
  return simulateTimed(law, start, c);
}
}  // namespace

TEST(TimedServo, StepModeMakesTheSameMovesAsTheIdealLoop)
{
  // The paper's mode with the arm model: each move ends before the next image, so the moves are the
  // ones of the ideal loop (6 at gain 0.5, dt 1 s) and no command ever replaces a running move.
  const TimedSimResult r = runTimed(timedConfig(ServoMode::STEP));
  ASSERT_TRUE(r.converged);
  EXPECT_EQ(r.iterations, 6);
  EXPECT_EQ(r.replaced, 0);
  EXPECT_LT(r.final_true_error, 0.002);
}

TEST(TimedServo, ContinuousConvergesFrom30cm)
{
  for (const double camera_period : { 0.2, 0.0 })  // free-running 5 Hz camera; triggered camera
  {
    TimedSimConfig c = timedConfig(ServoMode::CONTINUOUS);
    c.camera_period = camera_period;
    const TimedSimResult x = runTimed(c);
    ASSERT_TRUE(x.converged) << "camera period " << camera_period;
    EXPECT_GT(x.errors.front(), 0.28);
    EXPECT_LT(x.errors.back(), 0.002);
    EXPECT_LT(x.final_true_error, 0.002);
    // commands replace running moves: the arm is not waited for
    EXPECT_GT(x.replaced, x.iterations / 2);
  }
  // The same start from the other side and above: converges too.
  const TimedSimResult o = runTimed(timedConfig(ServoMode::CONTINUOUS),
                                    desiredPoint() + vpTranslationVector(-0.10, -0.05, 0.27));
  ASSERT_TRUE(o.converged);
  EXPECT_LT(o.final_true_error, 0.002);
}

TEST(TimedServo, ContinuousIsShorterThanStepInSimulatedTime)
{
  // Deterministic simulated time (not a wall-clock measurement).
  const TimedSimResult step = runTimed(timedConfig(ServoMode::STEP));
  const TimedSimResult cont = runTimed(timedConfig(ServoMode::CONTINUOUS));
  ASSERT_TRUE(step.converged);
  ASSERT_TRUE(cont.converged);
  EXPECT_LT(cont.time, step.time);
}

TEST(TimedServo, ContinuousConvergesWithNoisyTargetEstimate)
{
  // +-5 mm (uniform, per axis) on the target estimate the depth comes from: constant for a goal (a
  // stereo estimate) or new at each image. The loop stops on its own error; the tool's true error is
  // then the threshold plus what the depth error moves the goal along the ray (|bias_z| (1 + x*^2 + y*^2)^0.5).
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> u(-0.005, 0.005);
  const double ray = std::sqrt(1.0 + std::pow(desiredPoint()[1] / desiredPoint()[2], 2));
  for (int i = 0; i < 60; ++i)
  {
    TimedSimConfig c = timedConfig(ServoMode::CONTINUOUS);
    c.target_bias = vpTranslationVector(u(rng), u(rng), u(rng));
    c.seed = 1000 + i;
    const TimedSimResult r = runTimed(c);
    ASSERT_TRUE(r.converged) << "run " << i;
    EXPECT_LT(r.final_true_error, c.threshold + ray * std::fabs(c.target_bias[2]) + 0.0005) << "run " << i;

    TimedSimConfig n = timedConfig(ServoMode::CONTINUOUS);
    n.target_noise = 0.005;
    n.seed = 2000 + i;
    const TimedSimResult q = runTimed(n);
    ASSERT_TRUE(q.converged) << "run " << i;
    EXPECT_LT(q.final_true_error, n.threshold + ray * n.target_noise + 0.0005) << "run " << i;
  }
}

int main(int argc, char **argv)
{
  testing::InitGoogleTest(&argc, argv);
  return RUN_ALL_TESTS();
}
