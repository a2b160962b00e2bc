// Which shard bakes which sector (shard.h, shardOwners): every sector once, the split balanced by
// cost (the longest-processing-time-first rule's bound), the same in every process.
#include <algorithm>
#include <numeric>
#include <random>
#include <vector>

#include <gtest/gtest.h>

#include "drtv/baker/shard.h"

namespace drtv::baker {
namespace {

std::vector<uint64_t> loads(const std::vector<uint64_t>& costs, const std::vector<int>& owner, int n) {
  std::vector<uint64_t> l(size_t(n), 0);
  for (size_t i = 0; i < costs.size(); ++i) l[size_t(owner[i])] += costs[i];
  return l;
}

TEST(ShardOwners, EverySectorHasOneShardAndTheCostliestShardIsWithinTheRulesBound) {
  std::mt19937_64 rng(7);
  for (int n : {1, 2, 3, 4, 8, 16, 100}) {
    std::vector<uint64_t> costs(256);
    // Skewed, as a world is: a few dense sectors (a town, a forest) among many cheap ones.
    for (uint64_t& c : costs) c = 1 + (rng() % 10 == 0 ? rng() % 200000 : rng() % 2000);
    const std::vector<int> owner = shardOwners(costs, n);
    ASSERT_EQ(owner.size(), costs.size());
    for (int k : owner) ASSERT_TRUE(k >= 0 && k < n) << k;
    EXPECT_EQ(shardOwners(costs, n), owner) << "the same split in every process";
    const std::vector<uint64_t> l = loads(costs, owner, n);
    const uint64_t total = std::accumulate(costs.begin(), costs.end(), uint64_t(0));
    const uint64_t largest = *std::max_element(costs.begin(), costs.end());
    // Graham's bound for list scheduling: the costliest shard is at most the mean plus one sector.
    EXPECT_LE(double(*std::max_element(l.begin(), l.end())), double(total) / n + double(largest)) << n << " shards";
    // And never worse than the round-robin split it replaced, here.
    std::vector<int> rr(costs.size());
    for (size_t i = 0; i < rr.size(); ++i) rr[i] = int(i % size_t(n));
    const std::vector<uint64_t> r = loads(costs, rr, n);
    EXPECT_LE(*std::max_element(l.begin(), l.end()), *std::max_element(r.begin(), r.end())) << n << " shards";
  }
}

TEST(ShardOwners, ACostlySectorHasAShardToItselfAndTiesGoInKeyOrderToTheLowestShard) {
  EXPECT_EQ(shardOwners(std::vector<uint64_t>{1, 1, 100, 1, 1}, 2), (std::vector<int>{1, 1, 0, 1, 1}));
  // Equal costs: sector 0 to shard 0, 1 to 1, 2 to 2, then 3 to the least loaded, 0.
  EXPECT_EQ(shardOwners(std::vector<uint64_t>{5, 5, 5, 5}, 3), (std::vector<int>{0, 1, 2, 0}));
  EXPECT_EQ(shardOwners(std::vector<uint64_t>{3, 9}, 1), (std::vector<int>{0, 0}));
  EXPECT_TRUE(shardOwners(std::vector<uint64_t>{}, 4).empty());
  // More shards than sectors: one sector each at most.
  EXPECT_EQ(shardOwners(std::vector<uint64_t>{2, 7}, 5), (std::vector<int>{1, 0}));
}

}  // namespace
}  // namespace drtv::baker
