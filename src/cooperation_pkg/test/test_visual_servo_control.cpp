/**
 * @file test_visual_servo_control.cpp
 * @brief gtest of the ViSP control law: feature maths, DOF selection, convergence of a simulated camera.
 */
#include <cmath>
#include <stdexcept>

#include <gtest/gtest.h>

#include "cooperation_pkg/visual_servo_control.h"
#include "servo_sim.h"

using cooperation_pkg::PointFeature;
using cooperation_pkg::VisualServoControl;
using cooperation_pkg::test::desiredPoint;
using cooperation_pkg::test::simulate;

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

int main(int argc, char **argv)
{
  testing::InitGoogleTest(&argc, argv);
  return RUN_ALL_TESTS();
}
