// fuzz::mutateUtime, the utime mutation of fuzz_nodes and fuzz_camera (utime_mutator.cpp): it
// changes one message's utime and nothing else, the message still decodes, and over many seeds it
// reaches the times a byte-level mutation hardly does.
#include <gtest/gtest.h>

#include <algorithm>
#include <limits>
#include <set>
#include <vector>

#include "depowder/part_pose_t.hpp"
#include "depowder/robot_state_t.hpp"
#include "depowder/test_messages.hpp"
#include "fuzz.hpp"

using namespace depowder;

namespace {

template <class T>
void appendRecord(std::vector<std::uint8_t>& input, int kind, const T& msg) {
  const std::vector<std::uint8_t> bytes = testutil::encoded(msg);
  input.push_back(static_cast<std::uint8_t>(kind));
  input.push_back(static_cast<std::uint8_t>(bytes.size() & 0xff));
  input.push_back(static_cast<std::uint8_t>(bytes.size() >> 8));
  input.insert(input.end(), bytes.begin(), bytes.end());
}

/// The utimes of the input's two messages (a ROBOT_STATE, then a PART_POSE); fails if either
/// no longer decodes.
std::vector<std::int64_t> utimes(const std::vector<std::uint8_t>& input) {
  std::vector<std::int64_t> out;
  fuzz::forEachRecord(input.data(), input.size(), 2, [&](int kind, const std::uint8_t* msg, std::size_t n) {
    robot_state_t robot;
    part_pose_t pose;
    if (kind == 0 && fuzz::decoded(robot, msg, n)) out.push_back(robot.utime);
    if (kind == 1 && fuzz::decoded(pose, msg, n)) out.push_back(pose.utime);
  });
  return out;
}

}  // namespace

TEST(UtimeMutator, ChangesOneUtimeToTheTimesThatStressAClock) {
  robot_state_t robot{};
  robot.utime = 1'000'000;
  part_pose_t pose{};
  pose.utime = 1'033'000;
  pose.part = "cube";
  std::vector<std::uint8_t> input;
  appendRecord(input, 0, robot);
  appendRecord(input, 1, pose);
  const std::vector<std::int64_t> before = utimes(input);
  ASSERT_EQ(before, (std::vector<std::int64_t>{1'000'000, 1'033'000}));

  std::vector<std::size_t> utime_offsets;  // after each record's header and type fingerprint
  fuzz::forEachRecord(input.data(), input.size(), 2, [&](int, const std::uint8_t* msg, std::size_t) {
    utime_offsets.push_back(static_cast<std::size_t>(msg - input.data()) + 8);
  });
  std::set<std::int64_t> seen;
  for (unsigned seed = 0; seed < 2000; ++seed) {
    std::vector<std::uint8_t> mutated = input;
    ASSERT_TRUE(fuzz::mutateUtime(mutated.data(), mutated.size(), seed));
    const std::vector<std::int64_t> after = utimes(mutated);
    ASSERT_EQ(after.size(), 2u) << "seed " << seed << ": a message no longer decodes";
    const int changed = (after[0] != before[0]) + (after[1] != before[1]);
    ASSERT_LE(changed, 1) << "seed " << seed;
    for (std::size_t at : utime_offsets)  // nothing but the utimes changed
      std::copy_n(input.begin() + static_cast<long>(at), 8, mutated.begin() + static_cast<long>(at));
    ASSERT_EQ(mutated, input) << "seed " << seed;
    seen.insert(after[0]), seen.insert(after[1]);
  }
  constexpr std::int64_t kMin = std::numeric_limits<std::int64_t>::min();
  const std::int64_t wanted[] = {
      kMin, std::numeric_limits<std::int64_t>::max(), 0, -1, 1'000'000 ^ kMin, 1'033'000 - 1, 1'000'000 - 1};
  for (std::int64_t t : wanted) EXPECT_TRUE(seen.count(t)) << t << " never set in 2000 mutations";
}

TEST(UtimeMutator, LeavesAnInputWithoutAWholeUtimeAlone) {
  std::vector<std::uint8_t> input = {1, 15, 0};  // one record of 15 bytes: fingerprint and 7 of 8
  input.resize(3 + 15, 0xab);
  const std::vector<std::uint8_t> before = input;
  EXPECT_FALSE(fuzz::mutateUtime(input.data(), input.size(), 7));
  EXPECT_EQ(input, before);
  EXPECT_FALSE(fuzz::mutateUtime(nullptr, 0, 7));
}
