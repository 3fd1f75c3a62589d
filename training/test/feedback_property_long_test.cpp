// The long run of the feedback property test (label "long", off by default:
// ctest -L long): 10^5 generated sessions for each of three seeds.
#include <gtest/gtest.h>

#include "feedback_property.h"

namespace dentar::training {
namespace {

TEST(FeedbackPropertyLong, RulesHoldOnThreeHundredThousandSessions) {
  for (std::uint64_t seed : {1u, 2u, 3u}) test::check_generated_sessions(seed, 100000);
}

}  // namespace
}  // namespace dentar::training
