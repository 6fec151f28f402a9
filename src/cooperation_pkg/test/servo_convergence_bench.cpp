/**
 * @file servo_convergence_bench.cpp
 * @brief Benchmark (not installed, not a test): iterations to the 2 mm stop for a simulated ideal
 *        camera about 300 mm from the goal, per gain and dt, and the cost of computeControlLaw.
 *        Run: rosrun cooperation_pkg servo_convergence_bench   (or devel/lib/cooperation_pkg/...)
 */
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <random>

#include "cooperation_pkg/visual_servo_control.h"
#include "servo_sim.h"

using cooperation_pkg::PointFeature;
using cooperation_pkg::ServoMode;
using cooperation_pkg::VisualServoControl;
using cooperation_pkg::test::TimedSimConfig;
using cooperation_pkg::test::TimedSimResult;

namespace
{
struct ModeCase
{
  ServoMode mode;
  double gain;
  double horizon;
  int max_iterations;
};

TimedSimResult runTimed(const ModeCase &m, const vpTranslationVector &start, double camera_period,
                        const vpTranslationVector &bias, double noise, unsigned seed)
{
  VisualServoControl law(m.gain);
  law.setDesired(PointFeature::fromPoint(cooperation_pkg::test::desiredPoint()));
  TimedSimConfig c;
  c.mode = m.mode;
  c.gain = m.gain;
  c.horizon = m.horizon;
  c.max_iterations = m.max_iterations;
  c.camera_period = camera_period;
  c.target_bias = bias;
  c.target_noise = noise;
  c.seed = seed;
  return cooperation_pkg::test::simulateTimed(law, start, c);
}

/** Visual-servo phase in simulated time, step vs continuous, with the arm's limits and the camera rate. */
void timedComparison(const vpTranslationVector &start)
{
  const ModeCase modes[] = { { ServoMode::STEP, 0.5, 1.0, 15 },
                             { ServoMode::CONTINUOUS, 2.5, 0.2, 150 },
                             { ServoMode::CONTINUOUS, 3.5, 0.2, 150 },
                             { ServoMode::CONTINUOUS, 4.5, 0.2, 150 } };
  struct Camera
  {
    const char *name;
    double period;
    double latency;
  };
  const Camera cameras[] = { { "5Hz/50ms", 0.2, 0.05 }, { "trig/50ms", 0.0, 0.05 }, { "trig/150ms", 0.0, 0.15 } };
  const vpTranslationVector offset = start - cooperation_pkg::test::desiredPoint();
  std::printf("\nservo phase in simulated time (arm limits of robot.yaml at the tool, camera free-running at 5 Hz "
              "or triggered, latency image -> command, move end seen at the 60 Hz poll)\n");
  std::printf("%-6s %-11s %5s %7s %-11s %6s %9s %8s %10s\n", "start", "mode", "gain", "dt/hor", "camera", "cmds",
              "replaced", "time[s]", "final[mm]");
  for (const double scale : { 1.0, 0.1 })
  {
    const vpTranslationVector from = cooperation_pkg::test::desiredPoint() + offset * scale;
    for (const auto &cam : cameras)
    {
      for (const auto &m : modes)
      {
        VisualServoControl law(m.gain);
        law.setDesired(PointFeature::fromPoint(cooperation_pkg::test::desiredPoint()));
        TimedSimConfig c;
        c.mode = m.mode;
        c.horizon = m.horizon;
        c.max_iterations = m.max_iterations;
        c.camera_period = cam.period;
        c.latency = cam.latency;
        const TimedSimResult r = cooperation_pkg::test::simulateTimed(law, from, c);
        char t[16];
        std::snprintf(t, sizeof(t), "%.2f", r.time);
        std::printf("%4.0fmm %-11s %5.2f %7.2f %-11s %6d %9d %8s %10.2f\n", offset.frobeniusNorm() * scale * 1e3,
                    cooperation_pkg::servoModeName(m.mode), m.gain, m.horizon, cam.name, r.iterations, r.replaced,
                    r.converged ? t : "no conv", r.final_true_error * 1e3);
      }
    }
  }
  std::printf("\n+-5 mm on the target estimate (uniform per axis), 200 runs each, 5 Hz camera:\n");
  std::printf("%-11s %5s %7s %-18s %9s %8s %8s %8s %14s\n", "mode", "gain", "dt/hor", "noise", "converged",
              "mean[s]", "p95[s]", "max[s]", "max final[mm]");
  for (const auto &m : modes)
  {
    for (int kind = 0; kind < 2; ++kind)
    {
      std::mt19937 rng(7);
      std::uniform_real_distribution<double> u(-0.005, 0.005);
      std::vector<double> times;
      int converged = 0;
      double worst = 0.0;
      const int runs = 200;
      for (int i = 0; i < runs; ++i)
      {
        const vpTranslationVector bias = kind == 0 ? vpTranslationVector(u(rng), u(rng), u(rng)) : vpTranslationVector(0, 0, 0);
        const TimedSimResult r = runTimed(m, start, 0.2, bias, kind == 1 ? 0.005 : 0.0, 100 + i);
        if (r.converged)
        {
          ++converged;
          times.push_back(r.time);
          worst = std::max(worst, r.final_true_error);
        }
      }
      std::sort(times.begin(), times.end());
      double mean = 0.0;
      for (double x : times)
      {
        mean += x / std::max<size_t>(1, times.size());
      }
      std::printf("%-11s %5.2f %7.2f %-18s %5d/%3d %8.2f %8.2f %8.2f %14.2f\n", cooperation_pkg::servoModeName(m.mode),
                  m.gain, m.horizon, kind == 0 ? "constant per run" : "new at each image", converged, runs, mean,
                  times.empty() ? 0.0 : times[static_cast<size_t>(0.95 * (times.size() - 1))],
                  times.empty() ? 0.0 : times.back(), worst * 1e3);
    }
  }
}
}  // namespace

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
  timedComparison(start);

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
