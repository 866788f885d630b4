// Linked into every gtest program that talks udpm between processes (depowder_test's NETNS
// option): unless the program runs inside a private network namespace (test/netns-run, as
// ctest runs it), every test is skipped, naming the interfaces seen, before any test opens the
// bus. So a test run by hand never sends multicast on a real interface.
#include <gtest/gtest.h>

#include <string>

#include "depowder/child_process.hpp"

namespace {

class PrivateNetworkOnly : public ::testing::Environment {
 public:
  void SetUp() override {
    if (const std::string refusal = depowder::testutil::multicastRefusal(); !refusal.empty())
      GTEST_SKIP() << refusal << " (ctest does)";
  }
};

const ::testing::Environment* const kPrivateNetworkOnly = ::testing::AddGlobalTestEnvironment(new PrivateNetworkOnly);

}  // namespace
