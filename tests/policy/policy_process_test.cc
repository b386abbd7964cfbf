// The wmkit-policy protocol end to end with a Python policy (echo_policy.py): a round trip that
// checks every value, and each way a policy can fail, which must name the policy, the episode
// and the step.
#include "policy/policy_process.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <chrono>
#include <cstdlib>

#include "core/error.h"
#include "policy/policy_spec.h"

namespace wm::policy {
namespace {

using ::testing::HasSubstr;

std::string EchoCommand(const std::string& args = "") {
  const char* src = std::getenv("WM_SOURCE_DIR");
  return "/usr/bin/python3 " + std::string(src ? src : ".") + "/tests/policy/echo_policy.py " +
         args;
}

PolicyProcessOptions Options(const std::string& args, double step_timeout_s = 10) {
  PolicyProcessOptions o;
  o.name = "echo";
  o.command = EchoCommand(args);
  o.image_height = 6;
  o.image_width = 5;
  o.step_timeout_s = step_timeout_s;
  o.start_timeout_s = 20;
  return o;
}

std::vector<uint8_t> TestImage(int seed) {
  std::vector<uint8_t> rgb(6 * 5 * 3);
  for (size_t i = 0; i < rgb.size(); ++i) rgb[i] = static_cast<uint8_t>((i * 37 + seed * 11) % 251);
  return rgb;
}

Observation Obs(const std::vector<uint8_t>& rgb, int64_t episode, int64_t step) {
  return {rgb.data(), 6, 5, "push the red block", episode, step};
}

// Runs episode 4 for steps 0..2 and returns the error message (empty when none).
std::string RunUntilError(const PolicyProcessOptions& options) {
  try {
    PolicyProcess policy(options);
    policy.Reset(4, 1234, "push the red block");
    for (int step = 0; step < 3; ++step) {
      const std::vector<uint8_t> rgb = TestImage(step);
      policy.Act(Obs(rgb, 4, step));
    }
  } catch (const Error& e) {
    return e.what();
  }
  return "";
}

TEST(PolicyProcessTest, RoundTripEchoesEveryField) {
  PolicyProcess policy(Options("--chatty"));
  EXPECT_THAT(policy.self_description(), HasSubstr("\"echo\""));
  // Two interleaved episodes, as a batched evaluation sends them.
  policy.Reset(0, 5001, "push the red block");
  policy.Reset(1, 7002, "push the red block");
  for (int step = 0; step < 3; ++step) {
    for (int64_t episode : {0, 1}) {
      const std::vector<uint8_t> rgb = TestImage(step + 10 * static_cast<int>(episode));
      int64_t sum = 0;
      for (uint8_t v : rgb) sum += v;
      const std::vector<float> a = policy.Act(Obs(rgb, episode, step));
      const std::vector<float> expected = {
          static_cast<float>(step),       static_cast<float>(episode),
          static_cast<float>(rgb[0]),     static_cast<float>(rgb[rgb.size() - 1]),
          static_cast<float>(sum % 9973), 18,
          episode == 0 ? 1.0f : 2.0f};
      EXPECT_EQ(a, expected) << "episode " << episode << " step " << step;
    }
  }
  policy.Close();
}

TEST(PolicyProcessTest, CrashNamesPolicyEpisodeStepAndStatus) {
  const std::string e = RunUntilError(Options("--bad crash --at 1"));
  EXPECT_THAT(e, HasSubstr("policy 'echo', episode 4, step 1: exited with status 3"));
  EXPECT_THAT(e, HasSubstr("misbehaving on purpose: crash"));  // the end of its stderr
}

TEST(PolicyProcessTest, KilledBySignal) {
  EXPECT_THAT(
      RunUntilError(Options("--bad segv --at 2")),
      ::testing::AllOf(HasSubstr("policy 'echo', episode 4, step 2: "), HasSubstr("SIGSEGV")));
}

TEST(PolicyProcessTest, HangPastTimeoutIsKilled) {
  const auto start = std::chrono::steady_clock::now();
  const std::string e = RunUntilError(Options("--bad hang --at 1", 0.5));
  EXPECT_THAT(e, HasSubstr("policy 'echo', episode 4, step 1: did not answer within 0.5 s"));
  EXPECT_LT(std::chrono::steady_clock::now() - start, std::chrono::seconds(8));
}

TEST(PolicyProcessTest, HangAtStartUp) {
  PolicyProcessOptions o = Options("--bad hang_start");
  o.start_timeout_s = 0.5;
  EXPECT_THAT(RunUntilError(o),
              HasSubstr("policy 'echo', at start-up: did not answer within 0.5 s"));
}

// Each misbehaviour of echo_policy.py and the error it must give.
struct BadPolicyCase {
  const char* args;
  const char* error;
};

class BadPolicyTest : public ::testing::TestWithParam<BadPolicyCase> {};

TEST_P(BadPolicyTest, NamesPolicyEpisodeStepAndProblem) {
  EXPECT_THAT(RunUntilError(Options(GetParam().args)), HasSubstr(GetParam().error));
}

INSTANTIATE_TEST_SUITE_P(
    PolicyProcessTest, BadPolicyTest,
    ::testing::Values(
        BadPolicyCase{"--bad malformed --at 0",
                      "policy 'echo', episode 4, step 0: answered a line that is not JSON: "
                      "'{this is not json'"},
        BadPolicyCase{
            "--bad wide --at 2",
            "policy 'echo', episode 4, step 2: answered an action of width 6, expected 7"},
        BadPolicyCase{"--bad nan --at 1",
                      "policy 'echo', episode 4, step 1: answered a non-finite action value NaN "
                      "at index 2"},
        BadPolicyCase{"--bad inf --at 0",
                      "episode 4, step 0: answered a non-finite action value -inf at index 4"},
        BadPolicyCase{"--bad raise --at 1",
                      "policy 'echo', episode 4, step 1: reported an error: RuntimeError: the "
                      "policy's own failure"},
        BadPolicyCase{"--bad old_version",
                      "policy 'echo', at start-up: speaks protocol 'wmkit-policy' version 0, "
                      "wmkit speaks 'wmkit-policy' version 1"}));

TEST(PolicyProcessTest, MissingCommand) {
  PolicyProcessOptions o = Options("");
  o.command = "/nonexistent/policy";
  EXPECT_THAT(RunUntilError(o), HasSubstr("policy 'echo', at start-up: exited with status 127"));
}

TEST(PolicyProcessTest, CallsAfterAFailureThrow) {
  PolicyProcess policy(Options("--bad wide --at 0"));
  policy.Reset(0, 1, "x");
  const std::vector<uint8_t> rgb = TestImage(0);
  EXPECT_THROW(policy.Act(Obs(rgb, 0, 0)), Error);
  EXPECT_THROW(policy.Act(Obs(rgb, 0, 1)), Error);
}

TEST(ProtocolTest, ParsesRepliesAndRefusesBadOnes) {
  EXPECT_EQ(ParseReply(R"({"type":"action","action":[1,2.5,-3]})").action,
            (std::vector<double>{1, 2.5, -3}));
  EXPECT_THROW(CheckedAction(ParseReply(R"({"type":"action","action":[1, null]})"), 2), Error);
  EXPECT_THROW(CheckedAction(ParseReply(R"({"type":"action","action":[1, 1e300]})"), 2), Error);
  EXPECT_THROW(ParseReply(R"({"type":"action","action":"up"})"), Error);
  EXPECT_THROW(ParseReply(R"({"type":"dance"})"), Error);
  EXPECT_THROW(ParseReply("[1, 2]"), Error);
}

TEST(PolicySpecTest, ParsesNameEqualsCommand) {
  const PolicySpec s = ParsePolicySpec("colour_noise0=scripts/p.py --noise 0 --x=1");
  EXPECT_EQ(s.name, "colour_noise0");
  EXPECT_EQ(s.command, "scripts/p.py --noise 0 --x=1");
  EXPECT_THROW(ParsePolicySpec("Bad-Name=x"), Error);
  EXPECT_THROW(ParsePolicySpec("no_command="), Error);
  EXPECT_THROW(ParsePolicySpec("missing_equals"), Error);
  EXPECT_THROW(CheckPolicyNames({{"a", "x"}, {"a", "y"}}), Error);
}

}  // namespace
}  // namespace wm::policy
