// A query client: asks densemap-server the occupancy of two points and the map's statistics.
//   example-query [DOMAIN]   (with densemap-server --domain DOMAIN --loopback running)
#include <cstdio>
#include <string>

#include "densemap/client/query_client.h"

int main(int argc, char** argv) {
  using namespace densemap;
  msg::DdsOptions dds;
  dds.domain = argc > 1 ? std::stoi(argv[1]) : 0;
  dds.loopback = true;
  msg::DdsNode node(dds);
  client::QueryClient query(node, "example-query");  // the id names this client's reply topic
  if (!query.waitForServer(std::chrono::seconds(30))) return std::puts("no densemap-server matched"), 1;
  msg::QueryRequest points;
  points.kind(msg::QUERY_POINTS);
  points.points({6.f, 0.f, 0.5f, 1.f, 0.f, 1.5f});  // x y z of each point, world frame
  const msg::QueryReply answer = query.call(points);
  for (std::size_t i = 0; i < answer.probabilities().size(); ++i)
    std::printf("point %zu: P(occupied) = %.3f\n", i, answer.probabilities()[i]);
  msg::QueryRequest stats;
  stats.kind(msg::QUERY_STATS);
  const msg::QueryReply s = query.call(stats);
  std::printf("map version %llu, %llu known cells\n", static_cast<unsigned long long>(s.map_version()),
              static_cast<unsigned long long>(s.stats().known_cells()));
  return answer.status() == msg::STATUS_OK ? 0 : 1;
}
