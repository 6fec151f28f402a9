/**
 * @file servo_convergence_bench.cpp
 * @brief Benchmark (not installed, not a test): iterations to the 2 mm stop for a simulated ideal
 *        camera about 300 mm from the goal, per gain and dt, and the cost of computeControlLaw.
 *        Run: rosrun cooperation_pkg servo_convergence_bench   (or devel/lib/cooperation_pkg/...)
 */
#include <chrono>
#include <cstdio>

#include "cooperation_pkg/visual_servo_control.h"
#include "servo_sim.h"

using cooperation_pkg::PointFeature;
using cooperation_pkg::VisualServoControl;

int main()
{
  const vpTranslationVector start = cooperation_pkg::test::desiredPoint() + vpTranslationVector(0.06, 0.04, 0.28);
  const double initial = vpTranslationVector(0.06, 0.04, 0.28).frobeniusNorm();
  std::printf("start %.0f mm from the goal, stop below 2 mm, camera moves by exp(v dt)\n", initial * 1e3);
  std::printf("%-12s %5s %5s %11s %14s  %s\n", "law", "gain", "dt", "iterations", "servo time[s]", "errors [mm]");
  const double cases[][2] = { { 0.3, 1.0 }, { 0.5, 1.0 }, { 0.8, 1.0 }, { 1.0, 1.0 }, { 1.0, 0.5 }, { 0.5, 0.04 } };
  for (int mode = 0; mode < 2; ++mode)
  {
    for (const auto &c : cases)
    {
      VisualServoControl law(c[0], mode == 0 ? VisualServoControl::TRANSLATION : VisualServoControl::FULL);
      law.setDesired(PointFeature::fromPoint(cooperation_pkg::test::desiredPoint()));
      const auto r = cooperation_pkg::test::simulate(law, start, c[1], 0.002, 500, false);
      std::printf("%-12s %5.2f %5.2f %11s %14.2f ", mode == 0 ? "translation" : "6dof-drop", c[0], c[1],
                  r.converged ? std::to_string(r.iterations).c_str() : "diverged", r.iterations * c[1]);
      for (size_t i = 0; i < r.errors.size() && i < 8; ++i)
      {
        std::printf(" %.1f", r.errors[i] * 1e3);
      }
      std::printf("\n");
    }
  }
  VisualServoControl law(0.5);
  law.setDesired(PointFeature::fromPoint(cooperation_pkg::test::desiredPoint()));
  const PointFeature cur = PointFeature::fromPoint(start);
  const int n = 20000;
  double sink = 0.0;
  const auto t0 = std::chrono::steady_clock::now();
  for (int i = 0; i < n; ++i)
  {
    sink += law.computeControlLaw(cur)[2];
  }
  const double us = std::chrono::duration<double, std::micro>(std::chrono::steady_clock::now() - t0).count() / n;
  std::printf("computeControlLaw: %.2f us per call (checksum %.3f)\n", us, sink / n);
  return 0;
}
