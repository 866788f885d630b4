// What the arm is commanded, whatever NOZZLE_PLANs arrive: each plan goes through the driver's
// own path (fromMsg, preparePlan from where the arm is, setPlan on the running trajectory) on
// the default cell's arm, and every 8 ms command stays inside the joint limits, at most
// velocity_scale of each joint's speed limit and within its acceleration limit, across plan
// switches and stops: the properties test_trajectory checks on its own plans.
// Input: records of [cycles to run, 2 bytes LE][length, 2 bytes LE][the nozzle_plan_t];
// a record of length 0 is a controlled stop.
#include <algorithm>
#include <cmath>
#include <cstdlib>

#include "driver_config.hpp"
#include "fuzz.hpp"
#include "plan_msg.hpp"

using namespace depowder;
using namespace depowder::robot;

namespace {

struct Arm {
  DriverConfig config = readRobotSection(node::loadCell(node::defaultCellPath())).driver;
};

// Checks every command against the limits (aborts on a violation).
class Checker {
 public:
  Checker(const DriverConfig& c, TrajectoryGenerator& gen) : c_(c), gen_(gen), prev_(gen.current().q), prev2_(prev_) {}

  /// Runs `cycles` commands; false if the arm ended them at rest with nothing left to do.
  bool run(int cycles) {
    bool moving = true;
    for (int k = 0; k < cycles; ++k) {
      const TrajectorySample s = gen_.step();
      moving = s.moving || gen_.hasPath();
      const ArmConfig& arm = c_.arm;
      const double dt = c_.trajectory.cycle_s;
      for (int i = 0; i < 6; ++i) {
        const double v = (s.q[i] - prev_[i]) / dt, a = (s.q[i] - 2 * prev_[i] + prev2_[i]) / (dt * dt);
        if (!std::isfinite(s.q[i]) || s.q[i] < arm.q_min[i] - 1e-9 || s.q[i] > arm.q_max[i] + 1e-9) std::abort();
        if (std::abs(v) > (c_.trajectory.velocity_scale + 1e-9) * arm.qd_max[i]) std::abort();
        if (std::abs(a) > (1 + 1e-9) * arm.qdd_max[i]) std::abort();
      }
      prev2_ = prev_;
      prev_ = s.q;
    }
    return moving;
  }

 private:
  const DriverConfig& c_;
  TrajectoryGenerator& gen_;
  Joints prev_, prev2_;
};

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static const Arm arm;
  const DriverConfig& c = arm.config;
  TrajectoryGenerator gen(c.arm, c.trajectory);
  gen.reset(c.arm.q_home);
  Checker check(c, gen);
  while (size >= 4) {
    const int cycles = (data[0] | data[1] << 8) % 1000;
    const std::size_t n = std::min<std::size_t>(size - 4, data[2] | data[3] << 8);
    nozzle_plan_t msg;
    Plan plan;
    std::string why;
    if (n == 0)
      gen.stop();
    else if (fuzz::decoded(msg, data + 4, n) && fromMsg(msg, &plan, &why))
      if (const PreparedPlan p = preparePlan(c.arm, c.trajectory, c.safety.workspace, plan, gen.current().q);
          p.usable())
        gen.setPlan(p);
    data += 4 + n, size -= 4 + n;
    check.run(cycles);
  }
  for (int k = 0; k < 300 && check.run(100); ++k) {  // up to 4 minutes more: every plan runs out
  }
  return 0;
}
