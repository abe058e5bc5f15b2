#include "pl/eval/timing.hpp"

#include <algorithm>
#include <cstdio>

#include "pl/common/error.hpp"
#include "pl/common/stats.hpp"
#include "pl/common/text.hpp"

namespace pl::eval {

namespace {

// Comma-separated fields, empty ones kept (so columns do not shift), trimmed, with one level of
// surrounding double quotes removed. Quoted commas are not supported (timing logs have none).
std::vector<std::string> split_csv(const std::string& line) {
  std::vector<std::string> out;
  std::size_t start = 0;
  while (true) {
    std::size_t comma = line.find(',', start);
    std::string f = line.substr(start, comma == std::string::npos ? std::string::npos : comma - start);
    const std::size_t b = f.find_first_not_of(" \t\r");
    const std::size_t e = f.find_last_not_of(" \t\r");
    f = b == std::string::npos ? std::string() : f.substr(b, e - b + 1);
    if (f.size() >= 2 && f.front() == '"' && f.back() == '"') f = f.substr(1, f.size() - 2);
    out.push_back(f);
    if (comma == std::string::npos) break;
    start = comma + 1;
  }
  return out;
}

bool ends_with(const std::string& s, const std::string& suffix) {
  return s.size() >= suffix.size() && s.compare(s.size() - suffix.size(), suffix.size(), suffix) == 0;
}

std::string join(const std::vector<std::string>& v) {
  std::string out;
  for (const auto& s : v) out += (out.empty() ? "" : ", ") + s;
  return out;
}

}  // namespace

TimingColumn read_timing_csv(const std::string& path, const std::optional<std::string>& column) {
  LineReader reader(path);
  std::string line;
  if (!reader.next(line)) throw Error(path + ": empty file (expected a CSV header line, e.g. scan,registration_ms)");
  TimingColumn out;
  out.all_columns = split_csv(line);
  const auto& cols = out.all_columns;

  std::size_t index = cols.size();
  if (column) {
    index = static_cast<std::size_t>(std::find(cols.begin(), cols.end(), *column) - cols.begin());
    if (index == cols.size())
      throw Error(path + ": no column named \"" + *column + "\"; the columns are: " + join(cols));
  } else {
    index = static_cast<std::size_t>(std::find(cols.begin(), cols.end(), "registration_ms") - cols.begin());
    if (index == cols.size()) {
      std::vector<std::size_t> ms;
      for (std::size_t i = 0; i < cols.size(); ++i)
        if (ends_with(cols[i], "_ms")) ms.push_back(i);
      if (ms.size() != 1)
        throw Error(path + ": " +
                    (ms.empty() ? std::string("no column is named registration_ms or ends in _ms")
                                : std::string("no column is named registration_ms and several end in _ms")) +
                    "; pick one with --column NAME (columns: " + join(cols) + ")");
      index = ms.front();
    }
  }
  out.name = cols[index];

  while (reader.next(line)) {
    const auto fields = split_csv(line);
    if (fields.size() != cols.size())
      reader.fail(std::to_string(cols.size()) + " comma-separated fields like the header (" + join(cols) + ")", line);
    double v = 0.0;
    if (!parse_double(fields[index], v))
      reader.fail("a number in column \"" + out.name + "\" (field " + std::to_string(index + 1) + ")", line);
    out.values.push_back(v);
  }
  if (out.values.empty()) throw Error(path + ": no data rows under the header");
  return out;
}

TimingStats timing_stats(const std::vector<double>& values) {
  const Summary s = summarize(values);
  TimingStats t;
  t.count = s.count;
  t.min = s.min;
  t.mean = s.mean;
  t.p50 = percentile(values, 50);
  t.p90 = percentile(values, 90);
  t.p99 = percentile(values, 99);
  t.max = s.max;
  return t;
}

std::string text_histogram(const Histogram& h, std::size_t width, int decimals) {
  std::size_t top = 0;
  for (std::size_t c : h.counts) top = std::max(top, c);
  std::vector<std::string> lo(h.counts.size()), hi(h.counts.size());
  std::size_t lw = 0, hw = 0;
  char buf[64];
  for (std::size_t i = 0; i < h.counts.size(); ++i) {
    std::snprintf(buf, sizeof buf, "%.*f", decimals, h.edge(i));
    lo[i] = buf;
    std::snprintf(buf, sizeof buf, "%.*f", decimals, i + 1 == h.counts.size() ? h.hi : h.edge(i + 1));
    hi[i] = buf;
    lw = std::max(lw, lo[i].size());
    hw = std::max(hw, hi[i].size());
  }
  std::string out;
  for (std::size_t i = 0; i < h.counts.size(); ++i) {
    const bool last = i + 1 == h.counts.size();
    std::size_t bar = top == 0 ? 0 : (h.counts[i] * width + top / 2) / top;
    if (bar == 0 && h.counts[i] > 0) bar = 1;  // a non-empty bin always shows
    std::snprintf(buf, sizeof buf, "%7zu ", h.counts[i]);
    out += "[" + std::string(lw - lo[i].size(), ' ') + lo[i] + ", " + std::string(hw - hi[i].size(), ' ') + hi[i] +
           (last ? "] " : ") ") + buf + std::string(bar, '#') + "\n";
  }
  return out;
}

}  // namespace pl::eval
