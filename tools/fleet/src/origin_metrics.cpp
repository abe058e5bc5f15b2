// Origins: pl_requests_total by route, before and after.
#include "origin_metrics.hpp"

#include <algorithm>
#include <cstdlib>
#include <sstream>

#include "pl/common/error.hpp"
#include "pl/schema/http_client.hpp"
#include "url.hpp"

namespace pl::fleet {

Counters scrape(const std::string& url, const FleetOptions& o) {
  const Url u = parse_url(url, "origin_metrics");
  api::HttpOptions ho;
  ho.timeout_s = std::max(o.timeout_s, 5.0);
  ho.insecure_http = true;
  api::HttpClient c(url, ho);
  const api::HttpResponse r = c.get(u.path.empty() ? "/metrics" : u.path);
  if (r.status != 200) throw Error(url + " answered HTTP " + std::to_string(r.status));
  Counters out;
  std::istringstream in(r.body);
  std::string line;
  while (std::getline(in, line)) {
    if (line.rfind("pl_requests_total{", 0) != 0) continue;
    auto field = [&](const std::string& name) {
      const auto at = line.find(name + "=\"");
      if (at == std::string::npos) return std::string();
      const auto from = at + name.size() + 2;
      return line.substr(from, line.find('"', from) - from);
    };
    const auto sp = line.rfind(' ');
    if (sp == std::string::npos) continue;
    out[{field("route"), field("status")}] += std::strtod(line.c_str() + sp + 1, nullptr);
  }
  return out;
}

OriginCounts origin_delta(const std::string& url, const Counters& before, const Counters& after) {
  OriginCounts oc;
  oc.url = url;
  oc.ok = true;
  for (const auto& [key, n] : after) {
    auto b = before.find(key);
    const double d = n - (b == before.end() ? 0.0 : b->second);
    if (d < 0) {
      oc.ok = false;
      oc.error = "pl_requests_total went down (the replica restarted during the run): its counts are left out";
      return oc;
    }
    const std::string& route = key.first;
    if (route == "/metrics" || route == "/healthz" || route == "/readyz") continue;
    if (route == "/v1/blobs/{hash}" || route == "/v1/maps/{map}/versions/{v}/tiles/{tx}/{ty}")
      oc.tiles += d;
    else if (route == "/v1/maps/{map}/roi")
      oc.roi += d;
    else if (route == "/v1/maps/{map}" || route == "/v1/maps/{map}/versions/{v}/manifest")
      oc.manifests += d;
    else
      oc.other += d;
    if (!key.second.empty() && key.second[0] == '5') oc.errors_5xx += d;
  }
  return oc;
}

}  // namespace pl::fleet
